// `afterimage denoise`: SVGF of a path-traced frame sequence (svgf/). Parses, builds the method
// from the registry (run/methods.h: "svgf:<preset>+key=value") and calls run_sequence, as
// `resolve` does (DESIGN.md §6: thin CLI): the same reading (any layout), checks and writing.
#include <fmt/format.h>

#include <memory>
#include <string>
#include <vector>

#include "apps/cli/commands.h"
#include "core/error.h"
#include "run/methods.h"
#include "run/post_pipeline.h"
#include "run/sequence.h"

namespace afterimage::cli {

namespace {

// The registry technique this command runs.
const MethodFamily& denoiser_family() {
  for (const MethodFamily& f : method_families())
    if (f.denoiser) return f;
  throw SettingsError("denoise: no denoiser in the method registry");
}

struct DenoiseArgs : MethodRunOptions {
  std::string preset;
  std::vector<std::string> sets;
  // TAA after SVGF (a preset of the taa family, or "off"): the paper's own pipeline ends in
  // TAA, and on the path-traced scenes SVGF + TAA beats SVGF alone (README, issue 11 note).
  std::string taa = "default";
  bool list_settings = false;
  bool markdown = false;
};

void run_denoise(const DenoiseArgs& a, const Context& ctx) {
  const std::string technique = denoiser_family().technique;
  const std::string preset = a.preset.empty() ? default_variant(technique) : a.preset;
  std::string spec = technique + ":" + preset;
  for (const auto& kv : a.sets) spec += "+" + kv;
  // The svgf spec is validated on its own first, so a bad --set names svgf, not the chain.
  std::unique_ptr<SequenceMethod> method = make_method(spec, ctx.exec);
  std::string taa_label = "off";
  if (a.taa != "off") {
    const std::string taa_preset = a.taa == "default" ? default_variant("taa") : a.taa;
    PipelineSpec chain;
    chain.denoise = spec;
    chain.temporal = "taa:" + taa_preset;
    method = make_pipeline_method(chain, ctx.exec);
    taa_label = taa_preset;
  }
  if (a.list_settings && a.markdown) {
    fmt::print("{}", settings_markdown(technique));
    return;
  }
  if (a.list_settings) {
    fmt::print("preset {} with {} override(s), then TAA {}:\n{}", preset, a.sets.size(), taa_label,
               method->describe_settings());
    return;
  }
  const SequenceRunStats st = run_method_files(*method, a, "denoise", preset);
  fmt::print(
      "denoised {} frames (layout {}) with preset {} then TAA {} to {} in {:.1f} s ({:.2f} "
      "ms/frame in {})\n",
      st.frames, st.layout, preset, taa_label, a.files.out_dir, st.seconds,
      1e3 * st.process_seconds / double(st.frames), denoiser_family().label);
}

}  // namespace

void add_denoise_command(CLI::App& app, Context& ctx) {
  const MethodFamily& fam = denoiser_family();
  auto* sub = app.add_subcommand("denoise", fam.description);
  auto a = std::make_shared<DenoiseArgs>();
  sub->add_option("--in", a->files.in.dir,
                  "input sequence directory: DIR/NAME.%04d.exr or DIR/NAME_%04d.exr with color, "
                  "depth, normal, motion (albedo, emission, direct/indirect or diffuse/specular, "
                  "id, depth_gradient used when present)");
  sub->add_option("--out", a->files.out_dir,
                  "output directory (same file names; never the input files)");
  add_sequence_input_options(sub, a->files.in);
  add_output_name_option(sub, a->files.out_name);
  sub->add_option("--preset", a->preset,
                  fmt::format("{} (default {})", fmt::join(method_variants(fam.technique), " | "),
                              default_variant(fam.technique)));
  sub->add_option("--taa", a->taa,
                  fmt::format("TAA after SVGF: {} | off (default: the taa default, {})",
                              fmt::join(method_variants("taa"), " | "), default_variant("taa")))
      ->capture_default_str();
  sub->add_option("--set", a->sets, "override an SVGF setting: key=value (repeatable)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sub->add_option("--out-format", a->out_format,
                  "exr: denoised color (R G B) with the input's camera metadata; png | jpg: "
                  "8-bit display images (exposure, tonemap, sRGB as eval's metrics)")
      ->capture_default_str();
  sub->add_flag("--keep-gbuffer", a->files.out.keep_gbuffer,
                "EXR only: also write every input channel the method does not produce");
  sub->add_option("--compression", a->files.out.exr.compression, "EXR compression (see resolve)")
      ->capture_default_str();
  sub->add_flag("--half", a->files.out.exr.half_color,
                "EXR: store color as 16-bit half (clamped to +-65504)");
  sub->add_option("--exposure", a->files.out.exposure,
                  "png | jpg: exposure multiplying linear color before the tonemap")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub->add_option("--tonemap", a->tonemap, "png | jpg: reinhard | clamp")->capture_default_str();
  sub->add_flag("--sequential", a->sequential,
                "read, denoise and write one frame at a time instead of overlapping them");
  sub->add_option("--save-state", a->save_state, "write the denoiser state after the last frame");
  sub->add_option("--load-state", a->load_state, "start from a saved denoiser state");
  sub->add_flag("--list-settings", a->list_settings,
                "print every setting (value, default, range) of the preset + overrides and exit");
  sub->add_flag("--markdown", a->markdown,
                "with --list-settings: print the settings table as markdown");
  sub->callback([a, &ctx] { run_denoise(*a, ctx); });
}

}  // namespace afterimage::cli
