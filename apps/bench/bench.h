// `afterimage bench` (DESIGN.md §5): times whole passes at stated resolutions, at 1 thread
// and all threads, next to a memory-bandwidth floor measured in the same run: a streaming
// pass over exactly the bytes the pass must read and write. The ratio pass / floor is what
// to compare between runs on these noisy machines, not absolute milliseconds.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/parallel.h"

namespace afterimage {

// A pass under test. `prepare(w, h)` builds synthetic inputs (untimed); `run(exec)` is one
// frame of the pass. The floor streams `read_planes` float planes in and `write_planes` out.
struct BenchPass {
  std::string name;
  int read_planes = 0, write_planes = 0;
  std::function<void(int width, int height)> prepare;
  std::function<void(const Exec&)> run;
  // Optional: a floor measured by running this instead of the bandwidth floor (the I/O floor
  // of an end-to-end row), and a divisor turning one run's time into ms per frame.
  std::function<void(const Exec&)> floor_run;
  int frames_per_run = 1;
  // Optional: one run that reports its own time in ms (a stage inside a larger pass, by the
  // method's stage clock); replaces the wall time of `run`.
  std::function<double(const Exec&)> self_timed_run;
  // The bandwidth floor is this many streaming sweeps over read/write planes (a pass made of
  // several sweeps over the image, such as the à-trous iterations).
  int floor_sweeps = 1;
  // Optional, asked after prepare: the planes the pass itself reports streaming (a method's
  // last_traffic: they depend on its settings), replacing read_planes / write_planes when
  // non-zero.
  std::function<std::pair<int, int>()> streamed_planes;
  // Empty: every bench size; else only these sizes. all_threads_only: skip the 1-thread row.
  std::vector<std::pair<int, int>> sizes;
  bool all_threads_only = false;
};

struct BenchSettings {
  std::vector<std::pair<int, int>> sizes = {{960, 540}, {1920, 1080}, {3840, 2160}};
  int repeats = 7;     // timed runs per measurement (after one warm-up run)
  std::string filter;  // substring of pass names to run; empty = all
  bool simd = true;
};

struct BenchTiming {
  double median_ms = 0, min_ms = 0, max_ms = 0;
};
struct BenchRow {
  std::string pass;
  int width = 0, height = 0, threads = 0;
  BenchTiming time, floor;
  int read_planes = 0, write_planes = 0;  // the floor's (per sweep)
  double ratio() const { return time.median_ms / floor.median_ms; }
};

// Median / min / max of `repeats` timed calls of fn (after one warm-up call).
BenchTiming time_runs(int repeats, const std::function<void()>& fn);

// Median / min / max of `repeats` calls of fn that each return their own time in ms.
BenchTiming time_self_timed(int repeats, const std::function<double()>& fn);

// Time of a streaming pass reading `read_planes` and writing `write_planes` float planes.
BenchTiming bandwidth_floor(const Exec& ex, int width, int height, int read_planes,
                            int write_planes, int repeats);

// Whether bench's --filter selects the pass `name`: a substring of it, or with a trailing '$'
// its end.
bool bench_filter_matches(const std::string& filter, const std::string& name);

std::vector<BenchRow> run_bench(const std::vector<BenchPass>& passes, const BenchSettings& s,
                                const std::function<void(const BenchRow&)>& on_row = {});

nlohmann::json bench_to_json(const std::vector<BenchRow>& rows);

}  // namespace afterimage
