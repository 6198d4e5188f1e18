#include "apps/demo/demo_lights.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "eval/evaluate.h"
#include "metrics/display.h"
#include "post/bloom.h"
#include "post/flare.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"

namespace afterimage {

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

ImageF crop(const ImageF& img, int x0, int y0, int w, int h) {
  ImageF out(w, h, img.channels());
  for (int c = 0; c < img.channels(); ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) out.at(x, y, c) = img.at_clamped(x0 + x, y0 + y, c);
  return out;
}

}  // namespace

LightEffectsDemo evaluate_light_effects(const std::string& scene, int width, int height, int frames,
                                        int spp, const metrics::MetricsSettings& ms,
                                        const Exec& ex) {
  const render::Scene sc = render::make_builtin_scene(scene, false);
  render::RenderSettings rs;
  rs.width = width;
  rs.height = height;
  render::SceneRenderer r(sc, rs, ex);

  const post::BloomSettings bloom_s;  // the stage's defaults
  const ImageF psf = post::bloom_psf(bloom_s, ex);
  post::FlareSettings flare_s, glare_s;
  glare_s.glare_intensity = 0.05f;

  MethodEvaluator none("no bloom (the render)", ms, ex), chain("bloom (mip chain)", ms, ex);
  ImageF last_render, last_truth, last_bloom, last_flare, last_glare;
  double bloom_ms = 0, flare_ms = 0, glare_ms = 0;
  for (int t = 0; t < frames; ++t) {
    std::fprintf(stderr, "\r%-40s %4d/%d", (scene + ": light effects").c_str(), t, frames);
    const Frame f = r.reference(t, spp);
    // Glare angles need the frame's field of view: projection[1][1] = 1 / tan(vfov / 2).
    glare_s.glare_fov =
        std::clamp(float(2.0 * std::atan(1.0 / f.projection.m[1][1]) * 180.0 / kPi), 1.0f, 179.0f);
    // Truth of the bloom: the chain's scattering done exactly (FFT with its own PSF).
    const ImageF source = post::bloom_source(f.color, bloom_s, ex);
    const ImageF truth = post::bloom_composite(
        f.color, source, post::bloom_reference_fft(source, psf, ex), bloom_s, ex);
    auto t0 = std::chrono::steady_clock::now();
    ImageF bloomed = post::bloom(f.color, bloom_s, ex);
    bloom_ms += ms_since(t0);
    // As `run --pipeline bloom,flare` composes them: the flare light of the radiance entering
    // the lens (bloom's input) added to bloom's output (DESIGN.md §1).
    t0 = std::chrono::steady_clock::now();
    ImageF flared =
        post::apply_row_pass(bloomed, post::lens_flare_row_pass(f.color, flare_s, ex), ex);
    flare_ms += ms_since(t0);
    t0 = std::chrono::steady_clock::now();
    ImageF glared =
        post::apply_row_pass(bloomed, post::lens_flare_row_pass(f.color, glare_s, ex), ex);
    glare_ms += ms_since(t0);
    none.add(f.color, truth, nullptr);
    chain.add(bloomed, truth, nullptr);
    last_render = f.color;
    last_truth = truth;
    last_bloom = std::move(bloomed);
    last_flare = std::move(flared);
    last_glare = std::move(glared);
  }
  std::fprintf(stderr, "\r%-40s %4d/%d\n", (scene + ": light effects").c_str(), frames, frames);

  const std::string in = "--in DIR/reference --out OUT";
  std::vector<MethodEvaluation> scored;
  scored.push_back(none.finish(
      last_render,
      fmt::format("afterimage render --scene {} --size {}x{} --frames {} --reference {}", scene,
                  width, height, frames, spp)));
  scored.push_back(chain.finish(last_bloom, fmt::format("afterimage run {} --pipeline bloom", in),
                                bloom_ms / frames));
  // Flare and glare: no reference, so no metrics (NaN: dashes in the report, null in JSON).
  auto shown = [](std::string label, std::string command, double ms, ImageF last) {
    MethodEvaluation e;
    e.label = std::move(label);
    e.command = std::move(command);
    e.ms_per_frame = ms;
    e.last_output = std::move(last);
    auto& m = e.metrics.summary;
    m.psnr = m.psnr_luma = m.psnr_linear = m.ssim = m.ssim_luma = m.flip = m.sharpness =
        m.temporal_error = std::nan("");
    return e;
  };
  std::vector<MethodEvaluation> rows = scored;
  rows.push_back(shown("bloom + flare (no reference)",
                       fmt::format("afterimage run {} --pipeline bloom,flare", in),
                       flare_ms / frames, last_flare));
  rows.push_back(
      shown("bloom + flare + glare (no reference)",
            fmt::format("afterimage run {} --pipeline bloom,flare --set flare.glare_intensity=0.05 "
                        "--set flare.glare_fov={:g}",
                        in, glare_s.glare_fov),
            glare_ms / frames, last_glare));

  LightEffectsDemo d;
  d.section.name = fmt::format("{} bloom, lens flare and glare ({}x{}, {} frames)", scene, width,
                               height, frames);
  d.section.description = fmt::format(
      "Post passes on the ray tracer's reference ({} samples per pixel). Bloom (default "
      "settings) is scored against its exact counterpart, the same scattering by FFT "
      "convolution with the chain's point-spread function; 'no bloom' is the error of leaving it "
      "out. Lens flare (King's sprites, Chapman's ghosts and halo, streaks) and the eye's glare "
      "(Spencer et al. 1995: lenticular halo and ciliary corona) have no physical reference here "
      "(no lens elements or eye in the ray tracer): their rows give only the cost of the flare "
      "pass alone (ms/frame) and the figures show the images.",
      spp);
  for (const auto& e : rows) d.section.methods.push_back(to_summary(e));
  Figure full;
  full.title = "Last frame (display: the metrics' tonemap)";
  for (const auto& [caption, img] :
       std::vector<std::pair<std::string, const ImageF*>>{{"render", &last_render},
                                                          {"bloom FFT reference", &last_truth},
                                                          {"bloom (mip chain)", &last_bloom},
                                                          {"bloom + flare", &last_flare},
                                                          {"bloom + flare + glare", &last_glare}})
    full.panels.push_back({caption, metrics::to_display(*img, ms.display, ex)});
  d.section.figures.push_back(std::move(full));
  // Around the brightest light of the last frame, where the glare's halo and corona are.
  const auto lights = post::detect_bright_lights(last_render, flare_s.threshold, 1, ex);
  if (!lights.empty()) {
    const int cw = std::max(16, std::min(width, height) / 2);
    const int x0 = std::clamp(int(lights[0].position.x) - cw / 2, 0, std::max(0, width - cw));
    const int y0 = std::clamp(int(lights[0].position.y) - cw / 2, 0, std::max(0, height - cw));
    Figure zoom;
    zoom.title = fmt::format("Around the brightest light ({}x{} at x={}, y={})", cw, cw, x0, y0);
    for (const auto& [caption, img] :
         std::vector<std::pair<std::string, const ImageF*>>{{"render", &last_render},
                                                            {"bloom + flare", &last_flare},
                                                            {"bloom + flare + glare", &last_glare}})
      zoom.panels.push_back(
          {caption, crop(metrics::to_display(*img, ms.display, ex), x0, y0, cw, cw)});
    d.section.figures.push_back(std::move(zoom));
  }
  for (Figure& fig : make_figures(scored, last_truth, ms.display, 1, ex))
    d.section.figures.push_back(std::move(fig));

  d.json = eval_to_json(rows, ms);
  d.table = format_eval_table(rows);
  return d;
}

}  // namespace afterimage
