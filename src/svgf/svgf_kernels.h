// Per-pixel functions of SVGF (Schied et al., HPG 2017), named after seed 001: temporal
// blend factor, luminance moments and variance, edge-stopping weights and the à-trous kernel.
// The lane forms of reference.h's plain functions, with the same bits (svgf_kernels_test):
// templated on a Highway descriptor (core/lanes.h), they run full-width and at 1 lane with the
// same per-lane arithmetic (exact FP).
#pragma once

#include "core/lanes.h"
#include "svgf/reference.h"

namespace afterimage::svgf {

// ---- Temporal accumulation (Sec. 4.1; seed 001 section 2.3) ---------------------------------

// alpha = max(alpha_min, 1 / (n + 1)), n = the history length reprojected from the previous
// frame. Seed 001 (section 2.3) argues for the reprojected n rather than the current pixel's:
// the history that is blended is the one found at p + motion, so its length is what says how
// many samples it averages; 1 / (n + 1) then makes the first n + 1 frames a plain mean.
template <class D>
HWY_INLINE V<D> temporal_alpha(D d, V<D> n_prev, float alpha_min) {
  const auto one = hn::Set(d, 1.0f);
  return hn::Max(hn::Set(d, alpha_min), hn::Div(one, hn::Add(n_prev, one)));
}

// History length after this frame: the reprojected one plus this frame, capped.
template <class D>
HWY_INLINE V<D> next_history_length(D d, V<D> n_prev, float cap) {
  return hn::Min(hn::Add(n_prev, hn::Set(d, 1.0f)), hn::Set(d, cap));
}

// The exponential moving average c' = (1 - alpha) c_prev + alpha c (Sec. 4.1). (Seed 001's
// listing puts alpha on the history instead; with alpha = 1/(n+1) that would weight the newest
// sample by n/(n+1), not a mean, so the paper's form is used.)
template <class D>
HWY_INLINE V<D> accumulate(D, V<D> prev, V<D> cur, V<D> alpha) {
  return lerp<D>(prev, cur, alpha);
}

// Luminance moments in central form: mean mu1 and variance mu2 - mu1^2 of the integrated
// moments (seed 001 section 2.2: sigma'^2 = mu'2 - mu'1^2).
template <class D>
struct Moments {
  V<D> mean, var;
};

// The moving averages mu1' = (1-a) mu1 + a l, mu2' = (1-a) mu2 + a l^2 carried as (mean, var):
// with delta = l - mu1, mean' = mu1 + a delta and var' = (1 - a)(var + a delta^2), which is
// algebraically mu2' - mu1'^2 (expand both) but never subtracts two large numbers. Seed 001's
// running sums (Eq.二.5-二.14) and the paper's raw moments compute mu2 - mu1^2 directly; at
// luminance L with noise sigma that difference loses all precision once sigma^2 nears
// L^2 * 2^-24 (svgf_kernels_test shows it). Welford's update, exponentially weighted.
template <class D>
HWY_INLINE Moments<D> accumulate_moments(D d, const Moments<D>& prev, V<D> l, V<D> alpha) {
  const auto delta = hn::Sub(l, prev.mean);
  const auto one = hn::Set(d, 1.0f);
  return {hn::MulAdd(alpha, delta, prev.mean),
          hn::Mul(hn::Sub(one, alpha), hn::MulAdd(hn::Mul(alpha, delta), delta, prev.var))};
}

// The plain difference mu2 - mu1^2 of raw moments (the paper's and seed 001's form), clamped at
// 0. Kept as the reference the precision test compares against; the filter does not use it.
template <class D>
HWY_INLINE V<D> raw_moment_variance(D d, V<D> mu1, V<D> mu2) {
  return hn::Max(hn::Zero(d), hn::NegMulAdd(mu1, mu1, mu2));
}

// Moments of a weighted blend of taps (bilinear reprojection): the raw moments blend linearly,
// so in central form mean = sum w_k m_k and var = sum w_k (v_k + (m_k - mean)^2) (the law of
// total variance) — the same estimate as blending mu1, mu2, without the cancellation.
template <class D, int N>
HWY_INLINE Moments<D> blend_moments(D d, const V<D> (&w)[N], const V<D> (&mean)[N],
                                    const V<D> (&var)[N]) {
  auto m = hn::Zero(d);
  for (int k = 0; k < N; ++k) m = hn::MulAdd(w[k], mean[k], m);
  auto v = hn::Zero(d);
  for (int k = 0; k < N; ++k) {
    const auto dm = hn::Sub(mean[k], m);
    v = hn::MulAdd(w[k], hn::MulAdd(dm, dm, var[k]), v);
  }
  return {m, v};
}

// ---- Edge-stopping weights (Sec. 4.3, Eqs. 3-5; seed 001 Eq.二.2, 二.3) ------------------------
// Each exponent term is returned separately so one exp serves w_z * w_l.

// Depth: |z_p - z_q| / (sigma_z |grad z(p) . (p - q)| + eps); `grad_dot_offset` is
// grad z(p) . (p - q) in depth units (gradient per pixel times the offset in pixels). The
// denominator is the same bits for the offsets o and -o (fma(g_x, -o_x, g_y * -o_y) is the
// exact negation), so the à-trous computes it once per tap pair.
template <class D>
HWY_INLINE V<D> depth_denominator(D d, V<D> grad_dot_offset, float sigma_z, V<D> eps) {
  return hn::MulAdd(hn::Set(d, sigma_z), hn::Abs(grad_dot_offset), eps);
}
template <class D>
HWY_INLINE V<D> depth_exponent_over(D, V<D> zp, V<D> zq, V<D> denominator) {
  return hn::Div(hn::Abs(hn::Sub(zp, zq)), denominator);
}
template <class D>
HWY_INLINE V<D> depth_exponent(D d, V<D> zp, V<D> zq, V<D> grad_dot_offset, float sigma_z,
                               V<D> eps) {
  return depth_exponent_over(d, zp, zq, depth_denominator(d, grad_dot_offset, sigma_z, eps));
}

// Luminance: |l_p - l_q| / (sigma_l sqrt(g3x3(Var(l_p))) + eps), given the reciprocal of the
// denominator (one per pixel: luminance_inv_phi).
template <class D>
HWY_INLINE V<D> luminance_exponent(D, V<D> lp, V<D> lq, V<D> inv_phi) {
  return hn::Mul(hn::Abs(hn::Sub(lp, lq)), inv_phi);
}
template <class D>
HWY_INLINE V<D> luminance_inv_phi(D d, V<D> prefiltered_variance, float sigma_l) {
  // eps: a variance of exactly 0 (a constant region) must stop at any luminance step, not divide
  // by zero.
  const auto sd = hn::Sqrt(hn::Max(prefiltered_variance, hn::Zero(d)));
  return hn::Div(hn::Set(d, 1.0f), hn::MulAdd(hn::Set(d, sigma_l), sd, hn::Set(d, 1e-10f)));
}

// Normal: max(0, n_p . n_q)^sigma_n (integer power by squaring: 7 squarings for 128).
template <class D>
HWY_INLINE V<D> normal_weight(D d, V<D> dot, int sigma_n) {
  auto base = hn::Max(dot, hn::Zero(d));
  auto r = hn::Set(d, 1.0f);
  for (unsigned k = unsigned(sigma_n); k; k >>= 1) {
    if (k & 1u) r = hn::Mul(r, base);
    if (k > 1u) base = hn::Mul(base, base);
  }
  return r;
}

// p * 2^n for the integer n in [-126, 127] that exp_neg rounds t to: `n` as a float and `r`,
// the float whose bits are 0x4B400000 + n. AVX-512 has this as one instruction (vscalefps);
// elsewhere 2^n is built in the exponent bits, (n + 127) << 23, and multiplied. Both round the
// exact product p 2^n once, so every target and lane count gives the same bits (2 vector
// operations fewer per weight: -3% à-trous CPU time at 1080p, perf task-clock).
template <class D>
HWY_INLINE V<D> times_pow2([[maybe_unused]] D d, V<D> p, [[maybe_unused]] V<D> n,
                           [[maybe_unused]] V<D> r) {
#if HWY_TARGET <= HWY_AVX3
  // The masked form with every lane set: the unmasked intrinsics start from an undefined
  // register, which GCC 12 warns about.
  V<D> out;
  if constexpr (sizeof(p.raw) == 64)
    out.raw = _mm512_mask_scalef_ps(p.raw, 0xFFFF, p.raw, n.raw);
  else if constexpr (sizeof(p.raw) == 32)
    out.raw = _mm256_mask_scalef_ps(p.raw, 0xFF, p.raw, n.raw);
  else
    out.raw = _mm_mask_scalef_ps(p.raw, 0xF, p.raw, n.raw);
  return out;
#else
  const hn::RebindToSigned<D> di;
  const auto scale =
      hn::BitCast(d, hn::ShiftLeft<23>(hn::Add(hn::BitCast(di, r), hn::Set(di, 127 - 0x4B400000))));
  return hn::Mul(p, scale);
#endif
}

// The normal term as an exponent, for the option normal_exp (settings.h): exp(-sigma_n (1 -
// n_p . n_q)) instead of max(0, n_p . n_q)^sigma_n. The two agree to first order at n_p . n_q
// = 1 (ln x = x - 1 + O((x-1)^2); at 0.99 and sigma_n 128: 0.278 against 0.276, at 0.9 both
// are below 3e-6), and the exponent joins the depth and luminance ones in the one exp instead
// of 7 squarings and a multiply. `offset` is added in the same FMA: the à-trous folds its
// kernel weight h(q) in as -ln h(q). A back-facing tap (n_p . n_q <= 0) gets exp(-sigma_n) or
// less rather than 0.
template <class D>
HWY_INLINE V<D> normal_exponent(D d, V<D> dot, float sigma_n, float offset) {
  return hn::NegMulAdd(hn::Set(d, sigma_n), dot, hn::Set(d, sigma_n + offset));
}

// exp(-e) for e in [0, 87], the weights' exponential: 2^t with t = -e log2(e) = n + f, n the
// nearest integer, 2^f on [-1/2, 1/2] by a degree-3 polynomial (constant term 1, so exp(0) = 1;
// iteratively reweighted least-squares fit of the relative error, max 1.0e-4) and 2^n put into
// the exponent bits. Adding 1.5 * 2^23 rounds t to an integer held in the low mantissa bits, so
// n needs no conversion. About half the operations of hn::Exp, which handles the whole float
// range; the à-trous evaluates one per tap and signal. Degree 3 instead of 5 (max 2e-7): -7%
// à-trous time at 1080p, denoise demo room / room_light within 0.001 dB PSNR and 0.0001 FLIP
// (a weight off by 1e-4 relative is an edge-stopping exponent off by 1e-4).
template <class D>
HWY_INLINE V<D> exp_neg(D d, V<D> e) {
  const auto magic = hn::Set(d, 12582912.0f);  // 1.5 * 2^23
  const auto t = hn::Mul(e, hn::Set(d, -1.44269504088896341f));
  const auto r = hn::Add(t, magic);
  const auto n = hn::Sub(r, magic);
  const auto f = hn::Sub(t, n);
  auto p = hn::Set(d, 0.0550066829f);
  p = hn::MulAdd(p, f, hn::Set(d, 0.242206424f));
  p = hn::MulAdd(p, f, hn::Set(d, 0.693282664f));
  p = hn::MulAdd(p, f, hn::Set(d, 1.0f));
  return times_pow2(d, p, n, r);
}

// w = w_z * w_n * w_l = exp(-(depth + luminance exponents)) * w_n (Eq.二.2). The exponent is
// clamped so exp stays in range (the weight is then ~1e-38, i.e. stopped).
template <class D>
HWY_INLINE V<D> edge_stopping_weight(D d, V<D> depth_exp, V<D> lum_exp, V<D> w_normal) {
  const auto e = hn::Min(hn::Add(depth_exp, lum_exp), hn::Set(d, 87.0f));
  return hn::Mul(exp_neg(d, e), w_normal);
}
// The same with every term in the exponent (normal_exp): w = exp(-(geometry + luminance)),
// `geometry_exp` the depth exponent plus normal_exponent.
template <class D>
HWY_INLINE V<D> edge_stopping_weight_exp(D d, V<D> geometry_exp, V<D> lum_exp) {
  return exp_neg(d, hn::Min(hn::Add(geometry_exp, lum_exp), hn::Set(d, 87.0f)));
}

// ---- Kernels (reference.h: the B3 and linear B-splines, -ln of their weights, the 3x3 Gaussian)

using reference::atrous_neg_log;
using reference::atrous_weight;
using reference::b3_neg_log;
using reference::b3_weight;
using reference::gauss3_weight;

// ---- Demodulation ---------------------------------------------------------------------------

// Illumination = radiance / max(albedo, eps) per channel; remodulation multiplies by the same.
template <class D>
HWY_INLINE V<D> demodulation_factor(D d, V<D> albedo, float eps) {
  return hn::Max(albedo, hn::Set(d, eps));
}

}  // namespace afterimage::svgf
