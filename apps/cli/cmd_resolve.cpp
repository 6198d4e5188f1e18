// `afterimage resolve`: temporal anti-aliasing of a frame sequence. Parses, then loops
// read_frame -> TemporalResolver::process -> write_frame (DESIGN.md §6: thin CLI; the TAA
// itself lives in src/taa).
#include <fmt/format.h>

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "apps/cli/commands.h"
#include "core/error.h"
#include "io/io.h"
#include "taa/presets.h"
#include "taa/resolver.h"

namespace afterimage::cli {

namespace {

struct ResolveArgs {
  std::string in, out;
  std::string name = "frame";
  std::string preset = "afterimage";
  std::vector<std::string> sets;
  std::string save_state, load_state;
  bool list_settings = false;
  bool markdown = false;
};

void run_resolve(const ResolveArgs& a, const Exec& exec) {
  taa::TaaSettings s = taa::make_preset(a.preset);
  for (const auto& kv : a.sets) s.set_assignment(kv);
  s.validate();
  if (a.list_settings && a.markdown) {  // the README table: keys, defaults, ranges, docs
    fmt::print("{}", taa::TaaSettings::params().markdown_table());
    return;
  }
  if (a.list_settings) {
    fmt::print("preset {} with {} override(s):\n{}", a.preset, a.sets.size(), s.describe());
    return;
  }
  if (a.in.empty()) throw SettingsError("resolve: --in DIR is required");
  if (a.out.empty()) throw SettingsError("resolve: --out DIR is required");

  const std::vector<std::string> files = io::list_sequence(a.in, a.name);
  // Every input is registered before anything is written, so no output replaces an input
  // even when --out is --in.
  io::InputRegistry inputs;
  for (const auto& f : files) inputs.add(f);

  taa::TemporalResolver resolver(s, exec);
  if (!a.load_state.empty()) resolver.load_state(a.load_state);
  std::error_code ec;
  std::filesystem::create_directories(a.out, ec);
  if (ec) throw InputError(fmt::format("{}: cannot create directory: {}", a.out, ec.message()));

  const bool tty = isatty(fileno(stderr));
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  double process_seconds = 0;
  for (size_t i = 0; i < files.size(); ++i) {
    const std::string& path = files[i];
    Frame f = io::read_frame(path, {"color", "depth", "motion"}, &inputs);
    const auto p0 = Clock::now();
    ImageF resolved;
    try {
      resolved = resolver.process(f);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", path, e.what()));
    }
    process_seconds += std::chrono::duration<double>(Clock::now() - p0).count();
    // The output keeps the input's G-buffer and camera metadata; only color is replaced.
    f.color = std::move(resolved);
    const std::string out_path =
        (std::filesystem::path(a.out) / std::filesystem::path(path).filename()).string();
    io::write_frame(out_path, f, &inputs);
    if (tty)
      std::fprintf(stderr, "\rresolve %s: frame %zu/%zu", a.preset.c_str(), i + 1, files.size());
    else
      std::fprintf(stderr, "resolve %s: frame %zu/%zu -> %s\n", a.preset.c_str(), i + 1,
                   files.size(), out_path.c_str());
    std::fflush(stderr);
  }
  if (tty) std::fprintf(stderr, "\n");
  if (!a.save_state.empty()) resolver.save_state(a.save_state);
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  fmt::print("resolved {} frames with preset {} to {} in {:.1f} s ({:.2f} ms/frame in TAA)\n",
             files.size(), a.preset, a.out, wall, 1e3 * process_seconds / double(files.size()));
}

}  // namespace

void add_resolve_command(CLI::App& app, Context& ctx) {
  auto* sub = app.add_subcommand("resolve", "temporal anti-aliasing (TAA) of a frame sequence");
  auto a = std::make_shared<ResolveArgs>();
  sub->add_option("--in", a->in,
                  "input sequence directory: DIR/NAME.%04d.exr with color, Z, motion");
  sub->add_option("--out", a->out, "output directory (same file names; never the input files)");
  sub->add_option("--name", a->name, "sequence file name stem")->capture_default_str();
  sub->add_option("--preset", a->preset,
                  "afterimage | none | uncharted4 | ue4 | inside | hdrp | variance")
      ->capture_default_str();
  sub->add_option("--set", a->sets, "override a setting: key=value (repeatable)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sub->add_option("--save-state", a->save_state, "write the resolver state after the last frame");
  sub->add_option("--load-state", a->load_state, "start from a saved resolver state");
  sub->add_flag("--list-settings", a->list_settings,
                "print every setting (value, default, range) of the preset + overrides and exit");
  sub->add_flag("--markdown", a->markdown,
                "with --list-settings: print the settings table (key, default, range, doc) as "
                "markdown");
  sub->callback([a, &ctx] { run_resolve(*a, ctx.exec); });
}

}  // namespace afterimage::cli
