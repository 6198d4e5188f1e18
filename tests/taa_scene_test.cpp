// TAA on the built-in scenes of the renderer, measured against its references
// (DESIGN.md §4): convergence to supersampling on a static scene, and recovery of
// disoccluded pixels on a moving one. Small sizes keep the test fast; the numbers are
// printed so regressions are visible in the log.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "display_util.h"
#include "metrics/display.h"
#include "metrics/psnr.h"
#include "metrics/temporal.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "taa/presets.h"
#include "taa/resolver.h"

using namespace afterimage;

namespace {

using test::display_psnr;

// A built-in scene's G-buffer frames with their 16-spp references: the inputs of the
// ghosting tests (no-AA is the G-buffer's own color).
struct RenderedSequence {
  std::vector<Frame> gbuffer;
  std::vector<ImageF> reference, noaa, motions;
};
RenderedSequence render_with_references(const std::string& scene_name, int width, int height,
                                        int frames) {
  const auto scene = render::make_builtin_scene(scene_name);
  render::RenderSettings rs;
  rs.width = width;
  rs.height = height;
  RenderedSequence r;
  for (int t = 0; t < frames; ++t) {
    r.gbuffer.push_back(render::render_gbuffer(scene, t, rs, Exec{}));
    r.reference.push_back(render::render_reference(scene, t, 16, rs, Exec{}).color);
    r.noaa.push_back(r.gbuffer.back().color);
    r.motions.push_back(r.gbuffer.back().motion);
  }
  return r;
}

// A TAA preset's outputs over the frames, from a fresh resolver.
std::vector<ImageF> resolve_all(const std::string& preset, const std::vector<Frame>& frames) {
  taa::TemporalResolver r(taa::make_preset(preset), Exec{});
  std::vector<ImageF> out;
  for (const auto& f : frames) out.push_back(r.process(f));
  return out;
}

}  // namespace

// Static `thin` scene: with point-sampled history (seed 000's Load) and sample-count alpha,
// TAA is an exact box average of the jittered samples, i.e. amortised supersampling. After
// 64 frames (64 Halton positions) it must be at least as close to the 64-spp reference as
// 16x SSAA, and it must improve every frame while it accumulates the first 16 samples.
TEST(TaaScene, StaticThinConvergesToSupersampling) {
  const auto scene = render::make_builtin_scene("thin", /*is_static=*/true);
  render::RenderSettings rs;
  rs.width = 160;
  rs.height = 90;
  rs.jitter.length = 64;
  const Exec ex;
  const Frame reference = render::render_reference(scene, 0, 64, rs, ex);
  const Frame ssaa16 = render::render_reference(scene, 0, 16, rs, ex);
  const double psnr_ssaa16 = display_psnr(reference.color, ssaa16.color);

  taa::TaaSettings s = taa::make_preset("none");
  s.static_mode = true;
  s.sample_count = true;
  s.alpha_min = 0.001f;
  taa::TemporalResolver resolver(s, ex);
  std::vector<double> psnr;
  for (int t = 0; t < 64; ++t) {
    const Frame f = render::render_gbuffer(scene, t, rs, ex);
    psnr.push_back(display_psnr(reference.color, resolver.process(f)));
  }
  std::printf("thin static: no-AA %.2f dB, TAA@16 %.2f dB, TAA@64 %.2f dB, SSAA16 %.2f dB\n",
              psnr[0], psnr[15], psnr[63], psnr_ssaa16);
  std::printf("thin static: PSNR curve, frames 1..16:");
  for (int t = 0; t < 16; ++t) std::printf(" %.2f", psnr[size_t(t)]);
  std::printf("\n");
  EXPECT_GE(psnr[63], psnr_ssaa16);
  for (int t = 1; t < 16; ++t) EXPECT_GT(psnr[size_t(t)], psnr[size_t(t - 1)]) << "frame " << t;
}

// Moving `motion` scene: pixels disoccluded at frame t (G-buffer disocclusion, age 1 at t)
// are compared with the 16-spp reference at t + 4 (age 5). The default preset must be
// within 0.8x the error no-AA has on the same pixels (issue 10; measured 0.69x); without
// rectification (`none`) the ghost of the occluder is still there (2.2x).
TEST(TaaScene, MotionDisocclusionRecoversWithinFourFrames) {
  const int warmup = 4;
  const RenderedSequence seq = render_with_references("motion", 192, 108, 24);
  std::vector<metrics::Mask> masks;
  for (size_t t = 0; t < seq.gbuffer.size(); ++t) {
    const Frame& g = seq.gbuffer[t];
    masks.push_back(t == 0 ? metrics::Mask(g.width, g.height, 1, 0)
                           : metrics::disocclusion_mask(g.depth, g.id, g.motion,
                                                        seq.gbuffer[t - 1].depth,
                                                        seq.gbuffer[t - 1].id));
  }
  auto age5_error = [&](const std::vector<ImageF>& out) {
    const auto curve = metrics::ghosting_curve(out, seq.reference, masks, seq.motions, warmup);
    return curve.error[4];  // age 5: disoccluded 4 frames ago
  };
  auto run = [&](const std::string& preset) {
    return age5_error(resolve_all(preset, seq.gbuffer));
  };
  const double e_noaa = age5_error(seq.noaa);
  const double e_default = run("afterimage");
  const double e_none = run("none");
  std::printf("motion disocclusion, error at age 5: no-AA %.4f, afterimage %.4f, none %.4f\n",
              e_noaa, e_default, e_none);
  ASSERT_TRUE(std::isfinite(e_noaa));
  EXPECT_LE(e_default, 0.8 * e_noaa);
  EXPECT_GT(e_none, 1.5 * e_noaa);
}

