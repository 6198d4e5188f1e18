#include "apps/demo/demo_reprojection.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <optional>

#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "reproject/shading_cache.h"
#include "run/extrapolate.h"

namespace afterimage {

namespace {

struct CacheVariant {
  std::string label;    // row label before the cost figures
  std::string command;  // the `afterimage render` flags that reproduce it
  int light_samples = 16;
  std::optional<reproject::ShadingCacheSettings> cache;
};

struct RenderedRun {
  std::vector<Frame> frames;
  uint64_t shadow_rays = 0;
  double seconds = 0, shaded_fraction = 1;
};

RenderedRun render_run(const render::Scene& sc, int w, int h, int frames, const CacheVariant& v,
                       const Exec& ex) {
  render::RenderSettings rs;
  rs.width = w;
  rs.height = h;
  rs.soft_shadows = true;
  rs.light_samples = v.light_samples;
  rs.shading_cache = v.cache;
  rs.per_frame_light_samples = v.cache && v.cache->mode == reproject::CacheMode::Average;
  render::SceneRenderer r(sc, rs, ex);
  RenderedRun run;
  render::RenderStats st;
  double fraction = 0;
  for (int t = 0; t < frames; ++t) {
    fprintf(stderr, "\r%-40s %4d/%d", (sc.name + ": " + v.label).c_str(), t, frames);
    run.frames.push_back(r.gbuffer(t, &st));
  }
  fprintf(stderr, "\r%-40s %4d/%d\n", (sc.name + ": " + v.label).c_str(), frames, frames);
  // The first frame shades everything (no history): the cost figures are of frames 1..n-1.
  for (size_t k = 1; k < st.cache_frames.size(); ++k)
    fraction += st.cache_frames[k].counters.shaded_fraction();
  if (st.cache_frames.size() > 1) {
    run.shaded_fraction = fraction / double(st.cache_frames.size() - 1);
  } else if (frames > 1) {  // no cache: every surface pixel (the sky needs no shading)
    for (size_t k = 1; k < run.frames.size(); ++k) {
      const auto& ids = run.frames[k].id.data();
      fraction += double(std::count_if(ids.begin(), ids.end(), [](uint32_t i) { return i != 0; })) /
                  double(ids.size());
    }
    run.shaded_fraction = fraction / double(frames - 1);
  }
  run.shadow_rays = st.shadow_rays;
  run.seconds = st.seconds;
  return run;
}

}  // namespace

ShadingCacheDemo evaluate_shading_cache(const std::string& scene, int width, int height, int frames,
                                        const metrics::MetricsSettings& ms, const Exec& ex) {
  const render::Scene sc = render::make_builtin_scene(scene, false);
  const std::string base =
      fmt::format("afterimage render --scene {} --size {}x{} --frames {} --soft-shadows", scene,
                  width, height, frames);
  reproject::ShadingCacheSettings reuse, no_change, average;
  no_change.change_threshold = 0.0f;
  average.mode = reproject::CacheMode::Average;
  const std::vector<CacheVariant> variants = {
      {"cache reuse", base + " --light-samples 16 --shading-cache reuse", 16, reuse},
      {"cache reuse, no change detection",
       base + " --light-samples 16 --shading-cache reuse --cache-set change_threshold=0", 16,
       no_change},
      {"cache average, 1 light sample", base + " --light-samples 1 --shading-cache average", 1,
       average},
      {"no cache, 1 light sample", base + " --light-samples 1", 1, std::nullopt},
  };
  const RenderedRun full =
      render_run(sc, width, height, frames, {"full shading", "", 16, std::nullopt}, ex);
  ShadingCacheDemo demo;
  demo.full_ms_per_frame = 1e3 * full.seconds / frames;
  for (const CacheVariant& v : variants) {
    const RenderedRun run = render_run(sc, width, height, frames, v, ex);
    const std::string label = fmt::format(
        "{}: {:.0f}% px, {:.0f}% rays", v.label, 100.0 * run.shaded_fraction,
        100.0 * double(run.shadow_rays) / double(std::max<uint64_t>(full.shadow_rays, 1)));
    MethodEvaluator ev(label, ms, ex);
    for (int t = 0; t < frames; ++t)
      ev.add(run.frames[size_t(t)].color, full.frames[size_t(t)].color, &full.frames[size_t(t)]);
    demo.rows.push_back(ev.finish(run.frames.back().color, v.command, 1e3 * run.seconds / frames));
  }
  demo.description = fmt::format(
      "Reverse reprojection shading cache (seed 004; Nehab et al. 2007): every row scored "
      "against shading every pixel every frame with 16 light samples (soft shadows), which "
      "costs {:.1f} ms/frame here. px = pixels shaded per frame after the first, rays = shadow "
      "rays traced, both relative to full shading; ms/frame is the whole G-buffer frame.",
      demo.full_ms_per_frame);
  return demo;
}

ExtrapolationDemo evaluate_extrapolation(const std::string& scene, int width, int height,
                                         int frames, const metrics::MetricsSettings& ms,
                                         const Exec& ex) {
  const render::Scene sc = render::make_builtin_scene(scene, false);
  render::RenderSettings rs;
  rs.width = width;
  rs.height = height;
  rs.jitter = parse_jitter("none");
  rs.motion_next = true;
  std::vector<Frame> truth;
  render::render_sequence(sc, frames, {{"gbuffer", 0}}, rs, ex,
                          [&](int, size_t, Frame&& f) { truth.push_back(std::move(f)); });
  const std::string render_cmd = fmt::format(
      "afterimage render --scene {} --size {}x{} --frames {} --jitter none --motion-next --out IN",
      scene, width, height, frames);
  ExtrapolationDemo demo;
  // Scores frames 1, 3, 5, ... (the synthesised ones) against the rendered frames.
  auto score = [&](const std::string& label, const std::string& command, double ms_per_frame,
                   const std::function<const ImageF&(size_t)>& output) {
    MethodEvaluator ev(label, ms, ex);
    size_t last = 1;
    for (size_t k = 1; k < truth.size(); k += 2) {
      ev.add(output(k), truth[k].color, &truth[k]);
      last = k;
    }
    demo.rows.push_back(ev.finish(output(last), command, ms_per_frame));
  };
  score("repeat last frame", "(show frame k-1 again)", -1,
        [&](size_t k) -> const ImageF& { return truth[k - 1].color; });
  struct Variant {
    bool interpolate;
    reproject::HoleFill fill;
  };
  std::vector<Variant> variants;
  for (const auto& f : reproject::hole_fills()) variants.push_back({false, f.fill});
  variants.push_back({true, reproject::FillSettings{}.fill});
  for (const Variant& v : variants) {
    ExtrapolateSettings st;
    st.skip = 1;
    st.interpolate = v.interpolate;
    st.fill.fill = v.fill;
    const auto t0 = std::chrono::steady_clock::now();
    const ExtrapolationResult r = extrapolate_sequence(truth, st, ex);
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    double holes = 0;
    size_t n = 0;
    for (size_t k = 0; k < r.color.size(); ++k)
      if (r.synthesized[k]) holes += r.reports[k].hole_fraction, ++n;
    const std::string fill = reproject::hole_fill_name(v.fill);
    score(fmt::format("{} {}: {:.2f}% holes", v.interpolate ? "interpolate" : "extrapolate", fill,
                      100.0 * holes / double(std::max<size_t>(n, 1))),
          fmt::format("afterimage extrapolate --in IN --out OUT --skip 1{} --fill {}",
                      v.interpolate ? " --interpolate" : "", fill),
          1e3 * secs / double(std::max<size_t>(n, 1)),
          [&](size_t k) -> const ImageF& { return r.color[k]; });
  }
  demo.description = fmt::format(
      "Forward reprojection (seed 004): every odd frame synthesised from the rendered even "
      "frames and the odd frame's camera, scored against the frame the renderer really drew "
      "(no jitter, 1 sample per pixel; input: `{}`). holes = pixels no source sample landed "
      "in, before the fill; interpolation splats both neighbours.",
      render_cmd);
  return demo;
}

}  // namespace afterimage
