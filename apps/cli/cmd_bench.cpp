#include <fmt/format.h>

#include <algorithm>
#include <string>
#include <vector>

#include "apps/bench/bench_passes.h"
#include "apps/cli/commands.h"
#include "core/error.h"
#include "io/io.h"

namespace afterimage::cli {

void add_bench_command(CLI::App& app, Context& ctx) {
  auto* sub = app.add_subcommand(
      "bench",
      "time every pass at 960x540, 1920x1080, 3840x2160 (1 and all threads) against a "
      "memory-bandwidth floor measured in the same run");
  auto s = std::make_shared<BenchSettings>();
  auto sizes = std::make_shared<std::vector<std::string>>();
  auto json = std::make_shared<std::string>();
  sub->add_option("--sizes", *sizes, "sizes WxH (default 960x540,1920x1080,3840x2160)")
      ->delimiter(',');
  sub->add_option("--repeats", s->repeats, "timed runs per measurement (median reported)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  sub->add_option("--filter", s->filter,
                  "only passes whose name contains this (a trailing $ anchors it at the end)");
  sub->add_option("--json", *json, "also write the rows as JSON");
  sub->callback([s, sizes, json, &ctx] {
    if (!sizes->empty()) {
      s->sizes.clear();
      for (const auto& t : *sizes) {
        int w = 0, h = 0;
        parse_size(t, &w, &h);
        s->sizes.push_back({w, h});
      }
    }
    s->simd = ctx.exec.simd;
    const std::vector<BenchPass> passes = all_bench_passes();
    size_t name_width = 28;  // the pass column fits the longest name
    for (const auto& p : passes) name_width = std::max(name_width, p.name.size());
    // "planes": the floor's read / written planes per pixel (per sweep).
    fmt::print("{:<{}} {:>9} {:>3} {:>10} {:>10} {:>10} {:>10} {:>7} {:>8}\n", "pass", name_width,
               "size", "thr", "median ms", "min ms", "max ms", "floor ms", "planes", "ratio");
    auto rows = run_bench(passes, *s, [name_width](const BenchRow& r) {
      fmt::print("{:<{}} {:>9} {:>3} {:>10.2f} {:>10.2f} {:>10.2f} {:>10.3f} {:>7} {:>8.1f}\n",
                 r.pass, name_width, fmt::format("{}x{}", r.width, r.height), r.threads,
                 r.time.median_ms, r.time.min_ms, r.time.max_ms, r.floor.median_ms,
                 r.read_planes + r.write_planes > 0
                     ? fmt::format("{}/{}", r.read_planes, r.write_planes)
                     : std::string("-"),  // a floor that is a run (end to end), not planes
                 r.ratio());
      std::fflush(stdout);
    });
    if (rows.empty()) throw SettingsError(fmt::format("bench: no pass matches '{}'", s->filter));
    if (!json->empty()) {
      io::write_text(*json, bench_to_json(rows).dump(2) + "\n");
      fmt::print("json: {}\n", *json);
    }
  });
}

}  // namespace afterimage::cli