// `cut` scene: the first frame of a shot carries camera_cut, and the resolver drops its
// history there: its output equals a fresh resolver's on that frame alone. With the flag
// cleared, the previous shot bleeds in (so the flag, not the image content, is what resets).
TEST(TaaScene, CutFrameDropsHistory) {
  const auto scene = render::make_builtin_scene("cut");
  render::RenderSettings rs;
  rs.width = 96;
  rs.height = 54;
  const Exec ex;
  std::vector<Frame> frames;
  for (int t = 0; t <= 8; ++t) frames.push_back(render::render_gbuffer(scene, t, rs, ex));
  ASSERT_TRUE(frames[8].camera_cut);
  for (int t = 0; t < 8; ++t) ASSERT_FALSE(frames[size_t(t)].camera_cut);

  const taa::TaaSettings s = taa::make_preset("afterimage");
  taa::TemporalResolver fresh(s, ex);
  const ImageF alone = fresh.process(frames[8]);
  taa::TemporalResolver through(s, ex), ignoring(s, ex);
  ImageF out, out_ignoring;
  Frame uncut = frames[8];
  uncut.camera_cut = false;
  for (int t = 0; t <= 8; ++t) {
    out = through.process(frames[size_t(t)]);
    out_ignoring = ignoring.process(t == 8 ? uncut : frames[size_t(t)]);
  }
  EXPECT_EQ(out, alone);
  const double psnr_ignoring = display_psnr(alone, out_ignoring);
  std::printf("cut: PSNR of the cut frame with history kept across the cut vs dropped: %.2f dB\n",
              psnr_ignoring);
  EXPECT_LT(psnr_ignoring, 40.0);
}

// `light` scene: the sweeping light moves the plate's shadow over the still floor while every
// motion vector is zero, so only rectification can drop the old shadow. Pixels whose
// reference changes at frame t (display luma step > 0.05: the shadow's edges arriving or
// leaving) play the disoccluded pixels of the test above; 4 frames later (age 5) the default
// must have reached the new lighting: error <= 1.2x no-AA's on the same pixels (issue 10).
// Without rectification (`none`) the old shadow is still there. Measured (2026-11-27, age 5):
// no-AA .0317, afterimage .0259 (0.82x), none .1082 (3.4x); for reference uncharted4 .0591,
// ue4 .0445, inside .0305, hdrp .0312, variance .0263.
TEST(TaaScene, MovingShadowIsReachedWithinFourFrames) {
  const int warmup = 8;
  const metrics::DisplaySettings ds;
  const RenderedSequence seq = render_with_references("light", 128, 72, 28);
  std::vector<metrics::Mask> masks;
  ImageF prev_display;
  for (size_t t = 0; t < seq.reference.size(); ++t) {
    const ImageF display = metrics::to_display(seq.reference[t], ds);
    metrics::Mask m(display.width(), display.height(), 1, 0);
    if (t > 0)
      for (int y = 0; y < display.height(); ++y)
        for (int x = 0; x < display.width(); ++x) {
          double step = 0;
          for (int c = 0; c < 3; ++c)
            step += std::abs(display.at(x, y, c) - prev_display.at(x, y, c)) / 3.0;
          m.at(x, y, 0) = step > 0.05 ? 1 : 0;
        }
    masks.push_back(std::move(m));
    prev_display = display;
  }
  for (const ImageF& mo : seq.motions)
    for (float v : mo.data()) ASSERT_EQ(v, 0.0f);  // nothing moves on screen
  auto errors = [&](const std::vector<ImageF>& out) {
    const auto curve = metrics::ghosting_curve(out, seq.reference, masks, seq.motions, warmup, ds);
    EXPECT_GE(curve.samples[4], 100u);  // pixel-frames at age 5
    return curve.error;
  };
  auto run = [&](const std::string& preset) { return errors(resolve_all(preset, seq.gbuffer)); };
  const auto e_noaa = errors(seq.noaa), e_default = run("afterimage"), e_none = run("none");
  std::printf("light: shadow error by age 1..5: no-AA");
  for (int a = 0; a < 5; ++a) std::printf(" %.4f", e_noaa[size_t(a)]);
  std::printf(" | afterimage");
  for (int a = 0; a < 5; ++a) std::printf(" %.4f", e_default[size_t(a)]);
  std::printf(" | none");
  for (int a = 0; a < 5; ++a) std::printf(" %.4f", e_none[size_t(a)]);
  std::printf("\n");
  ASSERT_TRUE(std::isfinite(e_noaa[4]) && e_noaa[4] > 0);
  EXPECT_LE(e_default[4], 1.2 * e_noaa[4]);
  EXPECT_GT(e_none[4], 1.2 * e_noaa[4]);
}
