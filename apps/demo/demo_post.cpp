#include "apps/demo/demo_post.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>

#include "core/error.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "run/post_pipeline.h"

namespace afterimage {

PostEffectDemo evaluate_post_effect(const std::string& section, int width, int height, int frames,
                                    int spp, const metrics::MetricsSettings& ms, const Exec& ex) {
  const size_t colon = section.find(':');
  const std::string stage_name = section.substr(0, colon);
  const std::string scene = colon == std::string::npos ? "" : section.substr(colon + 1);
  render::CameraEffects fx;
  std::string effect_flag;
  if (stage_name == "dof") {
    fx.depth_of_field = true;
    effect_flag = "--reference-dof";
  } else if (stage_name == "motion_blur") {
    fx.shutter_angle_deg = 360.0;  // a whole frame: the blur of the fast box is several px
    effect_flag = "--reference-motion-blur --shutter-angle 360";
  } else {
    throw SettingsError(
        fmt::format("demo: effect section '{}': expected dof:SCENE or motion_blur:SCENE", section));
  }
  // The pass rows: label and assignments over the stage's defaults. DoF: the gather at full
  // resolution, at half resolution (tiles of large blur only, and every blurred tile) and the
  // diffusion mode beside each other.
  struct Variant {
    std::string label;
    std::vector<std::string> sets;
    std::string run_sets;  // the same as `afterimage run` options
  };
  std::vector<Variant> variants;
  const render::Scene sc = render::make_builtin_scene(scene, false);
  if (stage_name == "dof") {
    variants = {{"dof pass", {}, ""},
                {"dof pass (half resolution)", {"resolution=half"}, " --set dof.resolution=half"},
                {"dof pass (half resolution, every blurred tile)",
                 {"resolution=half", "half_from=0"},
                 " --set dof.resolution=half --set dof.half_from=0"},
                {"dof pass (diffusion)", {"mode=diffusion"}, " --set dof.mode=diffusion"}};
    // A bladed lens: the disc gather beside the polygon (the default takes the frame's blades).
    if (sc.camera.lens.blades > 0)
      variants.insert(variants.begin() + 1,
                      {"dof pass (disc bokeh)", {"blades=0"}, " --set dof.blades=0"});
  } else {
    // 360 deg; the full path everywhere, McGuire's unmirrored weights and every sample on the
    // fast path (fast_tap_spacing=0) beside the default.
    variants = {{stage_name + " pass", {"shutter=1"}, " --set motion_blur.shutter=1"},
                {stage_name + " pass (full path only)",
                 {"shutter=1", "uniform_tolerance=0"},
                 " --set motion_blur.shutter=1 --set motion_blur.uniform_tolerance=0"},
                {stage_name + " pass (unmirrored weights)",
                 {"shutter=1", "mirror_weights=false"},
                 " --set motion_blur.shutter=1 --set motion_blur.mirror_weights=false"},
                {stage_name + " pass (all samples on the fast path)",
                 {"shutter=1", "fast_tap_spacing=0"},
                 " --set motion_blur.shutter=1 --set motion_blur.fast_tap_spacing=0"}};
  }
  const PostStageInfo* info = nullptr;
  for (const PostStageInfo& i : post_stages())
    if (i.name == stage_name) info = &i;
  AI_CHECK(info != nullptr);
  struct Row {
    std::unique_ptr<PostStage> stage;
    MethodEvaluator eval;
    ImageF last;
    double seconds = 0;
  };
  std::vector<Row> rows;
  for (const Variant& v : variants) {
    Row r{info->make(), MethodEvaluator(v.label, ms, ex), {}, 0.0};
    for (const std::string& kv : v.sets) r.stage->set(kv);
    r.stage->validate();
    rows.push_back(std::move(r));
  }

  render::RenderSettings rs;
  rs.width = width;
  rs.height = height;
  render::SceneRenderer r(sc, rs, ex);
  MethodEvaluator none(stage_name == "dof" ? "pinhole (no DoF)" : "instantaneous (no blur)", ms,
                       ex);
  ImageF last_none;
  for (int t = 0; t < frames; ++t) {
    std::fprintf(stderr, "\r%-40s %4d/%d", (scene + ": " + stage_name + " references").c_str(), t,
                 frames);
    r.set_effects({});
    const Frame plain = r.reference(t, spp);
    r.set_effects(fx);
    const Frame truth = r.reference(t, spp);
    none.add(plain.color, truth.color, &truth);
    last_none = plain.color;
    for (Row& row : rows) {
      const auto t0 = std::chrono::steady_clock::now();
      ImageF out = row.stage->process(plain, plain.color, ex);  // frames in order
      row.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      row.eval.add(out, truth.color, &truth);
      row.last = std::move(out);
    }
  }
  std::fprintf(stderr, "\r%-40s %4d/%d\n", (scene + ": " + stage_name + " references").c_str(),
               frames, frames);
  const std::string render_cmd =
      fmt::format("afterimage render --scene {} --size {}x{} --frames {} --reference {} {}", scene,
                  width, height, frames, spp, effect_flag);
  PostEffectDemo d;
  d.rows.push_back(none.finish(last_none, render_cmd));
  for (size_t i = 0; i < rows.size(); ++i)
    d.rows.push_back(rows[i].eval.finish(
        rows[i].last,
        fmt::format("afterimage run --in DIR/reference --out OUT --pipeline {}{}", stage_name,
                    variants[i].run_sets),
        1e3 * rows[i].seconds / frames));
  d.description = fmt::format(
      "{} as a post pass on the ray tracer's effect-free reference, scored against the "
      "reference rendered with the physical effect ({}; {} samples per pixel, the same seed).{}",
      stage_name, stage_name == "dof" ? "thin lens of the scene's camera" : "360-degree shutter",
      spp,
      stage_name == "dof" ? " Two modes: the scatter-as-gather pass (default) and simulated "
                            "heat diffusion (Kass, Lefohn, Owens 2006)."
                          : "");
  return d;
}

}  // namespace afterimage
