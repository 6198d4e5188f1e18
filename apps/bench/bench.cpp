#include "apps/bench/bench.h"

#include <tbb/info.h>

#include <algorithm>
#include <chrono>
#include <tuple>
#include <utility>

#include "core/image.h"
#include "core/simd.h"

namespace afterimage {

BenchTiming time_runs(int repeats, const std::function<void()>& fn) {
  fn();  // warm-up: first touch of memory, caches, thread pool start
  std::vector<double> ms;
  for (int i = 0; i < std::max(1, repeats); ++i) {
    auto t0 = std::chrono::steady_clock::now();
    fn();
    auto t1 = std::chrono::steady_clock::now();
    ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  return {ms[ms.size() / 2], ms.front(), ms.back()};
}

BenchTiming time_self_timed(int repeats, const std::function<double()>& fn) {
  fn();  // warm-up, as time_runs
  std::vector<double> ms;
  for (int i = 0; i < std::max(1, repeats); ++i) ms.push_back(fn());
  std::sort(ms.begin(), ms.end());
  return {ms[ms.size() / 2], ms.front(), ms.back()};
}

// The floor's software prefetch distance in floats: 64 and 128 measured alike on the 42-plane
// floor, 256 +10-20%, 512 +50%.
constexpr int kFloorPrefetchAhead = 64;

BenchTiming bandwidth_floor(const Exec& ex, int width, int height, int read_planes,
                            int write_planes, int repeats) {
  // Inputs and outputs as separate planes, like the passes' planar images.
  ImageF in(width, height, std::max(1, read_planes), 1.0f);
  ImageF out(width, height, std::max(1, write_planes));
  std::vector<float> sink(size_t(height), 0.0f);  // keeps read-only passes from being elided
  Exec full = ex;
  full.simd = true;  // the floor is the best streaming speed of this machine
  return time_runs(repeats, [&] {
    parallel_rows(full, height, [&](int y) {
      float row_sum = 0.0f;
      for_each_lane_block(full, width, [&](auto d, int x) {
        // One line of every plane kFloorPrefetchAhead floats ahead: with many planes (the
        // default TAA preset streams 42) the hardware prefetchers alone fall behind (its
        // floor measured 32.7 ms on 1 thread at 1080p without, 26 with; 17 planes: 9.9, 9.3).
        if (x + kFloorPrefetchAhead < width) {
          for (int c = 0; c < read_planes; ++c)
            __builtin_prefetch(in.row(c, y) + x + kFloorPrefetchAhead);
          for (int c = 0; c < write_planes; ++c)
            __builtin_prefetch(out.row(c, y) + x + kFloorPrefetchAhead, 1);
        }
        auto s = hn::Zero(d);
        for (int c = 0; c < read_planes; ++c) s = hn::Add(s, hn::LoadU(d, in.row(c, y) + x));
        for (int c = 0; c < write_planes; ++c) hn::StoreU(s, d, out.row(c, y) + x);
        if (write_planes == 0) row_sum += hn::GetLane(hn::SumOfLanes(d, s));
      });
      sink[size_t(y)] = row_sum;
    });
  });
}

bool bench_filter_matches(const std::string& filter, const std::string& name) {
  // A trailing '$' anchors the match at the end ("post.dof$": not post.dof.half).
  if (!filter.empty() && filter.back() == '$') {
    const std::string f = filter.substr(0, filter.size() - 1);
    return name.size() >= f.size() && name.find(f, name.size() - f.size()) != std::string::npos;
  }
  return name.find(filter) != std::string::npos;
}

std::vector<BenchRow> run_bench(const std::vector<BenchPass>& passes, const BenchSettings& s,
                                const std::function<void(const BenchRow&)>& on_row) {
  std::vector<BenchRow> rows;
  const int all = tbb::info::default_concurrency();
  std::vector<int> thread_counts = {1};
  if (all > 1) thread_counts.push_back(all);
  // A new process runs its first passes several times slower for a while (this VM: the first
  // row, post.dof at 960x540 on one thread, had medians of 4.6 to 27.9 ms over 7 repeats in four
  // processes, min 2.5; 2.5-2.6 with 31 or more repeats), beyond what one warm-up call absorbs:
  // the first pass runs untimed for half a second before any row is timed.
  bool settled = false;
  for (auto [w, h] : s.sizes) {
    for (const auto& p : passes) {
      if (!bench_filter_matches(s.filter, p.name)) continue;
      if (!p.sizes.empty() &&
          std::find(p.sizes.begin(), p.sizes.end(), std::pair<int, int>(w, h)) == p.sizes.end())
        continue;
      p.prepare(w, h);
      if (!settled) {
        const auto t0 = std::chrono::steady_clock::now();
        Exec ex;
        ex.threads = thread_counts.front();
        ex.simd = s.simd;
        do {
          if (p.self_timed_run)
            p.self_timed_run(ex);
          else
            p.run(ex);
        } while (std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(500));
        settled = true;
      }
      int read_planes = p.read_planes, write_planes = p.write_planes;
      if (p.streamed_planes) {
        const auto [r, wr] = p.streamed_planes();
        if (r + wr > 0) std::tie(read_planes, write_planes) = std::pair(r, wr);
      }
      for (int t : thread_counts) {
        if (p.all_threads_only && t != thread_counts.back()) continue;
        Exec ex;
        ex.threads = t;
        ex.simd = s.simd;
        BenchRow r;
        r.pass = p.name;
        r.width = w;
        r.height = h;
        r.threads = t;
        if (p.floor_run) {
          // Files: fewer repeats (a run is a whole sequence); floor first, then the pass. The
          // floor is a run, not planes (read_planes / write_planes stay 0).
          const int reps = std::max(1, std::min(s.repeats, 3));
          r.floor = time_runs(reps, [&] { p.floor_run(ex); });
          r.time = time_runs(reps, [&] { p.run(ex); });
        } else {
          r.read_planes = read_planes;
          r.write_planes = write_planes;
          r.floor = bandwidth_floor(ex, w, h, read_planes, write_planes, s.repeats);
          for (double* v : {&r.floor.median_ms, &r.floor.min_ms, &r.floor.max_ms})
            *v *= p.floor_sweeps;
          r.time = p.self_timed_run
                       ? time_self_timed(s.repeats, [&] { return p.self_timed_run(ex); })
                       : time_runs(s.repeats, [&] { p.run(ex); });
        }
        for (BenchTiming* bt : {&r.floor, &r.time}) {
          bt->median_ms /= p.frames_per_run;
          bt->min_ms /= p.frames_per_run;
          bt->max_ms /= p.frames_per_run;
        }
        rows.push_back(r);
        if (on_row) on_row(r);
      }
    }
  }
  return rows;
}

nlohmann::json bench_to_json(const std::vector<BenchRow>& rows) {
  nlohmann::json j = nlohmann::json::array();
  for (const auto& r : rows)
    j.push_back({{"pass", r.pass},
                 {"width", r.width},
                 {"height", r.height},
                 {"threads", r.threads},
                 {"median_ms", r.time.median_ms},
                 {"min_ms", r.time.min_ms},
                 {"max_ms", r.time.max_ms},
                 {"floor_median_ms", r.floor.median_ms},
                 {"floor_read_planes", r.read_planes},
                 {"floor_write_planes", r.write_planes},
                 {"ratio_to_floor", r.ratio()}});
  return j;
}

}  // namespace afterimage
