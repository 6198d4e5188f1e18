#include <fmt/format.h>

#include <stdexcept>
#include <string>

#include "apps/cli/commands.h"
#include "core/error.h"
#include "eval/evaluate.h"

namespace afterimage::cli {

void add_eval_command(CLI::App& app, Context& ctx) {
  auto* sub = app.add_subcommand(
      "eval", "score output sequences against a reference sequence (metrics JSON + HTML report)");
  auto o = std::make_shared<EvalOptions>();
  sub->add_option("--out", o->outputs, "output sequence directory (repeat to compare methods)")
      ->required();
  sub->add_option("--ref", o->reference, "reference sequence directory")->required();
  sub->add_option("--label", o->labels, "name of each --out in tables and plots (in order)");
  sub->add_option(
      "--gbuffer", o->gbuffer,
      "directory whose frames carry depth/id/motion for ghosting (default: each --out if its "
      "frames have them, else --ref)");
  sub->add_option("--layout", o->layout,
                  "how to read --ref and --gbuffer: auto, afterimage, blender[:VIEWLAYER] or a "
                  ".json file (each --out is recognised automatically)")
      ->capture_default_str();
  sub->add_option("--map", o->maps, "override one channel of --ref / --gbuffer (see resolve)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sub->add_option("--jitter", o->jitter,
                  "jitter of the --gbuffer frames when the files carry none: none | "
                  "haltonN[:start]");
  sub->add_option("--jitter-file", o->jitter_file,
                  "camera sidecar JSON of the --gbuffer frames (default: jitter.json beside "
                  "them, if any)");
  sub->add_option("--warmup", o->metrics.warmup, "frames excluded from the means")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--exposure", o->metrics.display.exposure, "exposure before the tonemap")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  auto every = std::make_shared<std::string>("1");
  sub->add_option("--every", *every,
                  "score frames t with t % N == OFFSET: N[:OFFSET] (2:1 = the frames "
                  "`extrapolate --skip 1` synthesised)")
      ->capture_default_str();
  sub->add_option("--json", o->json_path, "write per-frame and aggregate metrics as JSON");
  sub->add_option("--report", o->report_path, "write a self-contained HTML report");
  sub->callback([o, every, &ctx] {
    o->command_line = ctx.command_line;
    const size_t colon = every->find(':');
    try {
      size_t used = 0;
      o->every = std::stoi(every->substr(0, colon), &used);
      if (used != every->substr(0, colon).size()) throw std::invalid_argument("trailing");
      o->every_offset = 0;
      if (colon != std::string::npos) {
        const std::string off = every->substr(colon + 1);
        o->every_offset = std::stoi(off, &used);
        if (used != off.size()) throw std::invalid_argument("trailing");
      }
    } catch (const std::exception&) {
      throw SettingsError(fmt::format("--every '{}': expected N or N:OFFSET (integers)", *every));
    }
    o->note = print_note;
    EvalResult r = run_eval(*o, ctx.exec);
    fmt::print("reference {} (layout {})\n", o->reference, r.reference_layout);
    fmt::print("{}", format_eval_table(r.methods));
    if (!o->json_path.empty()) fmt::print("json: {}\n", o->json_path);
    if (!o->report_path.empty()) fmt::print("report: {}\n", o->report_path);
  });
}

}  // namespace afterimage::cli
