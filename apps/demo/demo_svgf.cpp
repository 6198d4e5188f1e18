#include "apps/demo/demo_svgf.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>

#include "metrics/temporal.h"
#include "peers/opencv_nlm.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "run/methods.h"
#include "run/post_pipeline.h"
#include "run/sequence.h"

namespace afterimage {

namespace {

// Spatial-only SVGF: every frame filtered alone (alpha 1: no history is blended in; the
// variance always from the spatial estimate).
constexpr const char* kSpatialOnly =
    "svgf:afterimage+alpha_min=1+moments_alpha_min=1+temporal_variance_frames=1024";

MethodEvaluation run_method(const std::string& label, SequenceMethod& m,
                            const std::vector<Frame>& noisy, const std::vector<ImageF>& refs,
                            const metrics::MetricsSettings& ms, const std::string& command,
                            const Exec& ex, std::vector<double>* errors = nullptr) {
  MethodEvaluator ev(label, ms, ex);
  ImageF last;
  const SequenceRunStats st = run_sequence(m, noisy, [&](size_t t, Frame&& out) {
    ev.add(out.color, refs[t], &noisy[t]);
    if (errors) errors->push_back(metrics::display_error_frame(out.color, refs[t], ms.display, ex));
    last = out.color;
  });
  return ev.finish(last, command, 1e3 * st.process_seconds / double(noisy.size()));
}

// First frame in [1, frames) at which the set of lights that are on differs from the frame
// before (room_light: the lamp switching on at frame 6), or -1.
int first_light_switch(const render::Scene& sc, int frames) {
  for (int t = 1; t < frames; ++t)
    for (const render::Light& l : sc.lights)
      if (l.blink.on(sc.eval_time(t)) != l.blink.on(sc.eval_time(t - 1))) return t;
  return -1;
}

}  // namespace

DenoiseDemo evaluate_denoise(const std::string& scene, int width, int height, int frames,
                             int reference_spp, const metrics::MetricsSettings& ms,
                             const Exec& ex) {
  const render::Scene sc = render::make_builtin_scene(scene, false);
  render::RenderSettings rs;
  rs.width = width;
  rs.height = height;
  rs.path_trace = render::PathTraceSettings{};
  render::SceneRenderer r(sc, rs, ex);
  std::vector<Frame> noisy;
  std::vector<ImageF> refs;
  for (int t = 0; t < frames; ++t) {
    std::fprintf(stderr, "\r%-40s %4d/%d", (scene + ": path-traced references").c_str(), t, frames);
    noisy.push_back(r.gbuffer(t));
    refs.push_back(r.reference(t, reference_spp).color);
  }
  std::fprintf(stderr, "\r%-40s %4d/%d\n", (scene + ": path-traced references").c_str(), frames,
               frames);
  DenoiseDemo d;
  {
    MethodEvaluator raw("1 spp input", ms, ex);
    for (int t = 0; t < frames; ++t)
      raw.add(noisy[size_t(t)].color, refs[size_t(t)], &noisy[size_t(t)]);
    d.rows.push_back(raw.finish(noisy.back().color,
                                fmt::format("afterimage render --scene {} --path-trace --size "
                                            "{}x{} --frames {} --reference {}",
                                            scene, width, height, frames, reference_spp)));
  }
  struct Row {
    std::string label, spec;
  };
  const std::string taa = "taa:" + default_variant("taa");
  for (const Row& row :
       {Row{"TAA alone", taa}, Row{"spatial a-trous only", kSpatialOnly},
        Row{"svgf-paper", "svgf:svgf-paper"}, Row{"svgf (afterimage)", "svgf:afterimage"}}) {
    auto m = make_method(row.spec, ex);
    d.rows.push_back(
        run_method(row.label, *m, noisy, refs, ms,
                   fmt::format("afterimage run --in DIR --out OUT --pipeline {}", row.spec), ex));
  }
  std::vector<double> plain_errors, asvgf_errors;
  {
    auto m = make_pipeline_method(parse_pipeline("svgf,taa", {}), ex);
    d.rows.push_back(run_method("svgf + TAA (denoise, frames without gradients)", *m, noisy, refs,
                                ms, "afterimage denoise --in DIR --out OUT", ex, &plain_errors));
  }
  {
    // A-SVGF (Schied et al. 2018): the same scene rendered with gradient samples (render
    // --gradients: one sample per 3x3 stratum re-traced, the color unchanged), denoised
    // by the default (the afterimage preset uses the gradients) and TAA.
    render::RenderSettings gs = rs;
    gs.gradients = true;
    render::SceneRenderer gr(sc, gs, ex);
    std::vector<Frame> grad;
    for (int t = 0; t < frames; ++t) grad.push_back(gr.gbuffer(t));
    auto m = make_pipeline_method(parse_pipeline("svgf,taa", {}), ex);
    d.rows.push_back(run_method("A-SVGF + TAA (denoise, --gradients frames)", *m, grad, refs, ms,
                                "afterimage render ... --gradients; afterimage denoise --in DIR "
                                "--out OUT",
                                ex, &asvgf_errors));
  }
  {
    // OpenCV's multi-frame NLM with its temporal window of 5; h (8-bit units) the best of a
    // few by mean PSNR against the references — the peer is tuned on the very frames it is
    // scored on, which favours it.
    std::vector<ImageF> colors;
    for (const Frame& f : noisy) colors.push_back(f.color);
    std::optional<MethodEvaluation> best;
    for (float h : {6.0f, 12.0f, 20.0f, 30.0f}) {
      peers::NlmSettings ns;
      ns.h = ns.h_color = h;
      MethodEvaluator ev(fmt::format("OpenCV NLM (h {:g})", h), ms, ex);
      ImageF last;
      double seconds = 0;
      for (size_t t = 0; t < colors.size(); ++t) {
        const auto t0 = std::chrono::steady_clock::now();
        last = peers::opencv_nlm_frame(colors, t, ns, ex);
        seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        ev.add(last, refs[t], &noisy[t]);
      }
      MethodEvaluation e =
          ev.finish(last, fmt::format("cv::fastNlMeansDenoisingColoredMulti, window 5, h {:g}", h),
                    1e3 * seconds / double(colors.size()));
      if (!best || e.metrics.summary.psnr > best->metrics.summary.psnr) best = std::move(e);
    }
    d.rows.push_back(std::move(*best));
  }
  d.description = fmt::format(
      "{} path-traced at 1 sample per pixel per frame (next-event estimation with MIS, 4 "
      "bounces), denoised, and scored against references path-traced with {} samples per pixel "
      "at the same times.",
      scene, reference_spp);
  const int step = first_light_switch(sc, frames);
  if (step > 0 && step + 8 <= frames) {
    // metrics/temporal.h lag_frames: frames after the switch until the display error is within
    // 1.2x the mean of the last 4 frames (at least 4 frames after the switch before those).
    d.lag_step = step;
    d.lag_svgf = metrics::lag_frames(plain_errors, step);
    d.lag_asvgf = metrics::lag_frames(asvgf_errors, step);
    d.description += fmt::format(
        " Lag after the light switch at frame {} (frames until the display error is within 1.2x "
        "its mean over the last 4 frames): svgf + TAA {}, A-SVGF + TAA {}.",
        step, d.lag_svgf, d.lag_asvgf);
  }
  return d;
}

}  // namespace afterimage
