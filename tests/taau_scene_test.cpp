// TAAU on the built-in scenes against native-resolution references (issue 10): at 2x it
// must beat bicubic upscaling of low-resolution TAA on every moving scene, and on a static
// scene it must converge (amortised supersampling of the finer output grid). Small sizes
// keep it fast; the numbers are printed so regressions are visible in the log.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <tuple>
#include <vector>

#include "apps/demo/demo.h"
#include "display_util.h"
#include "metrics/display.h"
#include "metrics/psnr.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "taau/resample.h"
#include "taau/settings.h"
#include "taau/upscaler.h"

using namespace afterimage;

namespace {

std::vector<ImageF> references(const std::string& scene, bool is_static, int w, int h, int frames,
                               int spp, const Exec& ex) {
  const render::Scene sc = render::make_builtin_scene(scene, is_static);
  render::RenderSettings rs;
  rs.width = w;
  rs.height = h;
  std::vector<ImageF> refs;
  render::render_sequence(sc, frames, {{"reference", spp}}, rs, ex,
                          [&](int, size_t, Frame&& f) { refs.push_back(std::move(f.color)); });
  return refs;
}

const MethodEvaluation& row(const std::vector<MethodEvaluation>& rows, const std::string& label) {
  for (const auto& r : rows)
    if (r.label == label) return r;
  ADD_FAILURE() << "no row " << label;
  return rows.front();
}

using test::display_psnr;

}  // namespace

// The test: 128x72 output, 64x36 input, 24 frames, means after frame 8.
TEST(TaauScene, BeatsBicubicUpscalingOfLowResTaaOnMovingScenes) {
  const Exec ex;
  metrics::MetricsSettings ms;
  ms.warmup = 8;
  const int w = 128, h = 72, frames = 24;
  for (const char* scene : {"thin", "motion", "orbit", "light", "blades", "sparkle", "moire", "cut",
                            "penumbra", "focus"}) {
    const LowResSequence low = render_low_res(scene, w, h, frames, 2.0f, ex);
    const std::vector<ImageF> refs = references(scene, false, w, h, frames, 16, ex);
    const auto rows =
        evaluate_upscaling(low, {}, refs, {"taau:performance"}, "taa:afterimage", ms, ex);
    const auto& base = row(rows, "TAA 1/2 + bicubic").metrics.summary;
    const auto& taau = row(rows, "TAAU performance").metrics.summary;
    std::printf("%-8s TAA 1/2 + bicubic: PSNR %.2f FLIP %.4f | TAAU 2x: PSNR %.2f FLIP %.4f\n",
                scene, base.psnr, base.flip, taau.psnr, taau.flip);
    EXPECT_GT(taau.psnr, base.psnr) << scene;
    EXPECT_LT(taau.flip, base.flip) << scene;
  }
}

// Static `thin` at 2x with an uncapped weight (a plain weighted mean of every sample): the
// output converges toward the native reference over one Halton cycle (32 phases), ending far
// above its first frame and above bicubic upscaling of the converged low-resolution TAA.
TEST(TaauScene, StaticSceneConverges) {
  const Exec ex;
  const int w = 128, h = 72, frames = 32;
  const render::Scene sc = render::make_builtin_scene("thin", true);
  render::RenderSettings rs;
  std::tie(rs.width, rs.height) = render::scaled_render_size(w, h, 2.0);
  rs.jitter.length = render::jitter_length_for_scale(2.0);
  std::vector<Frame> g;
  render::render_sequence(sc, frames, {{"gbuffer", 0}}, rs, ex,
                          [&](int, size_t, Frame&& f) { g.push_back(std::move(f)); });
  const ImageF ref = references("thin", true, w, h, 1, 64, ex).front();

  taau::TaauSettings s = taau::make_preset("performance");
  s.max_weight = 1024.0f;
  taau::Upscaler up(s, ex);
  std::vector<double> psnr;
  for (const Frame& f : g) psnr.push_back(display_psnr(ref, up.process(f)));
  std::printf("static thin 2x: TAAU PSNR frame 1 %.2f, 8 %.2f, 16 %.2f, 32 %.2f\n", psnr[0],
              psnr[7], psnr[15], psnr[31]);
  EXPECT_GT(psnr[31], psnr[0] + 3.0);
  EXPECT_GT(psnr[15], psnr[3]);
  EXPECT_GT(psnr[31], psnr[15]);
}
