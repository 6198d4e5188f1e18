// Per-pixel building blocks of temporal upsampling (TAAU), templated on a Highway
// descriptor like taa/taa_kernels.h (DESIGN.md §6): they run full-width and at 1 lane (the
// reference path, Exec::simd == false). Rectification, boxes and blends are reused from
// taa/taa_kernels.h; what is new is where a low-resolution sample lands in the output grid
// and how much it counts there.
//
// Coordinates (DESIGN.md §3 applied at each resolution): input pixel (i, j) of a frame with
// jitter (jx, jy) took its sample at input position (i + 0.5 + jx, j + 0.5 + jy); the input
// image [0, w] x [0, h] covers the same view as the output [0, W] x [0, H], so a position p
// in input pixels is p * (W / w, H / h) in output pixels. Output pixel (X, Y) has its center
// at (X + 0.5, Y + 0.5).
#pragma once

#include <hwy/contrib/math/math-inl.h>

#include <cmath>

#include "core/lanes.h"
#include "core/math.h"
#include "taau/settings.h"

namespace afterimage::taau {

// ----------------------------------------------------------------------------------------
// Coordinate mapping (scalar forms: the closed-form reference of the lane code below)
// ----------------------------------------------------------------------------------------

// Output-pixel position of the sample of input pixel (i, j): (i + 0.5 + jitter) * scale.
inline Vec2f sample_position_in_output(int i, int j, Vec2f jitter, Vec2f scale) {
  return {(float(i) + 0.5f + jitter.x) * scale.x, (float(j) + 0.5f + jitter.y) * scale.y};
}

// Input-pixel position of the center of output pixel (X, Y): (X + 0.5) / scale.
inline Vec2f output_center_in_input(int x, int y, Vec2f inv_scale) {
  return {(float(x) + 0.5f) * inv_scale.x, (float(y) + 0.5f) * inv_scale.y};
}

// The input pixel whose jittered sample is nearest to input position q along one axis:
// sample i sits at i + 0.5 + jitter, so i = floor(q - jitter) (clamped to [0, n - 1]).
inline int nearest_sample_index(float q, float jitter, int n) {
  const int i = int(std::floor(q - jitter));
  return i < 0 ? 0 : (i > n - 1 ? n - 1 : i);
}

// Motion vectors of the input are in input pixels (DESIGN.md §3 at the input resolution);
// the output pixel's history is read at its center + motion * scale.
inline Vec2f motion_in_output(Vec2f motion_in, Vec2f scale) {
  return {motion_in.x * scale.x, motion_in.y * scale.y};
}

// ----------------------------------------------------------------------------------------
// Sample weights of the true distance r (output pixels) to the output pixel center
// ----------------------------------------------------------------------------------------

// Lanczos-2 of r / width: sinc(x) sinc(x / 2) for x < 2, else 0 (the upsampling kernel of
// FSR2's documentation). With s = sin(pi x / 2), c = cos(pi x / 2): sin(pi x) = 2 s c, so
// sinc(x) sinc(x / 2) = (2 s c / (pi x)) (2 s / (pi x)) = 4 s^2 c / (pi x)^2. Takes r^2.
template <class D>
HWY_INLINE V<D> lanczos2_weight(D d, V<D> r2, float inv_width) {
  const auto x = hn::Mul(hn::Sqrt(r2), hn::Set(d, inv_width));
  const auto a = hn::Mul(x, hn::Set(d, 1.5707963267948966f));  // pi x / 2
  const auto s = hn::Sin(d, a), c = hn::Cos(d, a);
  const auto pix = hn::Mul(x, hn::Set(d, 3.14159265358979f));
  const auto w = hn::Div(hn::Mul(hn::Mul(hn::Set(d, 4.0f), hn::Mul(s, s)), c), hn::Mul(pix, pix));
  // x -> 0: the limit 1 (the formula is 0/0); x >= 2: outside the support.
  const auto tiny = hn::Lt(x, hn::Set(d, 1e-3f));
  return hn::IfThenElse(tiny, hn::Set(d, 1.0f), hn::IfThenElseZero(hn::Lt(x, hn::Set(d, 2.0f)), w));
}

// Gaussian exp(-r^2 / (2 sigma^2)). Takes r^2 and 1 / (2 sigma^2).
template <class D>
HWY_INLINE V<D> gaussian_weight(D d, V<D> r2, float inv_two_sigma2) {
  return hn::Exp(d, hn::Neg(hn::Mul(r2, hn::Set(d, inv_two_sigma2))));
}

// The kernel the settings select; `param` is 1 / lanczos_width or 1 / (2 sigma^2).
template <class D>
HWY_INLINE V<D> sample_weight(D d, SplatKernel kernel, V<D> r2, float param) {
  return kernel == SplatKernel::Lanczos2 ? lanczos2_weight(d, r2, param)
                                         : gaussian_weight(d, r2, param);
}
inline float sample_weight_param(const TaauSettings& s) {
  return s.kernel == SplatKernel::Lanczos2 ? 1.0f / s.lanczos_width
                                           : 1.0f / (2.0f * s.gaussian_sigma * s.gaussian_sigma);
}

// ----------------------------------------------------------------------------------------
// Splat accumulation of one frame's samples into an output pixel
// ----------------------------------------------------------------------------------------

template <class D>
struct Splat {
  Color3<D> sum;  // sum of w_k c_k
  V<D> weight;    // sum of w_k
};

template <class D>
HWY_INLINE Splat<D> splat_empty(D d) {
  return {splat(d, 0.0f, 0.0f, 0.0f), hn::Zero(d)};
}
template <class D>
HWY_INLINE Splat<D> splat_add(const Splat<D>& acc, const Color3<D>& c, V<D> w) {
  return {mul_add(c, w, acc.sum), hn::Add(acc.weight, w)};
}

// The weighted mean sum / weight; `fallback` (the nearest sample) where the weights nearly
// cancel or vanish (|weight| < 1e-4: no sample near the pixel this frame).
template <class D>
HWY_INLINE Color3<D> splat_color(D d, const Splat<D>& acc, const Color3<D>& fallback) {
  const auto ok = hn::Gt(hn::Abs(acc.weight), hn::Set(d, 1e-4f));
  const auto inv = hn::Div(hn::Set(d, 1.0f), hn::IfThenElse(ok, acc.weight, hn::Set(d, 1.0f)));
  return select<D>(ok, scale(acc.sum, inv), fallback);
}

// ----------------------------------------------------------------------------------------
// Accumulation with fractional sample weights
// ----------------------------------------------------------------------------------------

// The running weighted mean over frames: history carries the weight n of the samples it
// holds, this frame adds weight w, so alpha = w / (n + w) (seed 000 Eq.1 with weights). With
// n = 0 (no history) alpha = 1. Where a frame brings no weight (w = 0) history is kept.
template <class D>
HWY_INLINE V<D> alpha_from_weights(D d, V<D> n_history, V<D> w) {
  const auto total = hn::Add(n_history, w);
  const auto has = hn::Gt(total, hn::Zero(d));
  return hn::IfThenElse(has, hn::Div(w, hn::IfThenElse(has, total, hn::Set(d, 1.0f))),
                        hn::Set(d, 1.0f));
}

// The weight history carries into the next frame: n + w, capped at max_weight (the cap turns
// the running mean into an exponential filter with alpha >= w / (max_weight + w), Eq.3).
template <class D>
HWY_INLINE V<D> accumulated_weight(D d, V<D> n_history, V<D> w, float max_weight) {
  return hn::Min(hn::Add(n_history, w), hn::Set(d, max_weight));
}

}  // namespace afterimage::taau
