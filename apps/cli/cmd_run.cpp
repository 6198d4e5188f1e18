// `afterimage run`: a temporal method and post passes in the DESIGN.md order over a frame
// sequence (issue 12; run/post_pipeline.h). Parses, builds the chain and calls
// run_sequence like `resolve` (DESIGN.md §6: thin CLI).
#include <fmt/format.h>

#include <unistd.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "apps/cli/commands.h"
#include "core/error.h"
#include "run/post_pipeline.h"
#include "run/sequence.h"

namespace afterimage::cli {

namespace {

struct RunArgs {
  SequenceFiles files;
  std::string pipeline;
  std::vector<std::string> sets;
  std::string out_format = "exr";
  bool list_settings = false;
};

void run_pipeline(const RunArgs& a, const Context& ctx) {
  SequenceFiles files = a.files;
  files.out.format = parse_output_format(a.out_format);
  // --list-settings without --pipeline lists the widest pipeline (`--pipeline taau
  // --list-settings` shows the upscaler's table, the one resolve stage left out).
  const bool widest = a.list_settings && a.pipeline.empty();
  const PipelineSpec spec = parse_pipeline(widest ? widest_pipeline() : a.pipeline, a.sets);
  const bool display = files.out.format != OutputFormat::exr;
  // After a tonemap stage the 8-bit writer only clamps and encodes sRGB, or only clamps when a
  // sharpen stage worked on the encoded values (display_transform).
  if (display) files.out.tonemap = display_transform(spec);
  std::unique_ptr<SequenceMethod> method = make_pipeline_method(spec, ctx.exec, display);
  if (a.list_settings) {
    fmt::print("each stage's settings (change one with --set STAGE.KEY=VALUE):\n{}",
               method->describe_settings());
    return;
  }
  if (a.files.in.dir.empty()) throw SettingsError("run: --in DIR is required");
  if (a.files.out_dir.empty()) throw SettingsError("run: --out DIR is required");
  files.out.validate();
  const bool tty = isatty(fileno(stderr));
  const SequenceRunStats st = run_sequence(
      *method, files,
      [&](size_t done, size_t total, const std::string& out_path) {
        if (tty)
          std::fprintf(stderr, "\rrun: frame %zu/%zu", done, total);
        else
          std::fprintf(stderr, "run: frame %zu/%zu -> %s\n", done, total, out_path.c_str());
        std::fflush(stderr);
      },
      print_note);
  if (tty) std::fprintf(stderr, "\n");
  fmt::print("ran {} on {} frames (layout {}) to {} in {:.1f} s ({:.2f} ms/frame in the chain)\n",
             method->name(), st.frames, st.layout, a.files.out_dir, st.seconds,
             1e3 * st.process_seconds / double(st.frames));
}

}  // namespace

void add_run_command(CLI::App& app, Context& ctx) {
  auto* sub = app.add_subcommand(
      "run", "a temporal method and post passes (DESIGN.md order) over a frame sequence");
  auto a = std::make_shared<RunArgs>();
  std::vector<std::string> stages;
  for (const auto& s : post_stages()) stages.push_back(s.name);
  sub->add_option("--in", a->files.in.dir, "input sequence directory");
  sub->add_option("--out", a->files.out_dir,
                  "output directory (same file names; never the input files)");
  add_sequence_input_options(sub, a->files.in);
  add_output_name_option(sub, a->files.out_name);
  sub->add_option("--pipeline", a->pipeline,
                  fmt::format("comma list of stages, run in the DESIGN.md order whatever the "
                              "order given: taa[:preset] or taau[:mode], then {}",
                              fmt::join(stages, ", ")));
  sub->add_option("--set", a->sets, "stage.key=value (repeatable), e.g. tonemap.operator=agx")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sub->add_option("--out-format", a->out_format,
                  "exr | png | jpg (8-bit; after a tonemap stage only clamped and sRGB-encoded)")
      ->capture_default_str();
  sub->add_option("--compression", a->files.out.exr.compression, "EXR compression (see resolve)")
      ->capture_default_str();
  sub->add_flag("--list-settings", a->list_settings,
                "print the settings (value, default, range) of --pipeline's stages, by default "
                "of svgf, taa and every post stage, and exit");
  sub->callback([a, &ctx] { run_pipeline(*a, ctx); });
}

}  // namespace afterimage::cli
