// A pass run in place on each finished output row of the pass before it, instead of as a pass
// of its own over the whole frame: a per-pixel pass (tonemap), or one that adds light computed
// beforehand (flare's, into bloom's rows). The same values, without writing the frame to memory
// and reading it back (7be56e8, 80c79fa: `post.chain`; docs/perf/2026-log.md).
#pragma once

#include <algorithm>
#include <functional>
#include <type_traits>
#include <utility>

#include "core/image.h"
#include "core/parallel.h"

namespace afterimage::post {

// Called on pixels x0 .. x0 + n - 1 of row y's 3 planes (rows[c] points at pixel x0), after
// their last write; rewrites them in place. One task's rows come in increasing y, each row in
// pieces in increasing x0 that cover it, the first at x0 = 0. The passes that fuse a RowPass
// hand a row in pieces of kRowPiece pixels, which the pass and the RowFns after it then read and
// write while they stay in the first-level cache (a whole 1080p row's three planes, 23 KB, and
// flare's two upsampled texel rows, 46 KB, had outgrown it: 985efe1, `post.chain`).
using RowFn = std::function<void(int y, int x0, float* const* rows, int n)>;
inline constexpr int kRowPiece = 256;
// f(x0, n) for the pieces of a row `width` pixels wide, in increasing x0.
template <class F>
void for_each_row_piece(int width, F&& f) {
  for (int x0 = 0; x0 < width; x0 += kRowPiece) f(x0, std::min(kRowPiece, width - x0));
}
// Gives each task of the pass before it a RowFn of its own (which may keep scratch between
// the task's rows); tasks run concurrently. Called like the function it holds; empty: none.
//
// A pass that reads its input row by row (bloom's first downsample) may also hand each input
// row to `input_row` while the row is still in the cache (from its tasks, in any order; a row
// read twice may come twice, and a repeat must change nothing), and then call `input_done` once
// before any RowFn is made: flare's bright pass scans the radiance so instead of reading the
// whole frame again (c406a18, `post.chain`). A RowPass must give the same rows whether or
// not they come (flare then reads them itself).
//
// A RowPass reads its input (the image object it was made from) no more once any call of
// `make` has returned (flare's waits for its light, the only thing that reads it), and the
// pass before it makes each task's RowFn before the task writes a row: a pass that owns its
// input may then write its output over the input's pixels (bloom, flare: their ImageF&&
// overloads) without changing what the RowPass reads. It must not move the object away before
// a RowFn has been made (flare's light would find it empty).
struct RowPass {
  std::function<RowFn()> make;
  std::function<void(int y)> input_row;
  std::function<void()> input_done;

  RowPass() = default;
  // A RowFn factory alone (no input rows wanted).
  template <class F,
            class = std::enable_if_t<std::is_convertible_v<std::invoke_result_t<F&>, RowFn>>>
  RowPass(F f) : make(std::move(f)) {}  // NOLINT: implicit, as the function it wraps
  explicit operator bool() const { return bool(make); }
  RowFn operator()() const { return make(); }
};

// `first`, then `second`, on each row (and each of their input hooks).
inline RowPass row_pass_then(RowPass first, RowPass second) {
  if (!first) return second;
  if (!second) return first;
  RowPass both([a = first.make, b = second.make]() -> RowFn {
    return [a = a(), b = b()](int y, int x0, float* const* rows, int n) {
      a(y, x0, rows, n);
      b(y, x0, rows, n);
    };
  });
  if (first.input_row || second.input_row)
    both.input_row = [a = first.input_row, b = second.input_row](int y) {
      if (a) a(y);
      if (b) b(y);
    };
  if (first.input_done || second.input_done)
    both.input_done = [a = first.input_done, b = second.input_done] {
      if (a) a();
      if (b) b();
    };
  return both;
}

// `pass` run on every row of `img` (3 planes), in place: what a pass that cannot fuse it
// does. Bands of rows a task, in increasing y (a RowFn's scratch serves consecutive rows), each
// task's RowFn made before it writes. An empty pass changes nothing.
inline void apply_row_pass_in_place(ImageF& img, const RowPass& pass, const Exec& exec) {
  if (!pass) return;
  constexpr int kBand = 8;
  parallel_rows(exec, (img.height() + kBand - 1) / kBand, [&](int band) {
    const RowFn fn = pass();
    for (int y = band * kBand; y < std::min(img.height(), (band + 1) * kBand); ++y)
      for_each_row_piece(img.width(), [&](int x0, int n) {
        float* const rows[3] = {img.row(0, y) + x0, img.row(1, y) + x0, img.row(2, y) + x0};
        fn(y, x0, rows, n);
      });
  });
}
// The same, returning the image (a pass that cannot fuse `pass` and made a new one).
inline ImageF apply_row_pass(ImageF img, const RowPass& pass, const Exec& exec) {
  apply_row_pass_in_place(img, pass, exec);
  return img;
}

}  // namespace afterimage::post
