// Input sanitising shared by every pass that reads rendered frames: NaN / Inf / negative
// values must never enter history or a filter (one bad pixel would otherwise spread through
// every later frame).
#pragma once

#include "core/image.h"
#include "core/parallel.h"
#include "core/simd.h"

namespace afterimage {

// Non-finite depth is background (DESIGN.md §3: loaders map it to kBackgroundDepth).
template <class D>
HWY_INLINE hn::Vec<D> sanitize_depth(D d, hn::Vec<D> depth, float background) {
  return hn::IfThenElse(hn::IsFinite(depth), depth, hn::Set(d, background));
}

// True if any value of the 3-channel color is negative or not finite (the sanitize pass is
// then needed).
bool needs_sanitize(const ImageF& color, const Exec& ex);
// The same test for row y only (passes that check rows as they stream them, then sanitize and
// redo the frame in the rare case one needs it).
bool row_needs_sanitize(const ImageF& color, int y);

// Sanitises a 3-channel color if needs_sanitize: a non-finite value becomes the mean of the
// finite (negative-clamped) 3x3 neighbours of its channel, 0 if none; a negative value
// becomes 0. `invalid` (1 channel) is 1 where any channel was not finite, else 0. `out` and
// `invalid` are reallocated only if their shape differs. Returns false, touching nothing,
// when the color is already clean.
bool sanitize_color(const ImageF& color, ImageF& out, ImageF& invalid, const Exec& ex);

}  // namespace afterimage
