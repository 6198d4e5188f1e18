// One row-loop helper for per-pixel kernels written once as templates on a Highway
// descriptor `d` (tev's simdFor habit, DESIGN.md §6). The body runs at full SIMD width and
// then at 1 lane (CappedTag<float, 1>) for the tail. With Exec::simd == false every pixel
// takes the 1-lane path: that is the reference path the tests compare against.
#pragma once

#include <hwy/highway.h>

#include "core/parallel.h"

namespace afterimage {
namespace hn = hwy::HWY_NAMESPACE;

using FullTag = hn::ScalableTag<float>;
using OneTag = hn::CappedTag<float, 1>;

// Calls body(d, x) for x in [0, width): with a full-width tag while a whole vector fits
// (only if ex.simd), then with a 1-lane tag. `body` is a generic lambda.
template <class Body>
inline void for_each_lane_block(const Exec& ex, int width, Body&& body) {
  int x = 0;
  if (ex.simd) {
    const FullTag d;
    const int n = int(hn::Lanes(d));
    for (; x + n <= width; x += n) body(d, x);
  }
  const OneTag d1;
  for (; x < width; ++x) body(d1, x);
}

// Pixel-center x coordinates x + 0.5, x + 1.5, ... of the lanes of a block starting at x.
template <class D>
inline hn::Vec<D> pixel_center_x(D d, int x) {
  return hn::Add(hn::Iota(d, float(x)), hn::Set(d, 0.5f));
}

}  // namespace afterimage
