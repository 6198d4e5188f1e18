// A pass run in place on each finished output row of the pass before it, instead of as a pass
// of its own over the whole frame: a per-pixel pass (tonemap), or one that adds light computed
// beforehand (flare's, into bloom's rows). The same values, without writing the frame to memory
// and reading it back (DESIGN.md §5, speed passes 10 and 11).
#pragma once

#include <algorithm>
#include <functional>
#include <utility>

#include "core/image.h"
#include "core/parallel.h"

namespace afterimage::post {

// Called on row y's 3 planes (`width` pixels each), after the row's last write; rewrites them
// in place. One task's rows come in increasing y.
using RowFn = std::function<void(int y, float* const* rows, int width)>;
// Gives each task of the pass before it a RowFn of its own (which may keep scratch between
// the task's rows); tasks run concurrently.
using RowPass = std::function<RowFn()>;

// `first`, then `second`, on each row.
inline RowPass row_pass_then(RowPass first, RowPass second) {
  if (!first) return second;
  if (!second) return first;
  return [first = std::move(first), second = std::move(second)]() -> RowFn {
    return [a = first(), b = second()](int y, float* const* rows, int width) {
      a(y, rows, width);
      b(y, rows, width);
    };
  };
}

// `img` (3 planes) with `pass` run on every row: what a pass that cannot fuse it does. Bands
// of rows a task, in increasing y (a RowFn's scratch serves consecutive rows).
inline ImageF apply_row_pass(ImageF img, const RowPass& pass, const Exec& exec) {
  constexpr int kBand = 8;
  parallel_rows(exec, (img.height() + kBand - 1) / kBand, [&](int band) {
    const RowFn fn = pass();
    for (int y = band * kBand; y < std::min(img.height(), (band + 1) * kBand); ++y) {
      float* const rows[3] = {img.row(0, y), img.row(1, y), img.row(2, y)};
      fn(y, rows, img.width());
    }
  });
  return img;
}

}  // namespace afterimage::post
