// The 2x2 bilinear footprint of a history position: the four previous-frame pixels whose
// centers surround it, their flat indices (for gathers) and their bilinear weights.
#pragma once

#include "core/lanes.h"

namespace afterimage::reproject {

// Flat index of pixel (ix, iy) (integer-valued floats), clamped to the image.
template <class D>
HWY_INLINE VI<D> clamped_pixel_index(D d, int width, int height, V<D> ix, V<D> iy) {
  const hn::RebindToSigned<D> di;
  ix = hn::Min(hn::Max(ix, hn::Zero(d)), hn::Set(d, float(width - 1)));
  iy = hn::Min(hn::Max(iy, hn::Zero(d)), hn::Set(d, float(height - 1)));
  return hn::Add(hn::Mul(hn::ConvertTo(di, iy), hn::Set(di, width)), hn::ConvertTo(di, ix));
}

// Flat index of the pixel containing (x, y) (HLSL Load), clamped to the image.
template <class D>
HWY_INLINE VI<D> nearest_pixel_index(D d, int width, int height, V<D> x, V<D> y) {
  return clamped_pixel_index(d, width, height, hn::Floor(x), hn::Floor(y));
}

// The 2x2 pixels whose centers surround (x, y) and the bilinear fractions.
template <class D>
struct Footprint {
  VI<D> i00, i10, i01, i11;
  V<D> fx, fy;
};
template <class D>
HWY_INLINE Footprint<D> bilinear_footprint(D d, int width, int height, V<D> x, V<D> y) {
  const auto half = hn::Set(d, 0.5f), one = hn::Set(d, 1.0f);
  auto tx = hn::Sub(x, half), ty = hn::Sub(y, half);
  auto x0 = hn::Floor(tx), y0 = hn::Floor(ty);
  auto x1 = hn::Add(x0, one), y1 = hn::Add(y0, one);
  return {clamped_pixel_index(d, width, height, x0, y0),
          clamped_pixel_index(d, width, height, x1, y0),
          clamped_pixel_index(d, width, height, x0, y1),
          clamped_pixel_index(d, width, height, x1, y1),
          hn::Sub(tx, x0),
          hn::Sub(ty, y0)};
}

// Per-tap weights of a footprint, in tap order 00, 10, 01, 11.
template <class D>
struct TapWeights {
  V<D> w[4];
};
// Bilinear weights (1-fx)(1-fy), fx(1-fy), (1-fx)fy, fx fy: they sum to 1 (up to rounding).
template <class D>
HWY_INLINE TapWeights<D> bilinear_tap_weights(D d, V<D> fx, V<D> fy) {
  const auto one = hn::Set(d, 1.0f);
  const auto gx = hn::Sub(one, fx), gy = hn::Sub(one, fy);
  return {{hn::Mul(gx, gy), hn::Mul(fx, gy), hn::Mul(gx, fy), hn::Mul(fx, fy)}};
}

}  // namespace afterimage::reproject
