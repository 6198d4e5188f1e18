// Deterministic parallel loops over rows (DESIGN.md §2: results are bit-identical for any
// thread count). Every row is computed by the same code whatever thread runs it; reductions
// use per-row partials combined in row order.
#pragma once

#include <type_traits>
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

// A non-owning reference to a callable taking (y0, y1): what parallel_row_ranges hands to
// the TBB loop in parallel.cpp, so that this header, which every pass includes, does not
// include TBB (about 55,000 more preprocessed lines in every file that includes it).
class RowRangeBody {
 public:
  template <class Body>
  explicit RowRangeBody(Body& body)
      : object_(static_cast<void*>(&body)),
        call_([](void* o, int y0, int y1) { (*static_cast<Body*>(o))(y0, y1); }) {}
  void operator()(int y0, int y1) const { call_(object_, y0, y1); }

 private:
  void* object_;
  void (*call_)(void*, int, int);
};

// parallel_row_ranges' loop (parallel.cpp): TBB over [0, height) with grain 1, in an arena of
// ex.threads threads where that differs from the current arena's.
void run_row_ranges(const Exec& ex, int height, RowRangeBody body);

// Calls body(y0, y1) on contiguous ranges of rows that cover [0, height) once, in parallel: a
// body that walks its rows in order knows which row comes next on its thread (motion blur's
// TileMax prefetches it).
template <class Body>
void parallel_row_ranges(const Exec& ex, int height, Body&& body) {
  if (ex.threads == 1) {
    if (height > 0) body(0, height);
    return;
  }
  std::remove_reference_t<Body>& b = body;
  run_row_ranges(ex, height, RowRangeBody(b));
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
