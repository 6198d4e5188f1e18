// Where a pixel's history is: the position p + motion in the previous frame (DESIGN.md §3:
// motion = p_prev - p_curr in pixels of the current frame, y down; the history value for
// pixel center p is read at p + motion) and whether it is on screen. Two forms, with
// different on-screen tests on purpose:
//  - history_position (lanes, resampling callers such as TAA): closed test 0 <= x <= w,
//    0 <= y <= h. A position on the right / bottom edge still has a bilinear footprint
//    (clamped into the image), so it is kept.
//  - nearest_history_pixel (scalar, nearest-pixel callers such as the disocclusion metrics):
//    half-open test 0 <= x < w, 0 <= y < h, the pixel whose footprint [i, i+1) contains the
//    position (DESIGN.md §3); x == w belongs to no pixel.
#pragma once

#include <optional>

#include "core/lanes.h"

namespace afterimage::reproject {

template <class D>
struct HistoryPosition {
  V<D> x, y;             // p + motion, clamped to [-2, w + 2] x [-2, h + 2] for fetching
  hn::Mask<D> onscreen;  // closed test on the unclamped position
};

// History position of the lanes at pixels (x.., y) with motion (mx, my). Off-screen
// positions are to be rejected by the caller; their fetch coordinates are still kept small
// and finite (a gather index must not overflow). A non-finite motion is off-screen (every
// comparison with NaN is false); callers that map unknown motion to a huge value get the
// same.
template <class D>
HWY_INLINE HistoryPosition<D> history_position(D d, int x, int y, V<D> mx, V<D> my, int width,
                                               int height) {
  const auto zero = hn::Zero(d);
  auto px = hn::Add(pixel_center_x(d, x), mx);
  auto py = hn::Add(hn::Set(d, float(y) + 0.5f), my);
  const auto fw = hn::Set(d, float(width)), fh = hn::Set(d, float(height));
  auto onscreen =
      hn::And(hn::And(hn::Ge(px, zero), hn::Le(px, fw)), hn::And(hn::Ge(py, zero), hn::Le(py, fh)));
  px = hn::Min(hn::Max(px, hn::Set(d, -2.0f)), hn::Add(fw, hn::Set(d, 2.0f)));
  py = hn::Min(hn::Max(py, hn::Set(d, -2.0f)), hn::Add(fh, hn::Set(d, 2.0f)));
  return {px, py, onscreen};
}

struct PixelCoord {
  int x = 0, y = 0;
};

// Nearest previous-frame pixel of pixel (x, y): the pixel containing (x + 0.5, y + 0.5) +
// (mx, my), or nothing if that is off-screen (half-open test, see above) or the motion is
// not finite.
std::optional<PixelCoord> nearest_history_pixel(int x, int y, float mx, float my, int width,
                                                int height);

}  // namespace afterimage::reproject
