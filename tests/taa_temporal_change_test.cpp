// TAA reacting to the temporal_change channel (A-SVGF's lambda, issue 11; taa/settings.h
// temporal_change): the blend factor becomes alpha' = (1 - lambda) alpha + lambda (Schied et
// al. 2018 Sec. 5). Closed forms on synthetic frames, bit-identity without the channel, and
// the lag after room_light's lamp switch end to end (svgf,taa as `afterimage denoise` runs it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "lamp_switch_lag.h"
#include "metrics/temporal.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "run/methods.h"
#include "run/post_pipeline.h"
#include "svgf/denoiser.h"
#include "svgf/settings.h"
#include "taa/presets.h"
#include "taa/resolver.h"

using namespace afterimage;

namespace {

// A static frame (zero motion, flat depth) whose color is `base` plus per-pixel noise of
// amplitude `noise` (seeded), so the neighbourhood boxes have extent.
Frame noisy_frame(int w, int h, float base, float noise, unsigned seed) {
  Frame f = Frame::allocate(w, h);
  f.depth.fill(2.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) f.color.at(x, y, c) = base * (1.0f + 0.2f * c) + noise * u(rng);
  return f;
}

// lambda(x, y) = 0 left of x0, `value` from x0 on.
void set_change(Frame& f, int x0, float value) {
  f.allocate_channel(Channel::temporal_change);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) f.temporal_change.at(x, y, 0) = x >= x0 ? value : 0.0f;
}

}  // namespace

// Plain accumulation (alpha 0.1, no rectification, static): frame 1's output is frame 0's
// color moved toward frame 1's by alpha' = (1 - lambda) 0.1 + lambda, per pixel.
TEST(TaaTemporalChange, BlendFactorFollowsTheAsvgfRule) {
  taa::TaaSettings s;  // seed 000 Eq.2, alpha 0.1
  for (float lambda : {0.0f, 0.25f, 0.5f, 1.0f}) {
    taa::TemporalResolver r(s);
    const Frame f0 = noisy_frame(24, 16, 0.3f, 0.1f, 1);
    Frame f1 = noisy_frame(24, 16, 2.0f, 0.1f, 2);
    set_change(f1, 12, lambda);
    EXPECT_EQ(r.process(f0), f0.color);
    const ImageF out = r.process(f1);
    for (int c = 0; c < 3; ++c)
      for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 24; ++x) {
          const double l = x >= 12 ? lambda : 0.0;
          const double a = (1.0 - l) * 0.1 + l, h = f0.color.at(x, y, c),
                       cur = f1.color.at(x, y, c);
          ASSERT_NEAR(out.at(x, y, c), h + a * (cur - h), 2e-6) << lambda << " " << x << "," << y;
        }
  }
}

// The default preset (sample count, variance clipping): after 8 frames of a dim noisy wall,
// the wall brightens with lambda = 1 on the right half. There the output is the current
// sample exactly (up to the blend's rounding) and the sample count restarts at 1; on the left
// half the clipped history still weighs in. blend_filtered is switched off: with it an
// untrusted pixel blends its filtered color, which this test does not recompute.
TEST(TaaTemporalChange, LambdaOneGivesTheCurrentSample) {
  taa::TaaSettings s = taa::make_preset("afterimage");
  s.blend_filtered = false;
  taa::TemporalResolver r(s);
  for (int t = 0; t < 8; ++t) r.process(noisy_frame(32, 18, 0.2f, 0.05f, 10 + t));
  Frame f = noisy_frame(32, 18, 1.0f, 0.05f, 99);
  set_change(f, 16, 1.0f);
  const ImageF out = r.process(f);
  int left_differs = 0;
  for (int y = 0; y < 18; ++y)
    for (int x = 0; x < 32; ++x) {
      bool differs = false;
      for (int c = 0; c < 3; ++c) {
        const float cur = f.color.at(x, y, c), o = out.at(x, y, c);
        if (x >= 16) {
          ASSERT_NEAR(o, cur, 1e-6f * std::abs(cur) + 1e-7f) << x << "," << y;
        } else {
          differs |= std::abs(o - cur) > 1e-3f;
        }
      }
      if (x >= 16) {
        EXPECT_EQ(r.sample_count().at(x, y, 0), 1.0f);
      }
      left_differs += differs;
    }
  // Without the channel the change is only rectified: most pixels keep some history.
  EXPECT_GT(left_differs, 16 * 18 / 2);
}

