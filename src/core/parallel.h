// Deterministic parallel loops over rows (DESIGN.md §2: results are bit-identical for any
// thread count). Every row is computed by the same code whatever thread runs it; reductions
// use per-row partials combined in row order.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <functional>
#include <vector>

#include "core/limits.h"

namespace afterimage {

// How a pass executes. Passed explicitly: there is no global state.
struct Exec {
  int threads = 0;   // 0 = all hardware threads
  bool simd = true;  // false = every pixel through the 1-lane reference path (--simd off)

  // Defaults from the environment: AFTERIMAGE_SIMD=off, AFTERIMAGE_THREADS=N.
  static Exec from_env();
};

// Calls body(y0, y1) on contiguous ranges of rows that cover [0, height) once, in parallel: a
// body that walks its rows in order knows which row comes next on its thread (motion blur's
// TileMax prefetches it).
template <class Body>
void parallel_row_ranges(const Exec& ex, int height, Body&& body) {
  auto run = [&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, height, 1),
                      [&](const tbb::blocked_range<int>& r) { body(r.begin(), r.end()); });
  };
  if (ex.threads == 1) {
    if (height > 0) body(0, height);
  } else if (ex.threads > 1 && ex.threads != tbb::this_task_arena::max_concurrency()) {
    // Clamped for library callers (the CLI refuses larger counts): results do not depend on
    // the thread count, and an arena of ~70000 threads crashes inside TBB.
    // Only when the count differs from the current arena's: a new arena per call costs ~40 us
    // more than running in the current one (2 threads, a 16-row loop: 68-80 against 35-44 us),
    // and the post chain makes 43 such calls a frame (counted in gdb), many over small images.
    tbb::task_arena arena(std::min(ex.threads, kMaxThreads));
    arena.execute(run);
  } else {
    run();
  }
}

// Calls body(y) for every row y in [0, height), in parallel.
template <class Body>
void parallel_rows(const Exec& ex, int height, Body&& body) {
  parallel_row_ranges(ex, height, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) body(y);
  });
}

// Sum over rows of row_value(y), combined in row order (deterministic for any thread count).
template <class RowValue>
double parallel_sum_rows(const Exec& ex, int height, RowValue&& row_value) {
  std::vector<double> partial(size_t(height > 0 ? height : 0), 0.0);
  parallel_rows(ex, height, [&](int y) { partial[size_t(y)] = row_value(y); });
  double s = 0.0;
  for (double v : partial) s += v;
  return s;
}

}  // namespace afterimage
