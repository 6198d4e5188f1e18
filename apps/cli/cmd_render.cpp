// `afterimage render`: renders a built-in scene to a frame sequence (G-buffer frames, and
// optionally reference / SSAA frames beside them). Parses, calls render/ and io/, reports.
#include <fmt/format.h>

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
  std::string compression = io::FrameWriteOptions().compression;
};

void run_render(const RenderArgs& a, const Exec& exec) {
  using namespace afterimage::render;
  const Scene scene = make_builtin_scene(a.scene, a.is_static);
  RenderSettings rs;
  parse_size(a.size, &rs.width, &rs.height);
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
  if (a.frames < 1) throw SettingsError(fmt::format("--frames {}: must be >= 1", a.frames));
  if (a.out.empty()) throw SettingsError("--out: an output directory is required");
  io::FrameWriteOptions wo;
  wo.compression = a.compression;
  io::check_exr_compression(wo.compression);

  // One pass per output directory: the G-buffer, then reference and SSAA frames.
  std::vector<RenderPass> passes{{"gbuffer", 0, gw, gh}};
  std::vector<std::string> dirs{a.out};
  if (a.reference != 0) {
    samples_per_axis(a.reference, "--reference");
    passes.push_back({fmt::format("reference {} spp", a.reference), a.reference});
    dirs.push_back(a.out + "/reference");
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
  render_sequence(
      scene, a.frames, passes, rs, exec,
      [&](int k, size_t pass, Frame&& f) {
        io::write_frame(io::frame_path(dirs[pass], k), f, nullptr, wo);
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
  fmt::print("rays: {} primary + {} shadow in {:.1f} s of tracing = {:.1f} Mrays/s\n",
             total.primary_rays, total.shadow_rays, total.seconds, total.rays_per_second() * 1e-6);
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
                  "also render DIR/reference/ with SPP stratified samples per pixel (square)");
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
  sub->callback([a, &ctx] { run_render(*a, ctx.exec); });
}

}  // namespace afterimage::cli
