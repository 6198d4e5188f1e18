#include <fmt/format.h>

#include "apps/cli/commands.h"
#include "apps/demo/demo.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "run/methods.h"

namespace afterimage::cli {

void add_demo_command(CLI::App& app, Context& ctx) {
  auto* sub = app.add_subcommand(
      "demo",
      "render the built-in scenes (cached), run no-AA, SSAA and every TAA preset, score them "
      "against the references; writes OUT/report.html");
  auto s = std::make_shared<DemoSettings>();
  auto size = std::make_shared<std::string>(fmt::format("{}x{}", s->width, s->height));
  sub->add_option("--out", s->out_dir, "output directory")->capture_default_str();
  sub->add_option("--size", *size, "frame size WxH")->capture_default_str();
  sub->add_option("--frames", s->frames, "frames per scene")->capture_default_str();
  sub->add_option("--scenes", s->scenes,
                  fmt::format("scenes to run (default: {}; any of: {})",
                              fmt::join(render::default_demo_scene_names(), ","),
                              fmt::join(render::builtin_scene_names(), ",")))
      ->capture_default_str()
      ->delimiter(',');
  auto presets = std::make_shared<std::vector<std::string>>();
  sub->add_option("--methods", s->methods,
                  fmt::format("methods to run, technique:variant[+key=value...] (default: {})",
                              fmt::join(default_demo_methods(), ",")))
      ->delimiter(',');
  sub->add_option("--presets", *presets,
                  "TAA presets to run, each as taa:PRESET in --methods (may carry +key=value)")
      ->delimiter(',');
  sub->add_option("--taau-scale", s->taau_scale,
                  "TAAU section: render scale per axis of its low-resolution input, in [1, 4] "
                  "(0: no TAAU section)")
      ->capture_default_str();
  sub->add_option("--taau-methods", s->taau_methods,
                  fmt::format("TAAU methods of that section (default: {})",
                              fmt::join(default_taau_demo_methods(), ",")))
      ->delimiter(',');
  sub->add_option("--reference", s->reference_spp, "reference samples per pixel")
      ->capture_default_str();
  sub->add_option("--warmup", s->warmup, "frames excluded from the means")->capture_default_str();
  sub->add_option("--warmup-reference", s->warmup_reference_spp,
                  "reference samples per pixel of the warm-up frames (only plotted, never in a "
                  "mean; square)")
      ->capture_default_str();
  sub->add_option("--cache-scenes", s->cache_scenes,
                  "shading cache section: scenes rendered with soft shadows (\"\": none)")
      ->capture_default_str()
      ->delimiter(',');
  sub->add_option("--extrapolate-scenes", s->extrapolate_scenes,
                  "forward reprojection section: scenes whose odd frames are extrapolated and "
                  "interpolated (\"\": none)")
      ->capture_default_str()
      ->delimiter(',');
  sub->add_option("--cache-frames", s->cache_frames,
                  "frames of the shading cache and forward reprojection sections")
      ->capture_default_str();
  sub->add_option("--effect-sections", s->effect_sections,
                  "camera-effect sections STAGE:SCENE, the post pass against the ray-traced "
                  "effect (\"\": none)")
      ->capture_default_str()
      ->delimiter(',');
  sub->add_option("--effect-frames", s->effect_frames, "frames of each camera-effect section")
      ->capture_default_str();
  sub->add_option("--light-sections", s->light_scenes,
                  "light-effects sections: bloom against its FFT reference, lens flare and glare "
                  "on these scenes (\"\": none)")
      ->capture_default_str()
      ->delimiter(',');
  sub->add_option("--light-frames", s->light_frames, "frames of each light-effects section")
      ->capture_default_str();
  sub->add_option("--denoise-scenes", s->denoise_scenes,
                  "denoising sections: path-traced scenes denoised by SVGF, TAA, spatial-only and "
                  "OpenCV NLM against converged references (\"\": none)")
      ->capture_default_str()
      ->delimiter(',');
  sub->add_option("--denoise-frames", s->denoise_frames, "frames of each denoising section")
      ->capture_default_str();
  sub->add_option("--denoise-spp", s->denoise_spp,
                  "samples per pixel of the denoising sections' references")
      ->capture_default_str();
  sub->add_flag("!--no-video", s->video, "skip the MP4");
  sub->add_option("--out-format", s->frames_format,
                  "also write every main-table row's frames and the reference as exr | png | jpg "
                  "to OUT/frames/SCENE/ROW/ (png | jpg: the metrics' tonemap and sRGB; eval "
                  "scores them)");
  sub->callback([s, size, presets, &ctx] {
    for (const auto& p : *presets) s->methods.push_back("taa:" + p);
    std::erase(s->cache_scenes, std::string());  // --cache-scenes "": no cache section
    std::erase(s->extrapolate_scenes, std::string());
    std::erase(s->effect_sections, std::string());
    std::erase(s->light_scenes, std::string());
    std::erase(s->denoise_scenes, std::string());
    parse_size(*size, &s->width, &s->height);
    s->command_line = ctx.command_line;
    run_demo(*s, ctx.exec);
  });
}

}  // namespace afterimage::cli