// lambda = 0 everywhere, and any lambda with temporal_change = 0, are the resolve without the
// channel bit for bit (the afterimage preset over a moving scene), for 1 and 2 threads and the
// 1-lane path; a non-zero lambda changes the result, identically for every thread count.
TEST(TaaTemporalChange, ZeroLambdaIsTheResolveWithoutTheChannel) {
  const auto scene = render::make_builtin_scene("motion");
  render::RenderSettings rs;
  rs.width = 48;
  rs.height = 27;
  std::vector<Frame> plain, zero, random;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int t = 0; t < 6; ++t) {
    plain.push_back(render::render_gbuffer(scene, t, rs, {}));
    zero.push_back(plain.back());
    zero.back().allocate_channel(Channel::temporal_change);
    random.push_back(zero.back());
    for (float& v : random.back().temporal_change.data()) v = u(rng);
  }
  auto run = [](const taa::TaaSettings& s, Exec ex, const std::vector<Frame>& frames) {
    taa::TemporalResolver r(s, ex);
    std::vector<ImageF> out;
    for (const Frame& f : frames) out.push_back(r.process(f));
    out.push_back(r.sample_count());
    return out;
  };
  const taa::TaaSettings on = taa::make_preset("afterimage");
  ASSERT_GT(on.temporal_change, 0.0f);
  taa::TaaSettings off = on;
  off.temporal_change = 0.0f;
  std::vector<ImageF> changed_ref;
  for (const Exec ex : {Exec{1, true}, Exec{2, true}, Exec{2, false}}) {
    const std::vector<ImageF> ref = run(on, ex, plain);
    EXPECT_EQ(run(on, ex, zero), ref);
    EXPECT_EQ(run(off, ex, random), ref);
    EXPECT_EQ(run(off, ex, plain), ref);
    const std::vector<ImageF> changed = run(on, ex, random);
    EXPECT_NE(changed[5], ref[5]);
    if (ex.simd) {
      if (changed_ref.empty()) changed_ref = changed;
      EXPECT_EQ(changed, changed_ref);  // 1 and 2 threads
    }
  }
}

// Issue 11, end to end: room_light (lamp on at frame 6), 96x54, 20 frames, 64-spp references,
// the same gradient-sample frames through svgf,taa. The default (A-SVGF lambda reaching TAA)
// lags at most half as long as SVGF without gradients, and no longer than with TAA ignoring
// lambda (taa temporal_change=0). Measured: svgf 4, ignoring 2, default 2 (before SVGF's
// history relighting, svgf gradient_relight: ignoring 3, failing the half, default 2).
TEST(TaaTemporalChange, DenoiseDefaultLagIsAtMostHalfOfSvgf) {
  const test::LampSwitchSequence seq = test::render_lamp_switch(96, 54, 20, 64);
  const int plain = test::lamp_switch_lag(seq, "svgf:afterimage+temporal_gradient=false,taa");
  const int ignored =
      test::lamp_switch_lag(seq, "svgf:afterimage,taa:afterimage+temporal_change=0");
  const int asvgf = test::lamp_switch_lag(seq, "svgf:afterimage,taa");
  std::printf(
      "lag after the switch at frame 6: svgf %d, A-SVGF (TAA ignores lambda) %d, "
      "A-SVGF (default) %d frames\n",
      plain, ignored, asvgf);
  EXPECT_GE(plain, 2);
  EXPECT_LE(2 * asvgf, plain);
  EXPECT_LE(asvgf, ignored);
}

// SVGF writes its lambda as the temporal_change channel exactly when it computed it (the
// gradient channel present, history valid, temporal_gradient on), and the svgf,taa chain hands
// it to TAA: across the lamp switch the chain's output then differs from TAA ignoring it.
TEST(TaaTemporalChange, SvgfWritesLambdaAndTheChainPassesItOn) {
  const auto sc = render::make_builtin_scene("room_light");
  render::RenderSettings rs;
  rs.width = 32;
  rs.height = 18;
  rs.path_trace = render::PathTraceSettings{};
  rs.gradients = true;
  render::SceneRenderer r(sc, rs, {});
  // The denoiser itself (make_method wraps it to carry alpha, run/alpha.h).
  auto svgf = std::make_unique<svgf::SvgfDenoiser>(svgf::make_preset("afterimage"), Exec{},
                                                   "svgf:afterimage");
  auto plain = make_method("svgf:afterimage+temporal_gradient=false", {});
  auto chain = make_pipeline_method(parse_pipeline("svgf,taa", {}), {});
  auto ignoring =
      make_pipeline_method(parse_pipeline("svgf,taa:afterimage+temporal_change=0", {}), {});
  bool chain_differs = false;
  for (int t = 4; t < 8; ++t) {  // the lamp switches on at frame 6
    const Frame f = r.gbuffer(t);
    ASSERT_TRUE(f.has(Channel::gradient));
    const Frame out = svgf->process(f);
    EXPECT_FALSE(plain->process(f).has(Channel::temporal_change));
    EXPECT_EQ(out.has(Channel::temporal_change), t > 4) << t;  // frame 4: no history yet
    if (t > 4) {
      EXPECT_EQ(out.temporal_change, svgf->gradient_lambda());
    }
    if (t == 6) {
      float max_lambda = 0;
      for (float v : out.temporal_change.data()) max_lambda = std::max(max_lambda, v);
      EXPECT_GT(max_lambda, 0.5f);  // the switch is seen
    }
    chain_differs |= !(chain->process(f).color == ignoring->process(f).color);
  }
  EXPECT_TRUE(chain_differs);
}
