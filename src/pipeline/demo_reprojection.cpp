#include "pipeline/demo_reprojection.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <optional>

#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "reproject/shading_cache.h"

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

}  // namespace afterimage
