// Per-tap consistency tests of reprojection: is the previous-frame surface under a footprint
// tap the same surface as the current pixel's? (Nehab et al. 2007, reverse reprojection
// cache; Schied et al. 2017, SVGF Sec. 4.1; seed 000 "拒绝" for TAA.) Each test returns a lane
// mask; callers combine them per tap, then either accept history if any weighted tap passes
// (TAA) or renormalise the bilinear weights over the passing taps (SVGF, the cache).
#pragma once

#include "core/lanes.h"
#include "reproject/footprint.h"

namespace afterimage::reproject {

// Relative depth test |d_prev - d| <= tol * d: linear view depth grows with distance, so the
// tolerance does too (TAA's depth rejection).
template <class D>
HWY_INLINE hn::Mask<D> depth_within_relative(D d, V<D> prev, V<D> cur, float rel_tol) {
  return hn::Le(hn::Abs(hn::Sub(prev, cur)), hn::Mul(hn::Set(d, rel_tol), cur));
}

// Slope-scaled depth test |d_prev - d| <= tol * d + slope_scale * |grad d| * distance, with
// |grad d| the current depth's screen-space gradient length (depth units per pixel) and
// `distance` the tap's distance in pixels from the history position. A surface seen at a
// grazing angle changes depth quickly across a pixel, so a fixed relative tolerance rejects
// its own neighbouring taps; SVGF scales the tolerance by the depth derivative (Schied et al.
// 2017, Sec. 4.1 and their reference isReprjValid: |Z - Z_prev| / (fwidth(Z) + 0.01) > 10
// rejects).
template <class D>
HWY_INLINE hn::Mask<D> depth_within_slope(D d, V<D> prev, V<D> cur, float rel_tol,
                                          float slope_scale, V<D> gradient_length, V<D> distance) {
  const auto slope = hn::Mul(hn::Mul(hn::Set(d, slope_scale), gradient_length), distance);
  return hn::Le(hn::Abs(hn::Sub(prev, cur)), hn::Add(hn::Mul(hn::Set(d, rel_tol), cur), slope));
}

// Normal test dot(n_prev, n) >= cos(max angle) (SVGF Sec. 4.1; normals are unit length,
// DESIGN.md §3; xyz in c0 c1 c2).
template <class D>
HWY_INLINE hn::Mask<D> normal_within_angle(D d, const Color3<D>& n_prev, const Color3<D>& n,
                                           float cos_max_angle) {
  const auto dot =
      hn::MulAdd(n_prev.c0, n.c0, hn::MulAdd(n_prev.c1, n.c1, hn::Mul(n_prev.c2, n.c2)));
  return hn::Ge(dot, hn::Set(d, cos_max_angle));
}

// Object id test (ids are uint32 lanes, DESIGN.md §3).
template <class DU>
HWY_INLINE hn::Mask<DU> id_matches(DU, hn::Vec<DU> prev, hn::Vec<DU> cur) {
  return hn::Eq(prev, cur);
}

// Motion test |m_prev - m|^2 <= tol^2 (pixels): the previous surface moved like this one.
template <class D>
HWY_INLINE hn::Mask<D> motion_within(D, V<D> prev_mx, V<D> prev_my, V<D> mx, V<D> my, V<D> tol2) {
  auto dx = hn::Sub(prev_mx, mx);
  auto dy = hn::Sub(prev_my, my);
  return hn::Le(hn::MulAdd(dx, dx, hn::Mul(dy, dy)), tol2);
}

// Taps that carry weight: a tap of zero weight contributes no history, so it can neither
// validate nor invalidate it.
template <class D>
HWY_INLINE void taps_used(D d, const TapWeights<D>& w, hn::Mask<D> (&used)[4]) {
  for (int i = 0; i < 4; ++i) used[i] = hn::Gt(w.w[i], hn::Zero(d));
}

// True where any used tap passes (TAA: reprojection onto an edge is not falsely rejected
// when one of the four previous pixels is the same surface).
template <class D>
HWY_INLINE hn::Mask<D> any_used_tap_passes(D d, const hn::Mask<D> (&used)[4],
                                           const hn::Mask<D> (&pass)[4]) {
  auto any = hn::Lt(hn::Zero(d), hn::Zero(d));  // all false
  for (int i = 0; i < 4; ++i) any = hn::Or(any, hn::And(used[i], pass[i]));
  return any;
}

// Bilinear weights renormalised over the taps that pass (Nehab et al. 2007; SVGF Sec. 4.1):
// failing taps get 0, the others w_i / sum of passing w; `any` is false (and every weight 0)
// where no tap with weight passes.
template <class D>
struct RenormalizedWeights {
  TapWeights<D> weights;
  hn::Mask<D> any;
};
template <class D>
HWY_INLINE RenormalizedWeights<D> renormalize_weights(D d, const TapWeights<D>& w,
                                                      const hn::Mask<D> (&pass)[4]) {
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  RenormalizedWeights<D> r;
  auto sum = zero;
  for (int i = 0; i < 4; ++i) {
    r.weights.w[i] = hn::IfThenElse(pass[i], w.w[i], zero);
    sum = hn::Add(sum, r.weights.w[i]);
  }
  r.any = hn::Gt(sum, zero);
  const auto inv = hn::Div(one, hn::IfThenElse(r.any, sum, one));
  for (int i = 0; i < 4; ++i) r.weights.w[i] = hn::Mul(r.weights.w[i], inv);
  return r;
}

}  // namespace afterimage::reproject
