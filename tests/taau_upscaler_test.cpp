// Upscaler (taau/upscaler.h) on synthetic frames: the output grid and jitter convention, the
// motion scaling, settings, presets, sizes, state files, and bit-identical results for any
// thread count and for the 1-lane reference path. Odd sizes exercise the SIMD tails.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "apps/bench/bench_passes.h"
#include "core/error.h"
#include "render/renderer.h"
#include "taau/settings.h"
#include "taau/taau_method.h"
#include "taau/upscaler.h"
#include "test_util.h"

using namespace afterimage;
using namespace afterimage::taau;

namespace {

Exec exec(bool simd, int threads) {
  Exec e;
  e.simd = simd;
  e.threads = threads;
  return e;
}

// A frame whose color identifies the input pixel: R = i, G = j, B = 1.
Frame index_frame(int w, int h, Vec2d jitter) {
  Frame f = Frame::allocate(w, h);
  f.jitter = jitter;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.color.at(x, y, 0) = float(x);
      f.color.at(x, y, 1) = float(y);
      f.color.at(x, y, 2) = 1.0f;
    }
  return f;
}

}  // namespace

TEST(TaauSettings, EveryMemberRegisteredAndPresets) {
  EXPECT_TRUE(settings::all_members_registered<TaauSettings>());
  EXPECT_EQ(make_preset("quality").scale, 1.5f);
  EXPECT_EQ(make_preset("balanced").scale, 1.7f);
  EXPECT_EQ(make_preset("performance").scale, 2.0f);
  EXPECT_EQ(preset_names().front(), "performance");
  EXPECT_THROW(make_preset("ultra"), SettingsError);
  TaauSettings s;
  EXPECT_THROW(s.set("scale", "0.5"), SettingsError);
  EXPECT_THROW(s.set("scale", "nan"), SettingsError);
  EXPECT_THROW(s.set("scale", "inf"), SettingsError);
  EXPECT_THROW(s.set("kernel", "box"), SettingsError);
  s.output_width = 100;
  EXPECT_THROW(s.validate(), SettingsError);  // output_height missing
  s.output_height = 50;
  EXPECT_NO_THROW(s.validate());
}

TEST(TaauSettings, UpscaleArgument) {
  EXPECT_EQ(upscale_spec("quality"), "taau:quality");
  EXPECT_EQ(upscale_spec("1.8"), "taau:performance+scale=1.8");
  EXPECT_EQ(upscale_spec("320x180"), "taau:performance+output_width=320+output_height=180");
  for (const char* bad : {"0.5", "4.5", "nan", "inf", "-2", "x", "320x", "0x10", "ultra", "1.5e"})
    EXPECT_THROW(upscale_spec(bad), SettingsError) << bad;
}

TEST(TaauSettings, OutputSize) {
  TaauSettings s;
  EXPECT_EQ(s.output_size(160, 90), std::make_pair(320, 180));
  s.scale = 1.7f;
  EXPECT_EQ(s.output_size(188, 106), std::make_pair(320, 180));  // round(319.6), round(180.2)
  s.output_width = 500;
  s.output_height = 90;
  EXPECT_EQ(s.output_size(160, 90), std::make_pair(500, 90));
  s.output_width = 100;  // smaller than the input
  EXPECT_THROW(s.output_size(160, 90), InputError);
  s.output_width = 641;  // more than 4x
  EXPECT_THROW(s.output_size(160, 90), InputError);
}

// Output pixel (X, Y) of the first frame, with a narrow Gaussian, is the color of the input
// pixel whose jittered sample (i + 0.5 + jx) * 2 lies nearest to its center X + 0.5 — checked
// where that sample is clearly nearer than the next one. A wrong jitter sign or pixel-center
// offset breaks most of these pixels.
TEST(TaauUpscaler, FirstFrameTakesTheNearestSample) {
  for (Vec2d jitter : {Vec2d{0.3, -0.2}, Vec2d{-0.45, 0.4}, Vec2d{0.0, 0.0}}) {
    TaauSettings s;
    s.kernel = SplatKernel::Gaussian;
    s.gaussian_sigma = 0.1f;
    s.deringing = false;
    Upscaler u(s);
    const int w = 21, h = 13;
    const ImageF out = u.process(index_frame(w, h, jitter));
    ASSERT_EQ(out.width(), 42);
    ASSERT_EQ(out.height(), 26);
    int checked = 0;
    for (int Y = 0; Y < 26; ++Y)
      for (int X = 0; X < 42; ++X) {
        auto nearest = [](float c, double j, int n, float* margin) {
          float best = 1e9f, second = 1e9f;
          int bi = 0;
          for (int i = 0; i < n; ++i) {
            const float dd = std::abs(float((i + 0.5 + j) * 2.0) - c);
            if (dd < best) {
              second = best;
              best = dd;
              bi = i;
            } else if (dd < second) {
              second = dd;
            }
          }
          *margin = second - best;
          return bi;
        };
        float mx = 0, my = 0;
        const int i = nearest(X + 0.5f, jitter.x, w, &mx), j = nearest(Y + 0.5f, jitter.y, h, &my);
        if (mx < 0.5f || my < 0.5f) continue;
        ++checked;
        EXPECT_NEAR(out.at(X, Y, 0), float(i), 1e-3) << X << "," << Y;
        EXPECT_NEAR(out.at(X, Y, 1), float(j), 1e-3) << X << "," << Y;
      }
    EXPECT_GT(checked, 42 * 26 / 4);
  }
}

