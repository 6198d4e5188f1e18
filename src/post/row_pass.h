// A per-pixel pass (tonemap) run in place on each finished output row of the pass before it,
// instead of as a pass of its own over the whole frame: the same values, without writing the
// frame to memory and reading it back (DESIGN.md §5, speed pass 10). The pass before it calls
// it once per output row, after the row's last write, from any thread (rows concurrently).
#pragma once

#include <functional>

#include "core/image.h"
#include "core/parallel.h"

namespace afterimage::post {

// rows: the 3 planes of one output row, `width` pixels each; rewritten in place.
using RowPass = std::function<void(float* const* rows, int width)>;

// `img` (3 planes) with `pass` run on every row: what a pass that cannot fuse it does.
inline ImageF apply_row_pass(ImageF img, const RowPass& pass, const Exec& exec) {
  parallel_rows(exec, img.height(), [&](int y) {
    float* const rows[3] = {img.row(0, y), img.row(1, y), img.row(2, y)};
    pass(rows, img.width());
  });
  return img;
}

}  // namespace afterimage::post
