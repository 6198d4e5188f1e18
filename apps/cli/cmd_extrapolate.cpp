// `afterimage extrapolate`: synthesises the frames between rendered ones by forward
// reprojection (issue 13; run/extrapolate.h). Parses and calls extrapolate_files
// (DESIGN.md §6: thin CLI).
#include <fmt/format.h>

#include <memory>
#include <string>

#include "apps/cli/commands.h"
#include "core/error.h"
#include "run/extrapolate.h"

namespace afterimage::cli {

namespace {

struct ExtrapolateArgs {
  ExtrapolateFiles files;
  ExtrapolateSettings settings;
  std::string fill = reproject::hole_fill_name(reproject::FillSettings{}.fill);
};

void run_extrapolate(ExtrapolateArgs a, const Context& ctx) {
  if (a.files.in.dir.empty()) throw SettingsError("extrapolate: --in DIR is required");
  if (a.files.out_dir.empty()) throw SettingsError("extrapolate: --out DIR is required");
  a.settings.fill.fill = reproject::parse_hole_fill(a.fill);
  a.settings.validate();
  const ExtrapolateRunStats st = extrapolate_files(
      a.files, a.settings, ctx.exec,
      [](size_t k, size_t, const std::string& path, const SynthesisReport* r) {
        if (r) fmt::print("frame {}: {} -> {}\n", k, r->describe(), path);
      },
      print_note);
  fmt::print(
      "extrapolate: {} frames (layout {}), {} synthesised with --skip {}{} and fill {}: holes "
      "{:.2f}% mean, {:.2f}% max; written to {} in {:.1f} s\n",
      st.frames, st.layout, st.synthesized, a.settings.skip,
      a.settings.interpolate ? " --interpolate" : "", a.fill, 100.0 * st.mean_hole_fraction,
      100.0 * st.max_hole_fraction, a.files.out_dir, st.seconds);
}

}  // namespace

void add_extrapolate_command(CLI::App& app, Context& ctx) {
  auto* sub = app.add_subcommand(
      "extrapolate",
      "synthesise frames from the previous rendered frame and the new camera by forward "
      "reprojection (VR-style asynchronous reprojection), or between two rendered frames");
  auto a = std::make_shared<ExtrapolateArgs>();
  sub->add_option("--in", a->files.in.dir,
                  "input sequence directory (color and depth; motion_next / motion used where "
                  "exact)");
  sub->add_option("--out", a->files.out_dir,
                  "output directory: every frame's color under the input's file names (never "
                  "the input files)");
  add_sequence_input_options(sub, a->files.in);
  add_output_name_option(sub, a->files.out_name);
  sub->add_option("--skip", a->settings.skip,
                  "frames synthesised after each rendered one: frame k is rendered (kept) when k "
                  "% (skip + 1) == 0, counting input frames from 0")
      ->capture_default_str();
  sub->add_flag("--interpolate", a->settings.interpolate,
                "also splat the next rendered frame (interpolation between two rendered frames)");
  sub->add_option("--fill", a->fill,
                  fmt::format("hole fill: {}", fmt::join(reproject::hole_fill_names(), " | ")))
      ->capture_default_str();
  sub->add_option("--compression", a->files.exr.compression, "EXR compression (see resolve)")
      ->capture_default_str();
  sub->callback([a, &ctx] { run_extrapolate(*a, ctx); });
}

}  // namespace afterimage::cli