// Content panning right by 1 input pixel per frame, motion -1 input pixel (DESIGN.md §3):
// history must be read 2 output pixels to the left. With the same jitter on both frames the
// second output is the first shifted by exactly 2 output pixels.
TEST(TaauUpscaler, MotionIsScaledToOutputPixels) {
  const int w = 24, h = 10;
  auto frame = [&](int shift) {
    Frame f = Frame::allocate(w, h);
    f.jitter = {0.25, -0.125};
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int u = x - shift;
        f.color.at(x, y, 0) = float((u * 7 + y * 3) % 5);
        f.color.at(x, y, 1) = float((u * u + y) % 3);
        f.color.at(x, y, 2) = 0.5f;
        f.depth.at(x, y, 0) = 5.0f;
        f.motion.at(x, y, 0) = shift > 0 ? -1.0f : 0.0f;
      }
    return f;
  };
  TaauSettings s;
  s.rectify = taa::Rectify::None;
  s.dilation = taa::VelocityDilation::None;
  Upscaler u(s);
  const ImageF a = u.process(frame(0));
  const ImageF b = u.process(frame(1));
  for (int c = 0; c < 3; ++c)
    for (int Y = 0; Y < 2 * h; ++Y)
      for (int X = 8; X < 2 * w - 6; ++X)
        EXPECT_NEAR(b.at(X, Y, c), a.at(X - 2, Y, c), 1e-5) << X << "," << Y << " c" << c;
}

TEST(TaauUpscaler, BitIdenticalForThreadsAndSimd) {
  for (const char* preset : {"performance", "balanced"})
    for (SplatKernel kernel : {SplatKernel::Gaussian, SplatKernel::Lanczos2}) {
      TaauSettings s = make_preset(preset);
      s.kernel = kernel;
      Upscaler ref(s, exec(false, 1)), simd(s, exec(true, 1)), threads(s, exec(true, 2)),
          threads_scalar(s, exec(false, 2));
      for (int t = 0; t < 5; ++t) {
        const Frame f = synthetic_frame(67, 41, t);
        const ImageF a = ref.process(f);
        EXPECT_EQ(a, simd.process(f)) << preset << " frame " << t;
        EXPECT_EQ(a, threads.process(f)) << preset << " frame " << t;
        EXPECT_EQ(a, threads_scalar.process(f)) << preset << " frame " << t;
      }
    }
}

TEST(TaauUpscaler, NonFiniteInputNeverEntersHistory) {
  Upscaler u;
  Frame f = synthetic_frame(33, 17, 0);
  u.process(f);
  f = synthetic_frame(33, 17, 1);
  f.color.at(5, 5, 0) = std::nanf("");
  f.color.at(6, 5, 1) = INFINITY;
  f.motion.at(7, 7, 0) = std::nanf("");
  for (int t = 0; t < 3; ++t) {
    const ImageF out = u.process(f);  // a range-for over u.process(f).data() would dangle
    for (float v : out.data()) ASSERT_TRUE(std::isfinite(v));
  }
}

TEST(TaauUpscaler, StateContinuesBitIdentically) {
  const auto dir = test::fresh_temp_dir("taau_state");
  const std::string path = (dir / "taau.state").string();
  TaauSettings s = make_preset("quality");
  Upscaler a(s), b(s);
  for (int t = 0; t < 3; ++t) a.process(synthetic_frame(41, 23, t));
  a.save_state(path);
  b.load_state(path);
  for (int t = 3; t < 5; ++t) {
    const Frame f = synthetic_frame(41, 23, t);
    EXPECT_EQ(a.process(f), b.process(f)) << t;
  }
  // A state saved for another size is refused on the next frame, and a TAA state is refused.
  Upscaler c(s);
  c.load_state(path);
  EXPECT_THROW(c.process(synthetic_frame(40, 23, 5)), InputError);
  std::filesystem::resize_file(path, 40);
  Upscaler d(s);
  EXPECT_THROW(d.load_state(path), InputError);
}

// An upsampled output takes none of the input's G-buffer (frame/frame.h: other sizes are
// skipped), and the method reports its output size before processing.
TEST(TaauMethod, OutputOfAnotherSizeAdoptsNoChannels) {
  auto m = std::make_unique<TaauMethod>("taau:performance", make_preset("performance"));
  EXPECT_EQ(m->output_size(33, 17), std::make_pair(66, 34));
  EXPECT_THROW(m->output_size(0, 17), InputError);
  Frame in = synthetic_frame(33, 17, 0);
  Frame out = m->process(in);
  EXPECT_EQ(out.width, 66);
  EXPECT_EQ(out.height, 34);
  out.adopt_missing_channels(std::move(in));
  EXPECT_FALSE(out.has_depth());
  EXPECT_FALSE(out.has_motion());
  validate_frame(out, "upsampled");  // consistent sizes: writable
}

TEST(TaauRender, ScaledSizeAndJitterLength) {
  EXPECT_EQ(render::scaled_render_size(320, 180, 2.0), std::make_pair(160, 90));
  EXPECT_EQ(render::scaled_render_size(320, 180, 1.7), std::make_pair(188, 106));
  EXPECT_EQ(render::scaled_render_size(320, 180, 1.5), std::make_pair(213, 120));
  EXPECT_EQ(render::jitter_length_for_scale(1.0), 8);
  EXPECT_EQ(render::jitter_length_for_scale(1.5), 18);
  EXPECT_EQ(render::jitter_length_for_scale(1.7), 24);
  EXPECT_EQ(render::jitter_length_for_scale(2.0), 32);
  for (double bad : {0.5, 4.5, std::nan("")}) {
    EXPECT_THROW(render::scaled_render_size(320, 180, bad), SettingsError);
    EXPECT_THROW(render::jitter_length_for_scale(bad), SettingsError);
  }
}
