// `afterimage resolve`: temporal anti-aliasing of a frame sequence. Parses, builds the method
// from the registry (run/methods.h) and calls run_sequence (DESIGN.md §6: thin CLI).
#include <fmt/format.h>

#include <unistd.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "apps/cli/commands.h"
#include "core/error.h"
#include "run/methods.h"
#include "run/sequence.h"

namespace afterimage::cli {

namespace {

struct ResolveArgs : MethodRunOptions {
  std::string preset;
  std::string upscale;  // TAAU: quality | balanced | performance | SCALE | WxH
  std::vector<std::string> sets;
  bool list_settings = false;
  bool markdown = false;
};

void run_resolve(const ResolveArgs& a, const Context& ctx) {
  const Exec& exec = ctx.exec;
  // "--preset P --set k=v" is the method spec "taa:P+k=v"; "--upscale U --set k=v" is
  // "taau:<preset or scale or size>+k=v" (temporal upsampling, taau/).
  if (!a.upscale.empty() && !a.preset.empty())
    throw SettingsError(
        "--preset names a TAA preset; with --upscale the mode is the argument "
        "of --upscale (quality, balanced, performance, a scale or WxH)");
  const bool upscale = !a.upscale.empty();
  const std::string technique = upscale ? "taau" : "taa";
  std::string spec = upscale ? upscale_method_spec(a.upscale)
                             : "taa:" + (a.preset.empty() ? default_variant("taa") : a.preset);
  for (const auto& kv : a.sets) spec += "+" + kv;
  std::unique_ptr<SequenceMethod> method = make_method(spec, exec);
  const std::string preset =
      upscale ? a.upscale : (a.preset.empty() ? default_variant("taa") : a.preset);
  if (a.list_settings && a.markdown) {  // the README table: keys, defaults, ranges, docs
    fmt::print("{}", settings_markdown(technique));
    return;
  }
  if (a.list_settings) {
    fmt::print("{} {} with {} override(s):\n{}", upscale ? "upscale" : "preset", preset,
               a.sets.size(), method->describe_settings());
    return;
  }
  const SequenceRunStats st = run_method_files(*method, a, "resolve", preset);
  fmt::print(
      "resolved {} frames (layout {}) with {} {} to {} in {:.1f} s ({:.2f} ms/frame in {})\n",
      st.frames, st.layout, upscale ? "upscale" : "preset", preset, a.files.out_dir, st.seconds,
      1e3 * st.process_seconds / double(st.frames), upscale ? "TAAU" : "TAA");
}

}  // namespace

SequenceRunStats run_method_files(SequenceMethod& method, const MethodRunOptions& o,
                                  const char* verb, const std::string& label) {
  if (o.files.in.dir.empty()) throw SettingsError(fmt::format("{}: --in DIR is required", verb));
  if (o.files.out_dir.empty()) throw SettingsError(fmt::format("{}: --out DIR is required", verb));
  if (!o.load_state.empty()) method.load_state(o.load_state);
  const bool tty = isatty(fileno(stderr));
  SequenceFiles files = o.files;
  files.out.format = parse_output_format(o.out_format);
  files.out.tonemap = parse_tonemap(o.tonemap);
  files.out.pipelined = !o.sequential;
  files.out.validate();
  // The state is replaced after the run; it must not be an input frame.
  if (!o.save_state.empty()) files.other_outputs.push_back(o.save_state);
  const SequenceRunStats st = run_sequence(
      method, files,
      [&](size_t done, size_t total, const std::string& out_path) {
        if (tty)
          std::fprintf(stderr, "\r%s %s: frame %zu/%zu", verb, label.c_str(), done, total);
        else
          std::fprintf(stderr, "%s %s: frame %zu/%zu -> %s\n", verb, label.c_str(), done, total,
                       out_path.c_str());
        std::fflush(stderr);
      },
      print_note);
  if (tty) std::fprintf(stderr, "\n");
  if (!o.save_state.empty()) method.save_state(o.save_state);
  return st;
}

void print_note(const std::string& note) {
  std::fprintf(stderr, "afterimage: %s\n", note.c_str());
}

void add_sequence_input_options(CLI::App* sub, io::SequenceInput& in) {
  sub->add_option("--name", in.name, "sequence file name stem (default: the only one in DIR)");
  sub->add_option("--layout", in.layout,
                  "how to read the frames: auto (recognise ours or Blender's), afterimage, "
                  "blender[:VIEWLAYER], or a layout .json file")
      ->capture_default_str();
  sub->add_option("--map", in.maps,
                  "override one channel: key=CH1,CH2[:convention], CH may be A+B (repeatable); "
                  "conventions: motion afterimage|blender|unity|unreal|fsr2, depth "
                  "linear|ray|hardware[:near:far]|hardware-reversed[:near:far]")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sub->add_option("--jitter", in.jitter,
                  "jitter of the input frames when the files carry none: none | haltonN[:start]");
  sub->add_option("--jitter-file", in.jitter_file,
                  "camera sidecar JSON: per frame jitter (pixels, y down), optional view and "
                  "projection (row-major); default: jitter.json beside foreign frames, if any "
                  "(--jitter none ignores it)");
}

void add_output_name_option(CLI::App* sub, std::string& out_name) {
  sub->add_option("--out-name", out_name,
                  "output file name stem: OUT/NAME.NNNN.EXT with the input's frame numbers "
                  "(default: each output keeps its input's file name)");
}

void add_resolve_command(CLI::App& app, Context& ctx) {
  auto* sub = app.add_subcommand("resolve", "temporal anti-aliasing (TAA) of a frame sequence");
  auto a = std::make_shared<ResolveArgs>();
  sub->add_option("--in", a->files.in.dir,
                  "input sequence directory: DIR/NAME.%04d.exr or DIR/NAME_%04d.exr with color, "
                  "depth, motion");
  sub->add_option("--out", a->files.out_dir,
                  "output directory (same file names; never the input files)");
  add_sequence_input_options(sub, a->files.in);
  add_output_name_option(sub, a->files.out_name);
  sub->add_option("--preset", a->preset,
                  fmt::format("{} (default {})", fmt::join(method_variants("taa"), " | "),
                              default_variant("taa")));
  sub->add_option("--upscale", a->upscale,
                  fmt::format("temporal upsampling (TAAU) of low-resolution frames (render "
                              "--render-scale): {}, a scale per axis in [1, 4] or the output "
                              "size WxH",
                              fmt::join(method_variants("taau"), " | ")));
  sub->add_option("--set", a->sets, "override a setting: key=value (repeatable)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sub->add_option("--out-format", a->out_format,
                  "exr: resolved color (R G B) with the input's camera metadata; png | jpg: "
                  "8-bit display images (exposure, tonemap, sRGB as eval's metrics)")
      ->capture_default_str();
  sub->add_flag("--keep-gbuffer", a->files.out.keep_gbuffer,
                "EXR only: also write every input channel the method does not produce (depth, "
                "normal, albedo, motion, id, ...), as the input had them");
  sub->add_option("--compression", a->files.out.exr.compression,
                  "EXR compression: none | rle | zips | zip | piz | pxr24 | b44 | b44a | dwaa | "
                  "dwab, optionally NAME:LEVEL")
      ->capture_default_str();
  sub->add_flag("--half", a->files.out.exr.half_color,
                "EXR: store color as 16-bit half (clamped to +-65504); G-buffer channels keep "
                "their types");
  sub->add_option("--exposure", a->files.out.exposure,
                  "png | jpg: exposure multiplying linear color before the tonemap")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub->add_option("--tonemap", a->tonemap,
                  "png | jpg: reinhard (x/(1+x) per channel, as eval's metrics) | clamp")
      ->capture_default_str();
  sub->add_flag("--sequential", a->sequential,
                "read, resolve and write one frame at a time instead of overlapping them (same "
                "output files; for measurements)");
  sub->add_option("--save-state", a->save_state, "write the resolver state after the last frame");
  sub->add_option("--load-state", a->load_state, "start from a saved resolver state");
  sub->add_flag("--list-settings", a->list_settings,
                "print every setting (value, default, range) of the preset + overrides and exit");
  sub->add_flag("--markdown", a->markdown,
                "with --list-settings: print the settings table (key, default, range, doc) as "
                "markdown");
  sub->callback([a, &ctx] { run_resolve(*a, ctx); });
}

}  // namespace afterimage::cli
