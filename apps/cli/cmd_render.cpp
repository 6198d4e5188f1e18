// `afterimage render`: renders a built-in scene to a frame sequence (G-buffer frames, and
// optionally reference / SSAA frames beside them). Parses, calls render/ and io/, reports.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "apps/cli/commands.h"
#include "core/error.h"
#include "io/io.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"

namespace afterimage::cli {

namespace {

struct RenderArgs {
  std::string scene;
  bool is_static = false;
  int frames = 60;
  std::string size = "640x360";
  std::string out;
  int reference = 0;      // 0 = no reference frames
  std::vector<int> ssaa;  // SSAA sample counts, one output directory each
  std::string jitter;     // empty: halton16, or halton ceil(8 S^2) with --render-scale S
  double render_scale = 1.0;
  uint64_t seed = 1;
  bool soft_shadows = false;
  int light_samples = render::RenderSettings().light_samples;
  bool motion_next = false;
  std::string shading_cache;                // empty: shade every pixel every frame
  int refresh = 0;                          // 0: the table's default
  float alpha = 0.0f;                       // 0: the table's default
  std::vector<std::string> cache_settings;  // KEY=VALUE of ShadingCacheSettings
  std::string compression = io::FrameWriteOptions().compression;
  // Camera-effect references (issue 12) and the lens / shutter they use (0 / empty: the
  // scene's own camera).
  bool reference_dof = false, reference_motion_blur = false;
  double f_number = 0.0, focus_distance = 0.0, focal_length = 0.0, blade_rotation = 0.0;
  int blades = -1;
  double shutter_angle = 180.0;
  std::string shutter_profile = "box";
  int shutter_samples = 0;
  // Path tracing (issue 11): noisy frames and path-traced references.
  bool path_trace = false;
  bool gradients = false;                  // A-SVGF gradient samples (needs --path-trace)
  bool gradient_replace = false;           // the gradient sample replaces the pixel's
  int bounces = -1, spp_per_frame = -1;    // -1: PathTraceSettings' defaults
  std::vector<std::string> path_settings;  // KEY=VALUE of PathTraceSettings
  std::vector<uint64_t> reference_seeds;   // more references, one per seed
};

// Per-frame counters of the shading cache to DIR/shading_cache.json, and a summary line.
void report_shading_cache(const reproject::ShadingCacheSettings& cs,
                          const std::vector<render::CacheFrameStats>& frames,
                          const std::string& dir) {
  nlohmann::json j;
  j["settings"] = nlohmann::json::parse(cs.to_json());
  reproject::ShadingCacheCounters sum;
  double seconds = 0.0, fraction = 0.0;
  for (const auto& f : frames) {
    const auto& k = f.counters;
    j["frames"].push_back({{"frame", f.frame},
                           {"pixels", k.pixels},
                           {"background", k.background},
                           {"hits", k.hits},
                           {"misses",
                            {{"no_history", k.no_history},
                             {"offscreen", k.offscreen},
                             {"id", k.id_miss},
                             {"depth", k.depth_miss},
                             {"normal", k.normal_miss}}},
                           {"refreshes",
                            {{"scheduled", k.scheduled},
                             {"stale", k.stale},
                             {"moving", k.moving},
                             {"changed", k.changed}}},
                           {"shaded", k.shaded},
                           {"shaded_fraction", k.shaded_fraction()},
                           {"max_age", k.max_age},
                           {"shadow_rays", f.shadow_rays},
                           {"ms", f.seconds * 1e3}});
    sum += k;
    seconds += f.seconds;
    fraction += k.shaded_fraction();
  }
  const std::string path = dir + "/shading_cache.json";
  io::write_text(path, j.dump(2) + "\n");
  const double n = double(std::max<size_t>(frames.size(), 1));
  fmt::print(
      "shading cache ({}): {:.1f}% of pixels shaded per frame on average, {:.1f} ms/frame; hits "
      "{}, misses {} (no history {}, off-screen {}, id {}, depth {}, normal {}), refreshes {} "
      "(scheduled {}, stale {}, moving objects {}, detected change {}), oldest value {} frames; "
      "per frame: {}\n",
      reproject::to_string(cs.mode), 100.0 * fraction / n, 1e3 * seconds / n, sum.hits,
      sum.misses(), sum.no_history, sum.offscreen, sum.id_miss, sum.depth_miss, sum.normal_miss,
      sum.scheduled + sum.stale + sum.moving + sum.changed, sum.scheduled, sum.stale, sum.moving,
      sum.changed, sum.max_age, path);
}

void run_render(const RenderArgs& a, const Exec& exec) {
  using namespace afterimage::render;
  Scene scene = make_builtin_scene(a.scene, a.is_static);
  RenderSettings rs;
  parse_size(a.size, &rs.width, &rs.height);
  // Lens options change the scene's camera, so every frame header carries the lens used.
  ThinLens& lens = scene.camera.lens;
  if (a.f_number != 0.0) lens.f_number = a.f_number;
  if (a.focus_distance != 0.0) lens.focus_distance = a.focus_distance;
  if (a.blades >= 0) lens.blades = a.blades;
  if (a.blade_rotation != 0.0) lens.blade_rotation_deg = a.blade_rotation;
  if (a.focal_length != 0.0) {  // the FOV follows the focal length (camera/camera.h FOV rule)
    lens.focal_length_mm = a.focal_length;
    scene.camera.vfov_degrees = fov_for_focal_length_deg(a.focal_length, lens.sensor_width_mm,
                                                         double(rs.width) / rs.height);
  }
  validate_lens(lens);
  // The frames carry the lens their projection implies (frame_lens: the focal length from the
  // FOV and the aspect). At an extreme aspect a lens scene's focal length can pass its focus
  // distance, which no thin lens focuses: refused before anything is written.
  if (lens.f_number > 0.0) {
    try {
      validate_lens(frame_lens(scene.camera, rs.width, rs.height));
    } catch (const SettingsError& e) {
      throw SettingsError(
          fmt::format("--size {}: with the scene's field of view, {}", a.size, e.what()));
    }
  }
  // --render-scale S (TAAU input, issue 10): the G-buffer at round(size / S) with a Halton
  // sequence of ceil(8 S^2) phases (FSR2); references and SSAA stay at --size, the output
  // resolution TAAU is scored at.
  const auto [gw, gh] = scaled_render_size(rs.width, rs.height, a.render_scale);
  rs.jitter = parse_jitter(!a.jitter.empty() ? a.jitter
                           : a.render_scale != 1.0
                               ? fmt::format("halton{}", jitter_length_for_scale(a.render_scale))
                               : "halton16");
  rs.seed = a.seed;
  rs.soft_shadows = a.soft_shadows;
  rs.light_samples = a.light_samples;
  rs.motion_next = a.motion_next;
  if (!a.shading_cache.empty()) {
    reproject::ShadingCacheSettings cs;
    cs.set_assignment("mode=" + a.shading_cache);
    if (a.refresh != 0) cs.set_assignment(fmt::format("refresh={}", a.refresh));
    if (a.alpha != 0.0f) cs.set_assignment(fmt::format("alpha={}", a.alpha));
    for (const auto& kv : a.cache_settings) cs.set_assignment(kv);
    cs.validate();
    rs.shading_cache = cs;
    // The averaging cache accumulates independent light samples, also on a static scene.
    rs.per_frame_light_samples = cs.mode == reproject::CacheMode::Average;
  } else if (a.refresh != 0 || a.alpha != 0.0f || !a.cache_settings.empty()) {
    throw SettingsError("--refresh, --alpha and --cache-set need --shading-cache reuse|average");
  }
  if (a.path_trace) {
    PathTraceSettings pt;
    if (a.bounces != -1) pt.set_assignment(fmt::format("bounces={}", a.bounces));
    if (a.spp_per_frame != -1) pt.set_assignment(fmt::format("spp_per_frame={}", a.spp_per_frame));
    for (const auto& kv : a.path_settings) pt.set_assignment(kv);
    pt.validate();
    rs.path_trace = pt;
    rs.gradients = a.gradients;
    rs.gradient_replace = a.gradient_replace;
    if (a.gradient_replace && !a.gradients)
      throw SettingsError("--gradient-replace needs --gradients");
    if (a.render_scale != 1.0 || !a.ssaa.empty() || a.reference_dof || a.reference_motion_blur)
      throw SettingsError(
          "--path-trace: no --render-scale, --ssaa, --reference-dof or --reference-motion-blur");
  } else if (a.bounces != -1 || a.spp_per_frame != -1 || !a.path_settings.empty() ||
             !a.reference_seeds.empty() || a.gradients) {
    throw SettingsError(
        "--bounces, --spp-per-frame, --path-set, --reference-seed and --gradients need "
        "--path-trace");
  }
  rs.validate();
  if (a.frames < 1) throw SettingsError(fmt::format("--frames {}: must be >= 1", a.frames));
  if (a.out.empty()) throw SettingsError("--out: an output directory is required");
  io::FrameWriteOptions wo;
  wo.compression = a.compression;
  io::check_exr_compression(wo.compression);

  // One pass per output directory: the G-buffer, then reference and SSAA frames.
  std::vector<RenderPass> passes{{"gbuffer", 0, gw, gh}};
  std::vector<std::string> dirs{a.out};
  if (a.reference != 0) {
    if (a.path_trace) {
      if (a.reference < 1)
        throw SettingsError(fmt::format("--reference {}: must be >= 1", a.reference));
    } else {
      samples_per_axis(a.reference, "--reference");
    }
    passes.push_back({fmt::format("reference {} spp", a.reference), a.reference});
    dirs.push_back(a.out + "/reference");
  }
  // Path tracing: the same reference with other seeds, so its own noise can be measured
  // (PSNR between two seeds).
  for (uint64_t seed : a.reference_seeds) {
    if (a.reference == 0) throw SettingsError("--reference-seed needs --reference SPP");
    if (seed == a.seed)
      throw SettingsError(fmt::format("--reference-seed {}: equals --seed", seed));
    RenderPass p{fmt::format("reference seed {}", seed), a.reference};
    p.seed = seed;
    passes.push_back(p);
    dirs.push_back(fmt::format("{}/reference-seed{}", a.out, seed));
  }
  if (a.reference_dof || a.reference_motion_blur) {
    if (a.reference == 0)
      throw SettingsError("--reference-dof / --reference-motion-blur use --reference N samples");
    if (a.reference_dof && !(lens.f_number > 0.0))
      throw SettingsError(fmt::format(
          "--reference-dof: scene '{}' has a pinhole camera; give --f-number", scene.name));
    RenderPass p{"", a.reference};
    p.effects.depth_of_field = a.reference_dof;
    if (a.reference_motion_blur) {
      p.effects.shutter_angle_deg = a.shutter_angle;
      p.effects.shutter_profile = parse_shutter_profile(a.shutter_profile);
      p.effects.shutter_samples = a.shutter_samples;
    }
    p.effects.validate();
    if (a.shutter_samples != 0 && a.reference % a.shutter_samples != 0)
      throw SettingsError(fmt::format("--shutter-samples {}: must divide --reference {}",
                                      a.shutter_samples, a.reference));
    const std::string name = a.reference_dof && a.reference_motion_blur ? "reference-dof-mb"
                             : a.reference_dof                          ? "reference-dof"
                                                                        : "reference-mb";
    p.label = fmt::format("{} {} spp", name, a.reference);
    passes.push_back(p);
    dirs.push_back(a.out + "/" + name);
  }
  for (int spp : a.ssaa) {
    samples_per_axis(spp, "--ssaa");
    passes.push_back({fmt::format("ssaa {} spp", spp), spp});
    dirs.push_back(fmt::format("{}/ssaa{}", a.out, spp));
  }

  // Progress: a rewritten percent line on a terminal (at most 4 updates/s), one line per
  // frame otherwise (logs).
  const bool tty = isatty(fileno(stderr));
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  auto last_print = t0, frame_start = t0;
  SequenceRenderProgress progress;
  if (tty)
    progress = [&](int k, size_t pass, double fraction) {
      const auto now = Clock::now();
      if (fraction < 1.0 && now - last_print < std::chrono::milliseconds(250)) return;
      last_print = now;
      std::fprintf(stderr, "\rrender %s: frame %d/%d %-18s %3d%%", scene.name.c_str(), k + 1,
                   a.frames, passes[pass].label.c_str(), int(fraction * 100.0));
      std::fflush(stderr);
    };
  RenderStats total;
  // Render time per pass: from the previous pass's frame written to this one's delivered.
  std::vector<double> pass_seconds(passes.size(), 0.0);
  auto pass_start = Clock::now();
  render_sequence(
      scene, a.frames, passes, rs, exec,
      [&](int k, size_t pass, Frame&& f) {
        pass_seconds[pass] += std::chrono::duration<double>(Clock::now() - pass_start).count();
        io::write_frame(io::frame_path(dirs[pass], k), f, nullptr, wo);
        pass_start = Clock::now();
        if (!tty && pass + 1 == passes.size()) {
          std::fprintf(stderr, "render %s: frame %d/%d done in %.2f s\n", scene.name.c_str(), k + 1,
                       a.frames, std::chrono::duration<double>(Clock::now() - frame_start).count());
          frame_start = Clock::now();
        }
      },
      &total, progress);
  if (tty) std::fprintf(stderr, "\n");
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  fmt::print("rendered {} frames of '{}' at {}x{} to {} ({} pass{}) in {:.1f} s\n", a.frames,
             scene.name, rs.width, rs.height, a.out, passes.size(), passes.size() > 1 ? "es" : "",
             wall);
  if (gw != rs.width || gh != rs.height)
    fmt::print(
        "G-buffer at {}x{} (render scale {}, jitter halton{}); upscale it with `afterimage "
        "resolve --in {} --upscale {}x{}`\n",
        gw, gh, a.render_scale, rs.jitter.length, a.out, rs.width, rs.height);
  fmt::print("rays: {} primary + {} shadow{} in {:.1f} s of tracing = {:.1f} Mrays/s\n",
             total.primary_rays, total.shadow_rays,
             total.bounce_rays ? fmt::format(" + {} bounce", total.bounce_rays) : "", total.seconds,
             total.rays_per_second() * 1e-6);
  for (size_t i = 0; i < passes.size(); ++i)
    fmt::print("  {}: {:.1f} ms/frame\n", passes[i].label, 1e3 * pass_seconds[i] / a.frames);
  if (rs.gradients) {
    // One candidate per 3x3 stratum per frame after the first: how many reached a stratum of
    // the next frame and were re-traced, and how many of those hit the same surface.
    const double strata = double((rs.width + 2) / 3) * double((rs.height + 2) / 3);
    fmt::print(
        "gradient samples: {} re-traced ({:.1f}% of the {} frames' strata), {} accepted "
        "({:.1f}% of the re-traced: same id, normal and depth)\n",
        total.gradient_retraced,
        a.frames > 1 ? 100.0 * double(total.gradient_retraced) / (strata * (a.frames - 1)) : 0.0,
        std::max(0, a.frames - 1), total.gradient_accepted,
        total.gradient_retraced
            ? 100.0 * double(total.gradient_accepted) / double(total.gradient_retraced)
            : 0.0);
  }
  if (rs.shading_cache) report_shading_cache(*rs.shading_cache, total.cache_frames, a.out);
}

}  // namespace

void add_render_command(CLI::App& app, Context& ctx) {
  auto* sub = app.add_subcommand("render", "render a built-in animated scene to EXR frames");
  auto a = std::make_shared<RenderArgs>();
  sub->add_option("--scene", a->scene,
                  fmt::format("{}", fmt::join(render::builtin_scene_names(), " | ")))
      ->required();
  sub->add_flag("--static", a->is_static, "freeze the scene and camera at t = 0 (only jitter)");
  sub->add_option("--frames", a->frames, "number of frames (frame k at k/30 s)")
      ->capture_default_str();
  sub->add_option("--size", a->size, "WIDTHxHEIGHT")->capture_default_str();
  sub->add_option("--out", a->out, "output directory: DIR/frame.%04d.exr")->required();
  sub->add_option("--reference", a->reference,
                  "also render DIR/reference/ with SPP stratified samples per pixel (square; "
                  "any count with --path-trace)");
  sub->add_option("--ssaa", a->ssaa, "also render DIR/ssaaSPP/ (repeatable; square SPP)");
  sub->add_option("--jitter", a->jitter,
                  "halton16 | halton8 | haltonN | none (default halton16, or halton ceil(8 S^2) "
                  "with --render-scale S)");
  sub->add_option("--render-scale", a->render_scale,
                  "render the G-buffer at round(size / S) per axis, S in [1, 4], for temporal "
                  "upsampling (resolve --upscale); references and SSAA stay at --size")
      ->capture_default_str();
  sub->add_option("--seed", a->seed, "seed of stratified and light samples")->capture_default_str();
  sub->add_option("--compression", a->compression,
                  "EXR compression of the frames (see resolve --compression); the default, none, "
                  "reads and writes fastest (measurements in docs/DESIGN.md §3)")
      ->capture_default_str();
  sub->add_flag("--soft-shadows", a->soft_shadows,
                "sample sphere lights' area (16 samples) instead of their center");
  sub->add_option("--light-samples", a->light_samples,
                  "light samples per shading point with --soft-shadows (a perfect square)")
      ->capture_default_str();
  sub->add_flag("--motion-next", a->motion_next,
                "also write motion_next (p_next - p_curr) for forward reprojection (extrapolate)");
  sub->add_option("--shading-cache", a->shading_cache,
                  "reuse: shade only cache misses and scheduled refreshes, reuse the rest from "
                  "the previous frame; average: shade all, running average (reverse "
                  "reprojection cache; counters in DIR/shading_cache.json)")
      ->check(CLI::IsMember({"reuse", "average"}));
  sub->add_option("--refresh", a->refresh,
                  "reuse: re-shade every pixel at least every K frames (default 8)");
  sub->add_option("--alpha", a->alpha, "average: weight of the new sample (default 0.1)");
  sub->add_option("--cache-set", a->cache_settings,
                  fmt::format("shading cache setting KEY=VALUE ({})",
                              fmt::join(reproject::ShadingCacheSettings::params().keys(), ", ")))
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sub->add_flag("--reference-dof", a->reference_dof,
                "also render DIR/reference-dof/: the reference with depth of field (thin-lens "
                "rays, --reference SPP); with --reference-motion-blur one DIR/reference-dof-mb/");
  sub->add_flag("--reference-motion-blur", a->reference_motion_blur,
                "also render DIR/reference-mb/: the reference with motion blur (samples over the "
                "shutter interval centered on the frame time, --reference SPP)");
  sub->add_option("--f-number", a->f_number, "lens f-number (default: the scene's)");
  sub->add_option("--focus-distance", a->focus_distance,
                  "focus distance, view depth in scene units (default: the scene's)");
  sub->add_option("--focal-length", a->focal_length,
                  "focal length in mm; sets the vertical FOV with the 36 mm sensor width "
                  "(default: the scene's FOV)");
  sub->add_option("--blades", a->blades, "aperture blades: 0 = disc, 3..16 = polygon");
  sub->add_option("--blade-rotation", a->blade_rotation, "aperture polygon rotation, degrees");
  sub->add_option("--shutter-angle", a->shutter_angle,
                  "motion blur shutter angle in degrees (360 = a whole frame interval)")
      ->capture_default_str();
  sub->add_option("--shutter-profile", a->shutter_profile, "box | triangle")
      ->check(CLI::IsMember({"box", "triangle"}))
      ->capture_default_str();
  sub->add_option("--shutter-samples", a->shutter_samples,
                  "time strata per frame, dividing SPP (0: largest divisor <= 64)");
  sub->add_flag("--path-trace", a->path_trace,
                "path-traced noisy frames (1 spp, NEE + MIS, Russian roulette) with emission, "
                "albedo, diffuse / specular and direct / indirect channels; --reference SPP "
                "(any count) then path traces the references");
  sub->add_flag("--gradients", a->gradients,
                "path tracing: A-SVGF gradient samples (one previous-frame sample per 3x3 "
                "stratum re-traced in this frame; channel gradient = delta, max, valid; about "
                "1/9 more rays)");
  sub->add_flag("--gradient-replace", a->gradient_replace,
                "with --gradients: the re-traced sample replaces the landing pixel's sample (the "
                "paper; by default it only measures the gradient and the color is unchanged)");
  sub->add_option("--bounces", a->bounces, "path tracing: scattering events per path (default 4)");
  sub->add_option("--spp-per-frame", a->spp_per_frame,
                  "path tracing: samples per pixel of a noisy frame (default 1)");
  sub->add_option("--path-set", a->path_settings,
                  fmt::format("path tracing setting KEY=VALUE ({})",
                              fmt::join(render::PathTraceSettings::params().keys(), ", ")))
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sub->add_option("--reference-seed", a->reference_seeds,
                  "path tracing: also render DIR/reference-seedK/, the reference with seed K "
                  "(repeatable; PSNR between two seeds states the reference's own noise)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sub->callback([a, &ctx] { run_render(*a, ctx.exec); });
}

}  // namespace afterimage::cli
