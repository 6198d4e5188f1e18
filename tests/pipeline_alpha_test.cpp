// Coverage alpha through the temporal methods and the post chain (run/alpha.h, DESIGN.md
// §3 "Alpha"). Truths: a linear filter whose weights come from the G-buffer gives, for a color
// c * alpha (c constant), exactly c times the filtered alpha; a temporal method's alpha twin
// fed frames whose color is the alpha is the method itself (the same bits); an opaque alpha
// stays exactly 1; state files continue the alpha bit for bit.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "run/alpha.h"
#include "run/methods.h"
#include "run/post_pipeline.h"
#include "test_util.h"

namespace afterimage {
namespace {

// Frames of a built-in scene with a coverage alpha: 1, 0.75, 0.5 or 0.25 by object, a fractional
// pattern on the background (so a filter's taps meet different alphas), and the
// color premultiplied: c * alpha, or the alpha itself in all three planes (c = 1); albedo grey.
std::vector<Frame> frames_with_alpha(const std::string& scene, int n, int w, int h,
                                     const float (&c)[3], bool opaque = false) {
  const render::Scene sc = render::make_builtin_scene(scene);
  render::RenderSettings rs;
  rs.width = w;
  rs.height = h;
  std::vector<Frame> out;
  for (int t = 0; t < n; ++t) {
    Frame f = render::render_gbuffer(sc, t, rs, Exec{});
    f.allocate_channel(Channel::alpha);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const uint32_t id = f.id.at(x, y, 0);
        const float a = opaque    ? 1.0f
                        : id != 0 ? 1.0f - 0.25f * float(id % 4)
                                  : 0.125f * float((x + 2 * y + t) % 9);
        f.alpha.at(x, y, 0) = a;
        for (int p = 0; p < 3; ++p) f.color.at(x, y, p) = c[p] * a;
        // A grey albedo: SVGF's demodulation then keeps the three planes equal, so a chain's
        // second method sees the alpha's planes as its twin does.
        const float g = f.albedo.at(x, y, 1);
        for (int p = 0; p < 3; ++p) f.albedo.at(x, y, p) = g;
      }
    out.push_back(std::move(f));
  }
  return out;
}

ImageF plane0(const ImageF& color) {
  return alpha_of_color(color);
}

// dof and motion_blur weigh taps by depth, CoC and velocity only: the alpha through their twins
// makes out.color = c * out.alpha to rounding. bloom, flare, tonemap and sharpen leave it as is.
TEST(PipelineAlpha, DofAndMotionBlurFilterAlphaWithTheColorsWeights) {
  const float c[3] = {0.3f, 0.6f, 0.9f};
  // (The box of `motion` moves ~3 px a frame at 640x360: enough for a blur past the early exit.)
  for (const auto& [scene, stages, w, h] :
       {std::tuple{"focus", "dof", 320, 180}, std::tuple{"motion", "motion_blur", 640, 360},
        std::tuple{"focus", "dof,motion_blur", 320, 180}}) {
    SCOPED_TRACE(std::string(scene) + " " + stages);
    const std::vector<Frame> frames = frames_with_alpha(scene, 3, w, h, c);
    auto m = make_pipeline_method(parse_pipeline(stages, {}), {});
    for (const Frame& f : frames) {
      const Frame out = m->process(f);
      ASSERT_TRUE(out.has(Channel::alpha));
      size_t moved = 0, worst = 0;
      double err = 0;
      for (int y = 0; y < f.height; ++y)
        for (int x = 0; x < f.width; ++x) {
          const float a = out.alpha.at(x, y, 0);
          moved += a != f.alpha.at(x, y, 0);
          for (int p = 0; p < 3; ++p) {
            const double e = std::abs(double(out.color.at(x, y, p)) - double(c[p]) * a);
            if (e > err) err = e, worst = size_t(y) * size_t(f.width) + size_t(x);
          }
        }
      EXPECT_LT(err, 2e-6) << "at pixel " << worst;
      if (f.index > 0) {
        EXPECT_GT(moved, 20u);  // the blur reached the alpha's edges
      }
    }
  }
  // Light added and per-pixel display steps: the alpha is the input's, bit for bit.
  const std::vector<Frame> frames = frames_with_alpha("focus", 2, 64, 36, c);
  auto m = make_pipeline_method(parse_pipeline("bloom,flare,tonemap,sharpen", {}), {});
  for (const Frame& f : frames) EXPECT_EQ(m->process(f).alpha, f.alpha);
}

std::vector<std::string> temporal_specs() {
  return {"taa:" + default_variant("taa"), "taau:" + default_variant("taau"),
          "svgf:" + default_variant("svgf"), "svgf,taa"};
}

std::unique_ptr<SequenceMethod> make(const std::string& spec) {
  return spec.find(',') != std::string::npos ? make_pipeline_method(parse_pipeline(spec, {}), {})
                                             : make_method(spec, {});
}

// With the color equal to the alpha, the alpha's twin sees what the method sees: the same bits
// frame after frame (its history, reprojection and G-buffer are the method's own).
TEST(PipelineAlpha, TemporalTwinIsTheMethodOnTheAlpha) {
  const float one[3] = {1, 1, 1};
  const std::vector<Frame> frames = frames_with_alpha("orbit", 5, 48, 27, one);
  for (const std::string& spec : temporal_specs()) {
    SCOPED_TRACE(spec);
    auto m = make(spec);
    for (const Frame& f : frames) {
      const Frame out = m->process(f);
      ASSERT_TRUE(out.has(Channel::alpha));
      EXPECT_EQ(out.alpha, plane0(out.color)) << "frame " << f.index;
    }
  }
}

// An alpha of exactly 1 gives exactly 1 (the twin is not run); a frame without alpha gives
// none; the first transparent frame after opaque ones starts the alpha's history afresh.
TEST(PipelineAlpha, OpaqueAlphaStaysOneAndTransparencyStartsAFreshHistory) {
  const float one[3] = {1, 1, 1};
  const std::vector<Frame> opaque = frames_with_alpha("orbit", 3, 48, 27, one, true);
  const std::vector<Frame> clear = frames_with_alpha("orbit", 5, 48, 27, one);
  for (const std::string& spec : temporal_specs()) {
    SCOPED_TRACE(spec);
    auto m = make(spec);
    // Transparent frames first, so that the alpha's twin has a history the opaque stretch
    // must end.
    for (int t = 0; t < 3; ++t) m->process(clear[size_t(t)]);
    for (const Frame& f : opaque) {
      const Frame out = m->process(f);
      ASSERT_TRUE(out.has(Channel::alpha));
      EXPECT_TRUE(fully_opaque(out.alpha));
    }
    Frame bare = opaque[0];
    bare.alpha = ImageF();
    EXPECT_FALSE(m->process(bare).has(Channel::alpha));
    // Frame 3 follows opaque frames: its alpha is a fresh method's first frame, not frame 2's
    // history continued.
    auto fresh = make(spec);
    EXPECT_EQ(m->process(clear[3]).alpha, fresh->process(clear[3]).alpha);
    EXPECT_EQ(m->process(clear[4]).alpha, fresh->process(clear[4]).alpha);
  }
}

// Saving after frame k and loading into a new method continues the alpha bit for bit; a save
// in an opaque stretch removes the alpha's file of an earlier save to the same path.
TEST(PipelineAlpha, StateFilesContinueTheAlpha) {
  const float c[3] = {0.5f, 0.25f, 1.0f};
  const std::vector<Frame> frames = frames_with_alpha("orbit", 5, 48, 27, c);
  const auto dir = test::fresh_temp_dir("pipeline_alpha_state");
  const std::string path = (dir / "state.bin").string();
  for (const std::string& spec : temporal_specs()) {
    SCOPED_TRACE(spec);
    auto whole = make(spec), first = make(spec), second = make(spec);
    std::vector<ImageF> want;
    for (const Frame& f : frames) want.push_back(whole->process(f).alpha);
    for (int t = 0; t < 3; ++t) first->process(frames[size_t(t)]);
    first->save_state(path);
    ASSERT_TRUE(std::filesystem::exists(path + ".alpha"));
    second->load_state(path);
    for (int t = 3; t < 5; ++t)
      EXPECT_EQ(second->process(frames[size_t(t)]).alpha, want[size_t(t)]) << "frame " << t;
    const std::vector<Frame> opaque = frames_with_alpha("orbit", 1, 48, 27, c, true);
    first->process(opaque[0]);
    first->save_state(path);
    EXPECT_FALSE(std::filesystem::exists(path + ".alpha"));
  }
  test::remove_if_passed(dir);
}

}  // namespace
}  // namespace afterimage
