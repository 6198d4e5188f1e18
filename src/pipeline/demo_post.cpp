#include "pipeline/demo_post.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>

#include "core/error.h"
#include "pipeline/post_pipeline.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"

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
  std::unique_ptr<PostStage> stage;
  for (const PostStageInfo& info : post_stages())
    if (info.name == stage_name) stage = info.make();
  AI_CHECK(stage != nullptr);
  if (stage_name == "motion_blur") stage->set("shutter=1");  // the same 360 degrees

  const render::Scene sc = render::make_builtin_scene(scene, false);
  render::RenderSettings rs;
  rs.width = width;
  rs.height = height;
  render::SceneRenderer r(sc, rs, ex);
  MethodEvaluator none(stage_name == "dof" ? "pinhole (no DoF)" : "instantaneous (no blur)", ms,
                       ex);
  MethodEvaluator pass(stage_name + " pass", ms, ex);
  ImageF last_none, last_pass;
  double seconds = 0;
  for (int t = 0; t < frames; ++t) {
    std::fprintf(stderr, "\r%-40s %4d/%d", (scene + ": " + stage_name + " references").c_str(), t,
                 frames);
    r.set_effects({});
    const Frame plain = r.reference(t, spp);
    r.set_effects(fx);
    const Frame truth = r.reference(t, spp);
    const auto t0 = std::chrono::steady_clock::now();
    ImageF out = stage->apply(plain, plain.color, ex);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    none.add(plain.color, truth.color, &truth);
    pass.add(out, truth.color, &truth);
    last_none = plain.color;
    last_pass = std::move(out);
  }
  std::fprintf(stderr, "\r%-40s %4d/%d\n", (scene + ": " + stage_name + " references").c_str(),
               frames, frames);
  const std::string render_cmd =
      fmt::format("afterimage render --scene {} --size {}x{} --frames {} --reference {} {}", scene,
                  width, height, frames, spp, effect_flag);
  PostEffectDemo d;
  d.rows.push_back(none.finish(last_none, render_cmd));
  d.rows.push_back(pass.finish(
      last_pass,
      fmt::format("afterimage run --in DIR/reference --out OUT --pipeline {}", stage_name),
      1e3 * seconds / frames));
  d.description = fmt::format(
      "{} as a post pass on the ray tracer's effect-free reference, scored against the "
      "reference rendered with the physical effect ({}; {} samples per pixel, the same seed).",
      stage_name, stage_name == "dof" ? "thin lens of the scene's camera" : "360-degree shutter",
      spp);
  return d;
}

}  // namespace afterimage
