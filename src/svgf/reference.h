// SVGF written plainly: the specification of each stage, one pixel at a time (Schied,
// Kaplanyan, Wyman et al., "Spatiotemporal Variance-Guided Filtering", HPG 2017, Sec. 4; seed
// 001 Eq.二.1-二.14; the A-SVGF gradient of Schied, Peters, Dachsbacher, HPG 2018). Read this
// first. The fast forms compute exactly this, bit for bit, on a faster schedule: svgf_kernels.h
// (the per-pixel functions in lanes), filter_fast.h (à-trous and variance: lanes, unrolled taps,
// interior blocks without border tests), gradient.cpp, history_clamp.cpp and SvgfDenoiser's
// reprojection and accumulation (denoiser.cpp accumulate_block: lanes, loads instead of gathers
// where the taps are consecutive, streaming stores); --simd off runs the stages below instead
// (svgf_filter_test, svgf_kernels_test, svgf_gradient_test, svgf_history_clamp_test and
// svgf_accumulate_reference_test compare them).
//
// Exact floating point: the file is compiled without FMA contraction; a std::fma below is one
// rounding on purpose and marks where the fast path uses a fused multiply-add. max_ps / min_ps
// keep x86's operand order (what Highway's Max / Min compile to), which decides NaN and -0. The
// à-trous, variance and gradient stages run with subnormals flushed (core/simd.h
// FlushSubnormals), the remodulation, the accumulation and the history options without, as the
// fast ones do.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/image.h"
#include "core/parallel.h"
#include "svgf/accumulate.h"
#include "svgf/filter.h"
#include "svgf/gradient.h"
#include "svgf/history_clamp.h"
#include "svgf/settings.h"

namespace afterimage::svgf::reference {

// ---- Kernels ---------------------------------------------------------------------------------

// The 1D B3-spline (1/16, 1/4, 3/8, 1/4, 1/16) of the à-trous wavelet, indexed by |offset|;
// the 5x5 kernel h(dx, dy) = b3(dx) b3(dy) sums to 1 (Dammertz et al. 2010; Sec. 4.3).
inline constexpr float kB3[3] = {3.0f / 8.0f, 1.0f / 4.0f, 1.0f / 16.0f};
inline constexpr float b3_weight(int dx, int dy) {
  return kB3[dx < 0 ? -dx : dx] * kB3[dy < 0 ? -dy : dy];
}
// -ln kB3: with normal_exp the kernel weight h(dx, dy) enters the exponent as
// -ln h = -ln b3(dx) - ln b3(dy).
inline constexpr float kNegLnB3[3] = {0.980829253f, 1.38629436f, 2.77258872f};
inline constexpr float b3_neg_log(int dx, int dy) {
  return kNegLnB3[dx < 0 ? -dx : dx] + kNegLnB3[dy < 0 ? -dy : dy];
}
// The 1D linear B-spline (1/4, 1/2, 1/4), the à-trous kernel of the setting atrous_kernel = 3x3
// (settings.h; beyond the paper, for speed): 9 taps per iteration instead of 25. The à-trous
// "starlet" literature (Starck, Murtagh) uses both; iterated at steps 2^i it converges to a
// smooth kernel as well, one iteration more reaching as far (radius 15 px after 4 iterations
// against 14 after the 5x5's 3).
inline constexpr float kB1[2] = {1.0f / 2.0f, 1.0f / 4.0f};
inline constexpr float kNegLnB1[2] = {0.693147181f, 1.38629436f};
// h(dx, dy) and -ln h(dx, dy) of the kernel of radius R (2: B3 5x5, 1: linear 3x3).
template <int R>
inline constexpr float atrous_weight(int dx, int dy) {
  if constexpr (R == 2) return b3_weight(dx, dy);
  return kB1[dx < 0 ? -dx : dx] * kB1[dy < 0 ? -dy : dy];
}
template <int R>
inline constexpr float atrous_neg_log(int dx, int dy) {
  if constexpr (R == 2) return b3_neg_log(dx, dy);
  return kNegLnB1[dx < 0 ? -dx : dx] + kNegLnB1[dy < 0 ? -dy : dy];
}
// The kernel's radius in steps: 2 for the paper's 5x5 B3, 1 for the linear 3x3.
inline int atrous_radius(const SvgfSettings& s) {
  return s.atrous_kernel == AtrousKernel::Linear3x3 ? 1 : 2;
}
// The 3x3 Gaussian (1/4, 1/2, 1/4)^2 that prefilters the variance for the luminance weight only
// (seed 001 Eq.二.3: it is not propagated to the next iteration).
inline constexpr float kGauss3[2] = {1.0f / 2.0f, 1.0f / 4.0f};
inline constexpr float gauss3_weight(int dx, int dy) {
  return kGauss3[dx < 0 ? -dx : dx] * kGauss3[dy < 0 ? -dy : dy];
}

// ---- Scalar arithmetic -----------------------------------------------------------------------

// x86 maxps / minps: the second operand unless the first compares greater / less.
inline float max_ps(float a, float b) {
  return a > b ? a : b;
}
inline float min_ps(float a, float b) {
  return a < b ? a : b;
}

// Rec.709 luminance (DESIGN.md §3), as core/lanes.h luminance rounds it.
inline float luminance(float r, float g, float b) {
  return std::fma(0.2126f, r, std::fma(0.7152f, g, 0.0722f * b));
}

// exp(-e) for e in [0, 87], the weights' exponential: 2^t with t = -e log2(e) = n + f, n the
// nearest integer (adding 1.5 * 2^23 rounds t to an integer held in the low mantissa bits), 2^f
// on [-1/2, 1/2] by a degree-3 polynomial (constant term 1, so exp(0) = 1; max relative error
// 1.0e-4) and 2^n put into the exponent bits. svgf_kernels.h exp_neg explains the choice.
float exp_neg(float e);

// ---- Temporal accumulation (Sec. 4.1; seed 001 section 2.3) -----------------------------------
// Per pixel, after the reprojection (denoiser.h step 3) found the history: the lane forms in
// svgf_kernels.h give the same bits (svgf_kernels_test).

// alpha = max(alpha_min, 1 / (n + 1)), n the history length reprojected from the previous frame:
// the first n + 1 frames are a plain mean (seed 001 section 2.3).
inline float temporal_alpha(float n_prev, float alpha_min) {
  return max_ps(alpha_min, 1.0f / (n_prev + 1.0f));
}
// History length after this frame: the reprojected one plus this frame, capped.
inline float next_history_length(float n_prev, float cap) {
  return min_ps(n_prev + 1.0f, cap);
}
// The exponential moving average c' = (1 - alpha) c_prev + alpha c (Sec. 4.1).
inline float accumulate(float prev, float cur, float alpha) {
  return std::fma(cur - prev, alpha, prev);
}
// Luminance moments in central form (mean, variance) instead of the paper's raw (mu1, mu2).
struct Moments {
  float mean, var;
};
// mu1' = (1-a) mu1 + a l and mu2' = (1-a) mu2 + a l^2 carried as (mean, var): with
// delta = l - mean, mean' = mean + a delta and var' = (1 - a)(var + a delta^2), algebraically
// mu2' - mu1'^2 without subtracting two large numbers (Welford's update, exponentially weighted;
// svgf_kernels.h accumulate_moments says why).
inline Moments accumulate_moments(const Moments& prev, float l, float alpha) {
  const float delta = l - prev.mean;
  return {std::fma(alpha, delta, prev.mean),
          (1.0f - alpha) * std::fma(alpha * delta, delta, prev.var)};
}
// The paper's and seed 001's form, mu2 - mu1^2 clamped at 0: the precision test's foil.
inline float raw_moment_variance(float mu1, float mu2) {
  return max_ps(0.0f, std::fma(-mu1, mu1, mu2));
}
// Moments of a weighted blend of taps (the bilinear reprojection): mean = sum w_k m_k and
// var = sum w_k (v_k + (m_k - mean)^2), the law of total variance.
template <int N>
inline Moments blend_moments(const float (&w)[N], const float (&mean)[N], const float (&var)[N]) {
  float m = 0.0f;
  for (int k = 0; k < N; ++k) m = std::fma(w[k], mean[k], m);
  float v = 0.0f;
  for (int k = 0; k < N; ++k) {
    const float dm = mean[k] - m;
    v = std::fma(w[k], std::fma(dm, dm, var[k]), v);
  }
  return {m, v};
}
// Illumination = radiance / max(albedo, eps) per channel; remodulation multiplies by the same.
inline float demodulation_factor(float albedo, float eps) {
  return max_ps(albedo, eps);
}

// ---- Reprojection (Sec. 4.1; seed 001 section 2.3; reproject/ in lanes) ------------------------
// SvgfDenoiser step 3 for one pixel: the previous frame's history at p + motion, from the 2x2
// bilinear taps that show the same surface (renormalised, Nehab et al. 2007), else from the
// consistent pixels of the 3x3 around it with equal weights, else none.

// Where pixel (x, y)'s history is: its center plus motion (which already holds the jitter
// change), and whether that is on screen (closed test: the right and bottom edges still have a
// bilinear footprint); the position is then clamped to [-2, w + 2] x [-2, h + 2], which keeps
// the taps' indices small (reproject/history.h). A NaN motion is off screen.
struct HistoryPosition {
  float x, y;
  bool onscreen;
};
inline HistoryPosition history_position(int x, int y, float mx, float my, int w, int h) {
  const float px = (float(x) + 0.5f) + mx, py = (float(y) + 0.5f) + my;
  const bool onscreen = px >= 0.0f && px <= float(w) && py >= 0.0f && py <= float(h);
  return {min_ps(max_ps(px, -2.0f), float(w) + 2.0f), min_ps(max_ps(py, -2.0f), float(h) + 2.0f),
          onscreen};
}
// Flat index of pixel (ix, iy) (integer-valued floats) clamped to the image.
inline int clamped_pixel_index(float ix, float iy, int w, int h) {
  ix = min_ps(max_ps(ix, 0.0f), float(w - 1));
  iy = min_ps(max_ps(iy, 0.0f), float(h - 1));
  return int(iy) * w + int(ix);
}
inline bool inside_image(float ix, float iy, int w, int h) {
  return ix >= 0.0f && ix < float(w) && iy >= 0.0f && iy < float(h);
}
// Bilinear weights of the taps 00, 10, 01, 11 at fractions (fx, fy): (1-fx)(1-fy), fx(1-fy),
// (1-fx)fy, fx fy.
inline void bilinear_tap_weights(float fx, float fy, float (&w)[4]) {
  const float gx = 1.0f - fx, gy = 1.0f - fy;
  w[0] = gx * gy;
  w[1] = fx * gy;
  w[2] = gx * fy;
  w[3] = fx * fy;
}
// The weights renormalised over the taps that pass (failing ones 0): false, every weight 0,
// where no tap with weight passes.
inline bool renormalize_weights(float (&w)[4], const bool (&pass)[4]) {
  float sum = 0.0f;
  for (int t = 0; t < 4; ++t) {
    w[t] = pass[t] ? w[t] : 0.0f;
    sum = sum + w[t];
  }
  const bool any = sum > 0.0f;
  const float inv = 1.0f / (any ? sum : 1.0f);
  for (int t = 0; t < 4; ++t) w[t] = w[t] * inv;
  return any;
}
// Slope-scaled depth test |d_prev - d| <= tol d + slope |grad d| distance, the distance in
// pixels from the history position to the tap (reproject/consistency.h depth_within_slope).
inline bool depth_consistent(float prev, float cur, float tol, float slope, float gradient_length,
                             float distance) {
  return std::fabs(prev - cur) <= tol * cur + (slope * gradient_length) * distance;
}
// Normal test n_prev . n >= cos(max angle).
inline bool normal_consistent(const float (&prev)[3], const float (&cur)[3], float cos_max) {
  return std::fma(prev[0], cur[0], std::fma(prev[1], cur[1], prev[2] * cur[2])) >= cos_max;
}
// The current pixel's surface, what each tap is tested against.
struct Surface {
  float z, n[3], gradient_length;
  uint32_t id;
};
// Tap `idx` of the previous frame at pixel (tx, ty) holds history for surface p: inside the
// image, the same surface (depth, normal and, when both frames carry ids, the object id) and a
// history length > 0 (a repaired pixel's 0 is nobody's history).
bool tap_consistent(const AccumulateContext& k, const Surface& p, const HistoryPosition& hp,
                    int idx, float tx, float ty);

// The history of one pixel: length, color, luminance moments and the fast history (fast-history
// clamp only) per signal.
struct History {
  float n;
  float c[kMaxSignals][3];
  Moments m[kMaxSignals];
  float f[kMaxSignals][3];
};
// This frame's own values as the history where there is none: length 0, moments (l, 0).
History own_history(const float (&cur)[kMaxSignals][3], const float (&lum)[kMaxSignals],
                    int signals);
// The history blended over taps `idx` with weights `w` (every tap summed, a weight-0 one too:
// a non-finite value there makes the blend non-finite, as in the lanes).
template <int N>
History blended_history(const AccumulateContext& k, const int (&idx)[N], const float (&w)[N]);
// Every value of the history finite (a corrupted state file's are dropped, never propagated).
bool history_finite(const AccumulateContext& k, const History& hist);
// Step 3: the reprojected history of pixel (x, y), or `own` (ok false) where none is found.
History reprojected_history(const AccumulateContext& k, int x, int y, const History& own, bool& ok);

// ---- Accumulation of one pixel (Sec. 4.1-4.2; SvgfDenoiser steps 2-4) ------------------------

// A-SVGF (gradient.h): the history length shortened by the temporal change, (1 - lambda) n.
inline float shortened_history_length(float n, float lambda) {
  return (1.0f - lambda) * n;
}
// Step 1's test on the raw inputs of flat index o (AccumulateContext::check; core/sanitize.h):
// a color-like value not finite or negative, a depth not finite or <= 0, a normal or depth
// gradient not finite.
bool inputs_need_sanitize(const AccumulateContext& k, size_t o);
// Steps 2-4 at pixel (x, y): keeps this frame's G-buffer, demodulates, reprojects (steps 3)
// and writes the accumulated color (or with the fast-history clamp: this frame's signal, the
// reprojected long history, the alpha and the fast history), moments and history length. A
// repaired input (k.invalid) resets the pixel's history: alpha 1, length 0. Returns, with
// k.check, whether an input needs step 1 (the values written are then to be discarded).
bool accumulate_pixel(const AccumulateContext& k, int x, int y);

// ---- Edge-stopping weights (Sec. 4.3, Eqs. 3-5; seed 001 Eq.二.2, 二.3) -----------------------

// The depth term's eps, relative to the depth (settings.h depth_epsilon), floored so that a zero
// depth cannot make 0 / 0.
inline float depth_eps(float zp, float depth_epsilon) {
  return max_ps(zp * depth_epsilon, 1e-30f);
}
// Depth: |z_p - z_q| / (sigma_z |grad z(p) . (q - p)| + eps), the gradient per pixel dotted
// with the tap's offset in pixels.
inline float depth_exponent(float zp, float zq, float gx, float gy, int ox, int oy, float sigma_z,
                            float eps) {
  const float grad_dot_offset = std::fma(gx, float(ox), gy * float(oy));
  return std::fabs(zp - zq) / std::fma(sigma_z, std::fabs(grad_dot_offset), eps);
}
// n_p . n_q
inline float normal_dot(const float (&np)[3], const float (&nq)[3]) {
  return std::fma(np[0], nq[0], std::fma(np[1], nq[1], np[2] * nq[2]));
}
// Normal: max(0, n_p . n_q)^sigma_n, an integer power by squaring.
inline float normal_weight(float dot, int sigma_n) {
  float base = max_ps(dot, 0.0f), r = 1.0f;
  for (unsigned k = unsigned(sigma_n); k; k >>= 1) {
    if (k & 1u) r *= base;
    if (k > 1u) base *= base;
  }
  return r;
}
// The normal term as an exponent (the setting normal_exp): sigma_n (1 - n_p . n_q) + offset,
// the offset carrying the à-trous kernel weight as -ln h(q) (svgf_kernels.h normal_exponent).
inline float normal_exponent(float dot, float sigma_n, float offset) {
  return std::fma(-sigma_n, dot, sigma_n + offset);
}
// Luminance: |l_p - l_q| / (sigma_l sqrt(g3x3(Var(l_p))) + eps), given the reciprocal of the
// denominator; eps: a variance of 0 (a constant region) stops at any luminance step.
inline float luminance_inv_phi(float prefiltered_variance, float sigma_l) {
  return 1.0f / std::fma(sigma_l, std::sqrt(max_ps(prefiltered_variance, 0.0f)), 1e-10f);
}
inline float luminance_exponent(float lp, float lq, float inv_phi) {
  return std::fabs(lp - lq) * inv_phi;
}
// w = w_z w_n w_l = exp(-(depth + luminance exponents)) w_n (Eq.二.2), the exponent clamped so
// exp stays in range (the weight is then ~1e-38: stopped).
inline float edge_stopping_weight(float depth_exp, float lum_exp, float w_normal) {
  return exp_neg(min_ps(depth_exp + lum_exp, 87.0f)) * w_normal;
}
// normal_exp: every term in the exponent, `geometry_exp` the depth plus the normal exponent.
inline float edge_stopping_weight_exp(float geometry_exp, float lum_exp) {
  return exp_neg(min_ps(geometry_exp + lum_exp, 87.0f));
}

// The geometric part of the weight of tap q = p + (ox, oy) pixels: the depth exponent and the
// normal weight, or with normal_exp the depth plus normal exponent (offset by `exp_offset`) and
// a normal weight of 1.
struct GeometryTerms {
  float exponent;
  float w_normal;
};
GeometryTerms geometry_terms(const Guide& g, const SvgfSettings& s, int x, int y, int ox, int oy,
                             float exp_offset = 0.0f);

// ---- Variance estimation (Sec. 4.2; seed 001 Eq.二.5-二.14) ------------------------------------

// The luminance variance of signal `sg` at (x, y): the temporal estimate (the moments' central
// variance) once the history length n >= temporal_variance_frames, else the spatial one over
// the (2 spatial_radius + 1)^2 window, weighted by the depth and normal edge-stopping functions
// (center weight 1): the window's moments accumulated around this pixel's mean, so that
// mu2 - mu1^2 does not cancel catastrophically; each tap adds its own variance (law of total
// variance). Taps outside the image are left out.
float variance_at(const Guide& g, const ImageF& moments, const ImageF& length,
                  const SvgfSettings& s, int x, int y, int sg);

// ---- À-trous iteration (Sec. 4.3; seed 001 Eq.二.1-二.4) ---------------------------------------

// The 3x3 Gaussian of signal sg's variance around (x, y), renormalised over the taps inside the
// image (Eq.二.3: it drives the luminance weight only).
float prefiltered_variance_at(const ImageF& variance, int x, int y, int sg);

// One à-trous tap sum of signal sg at (x, y) with step `step`:
//   c'(p)   = sum_q h(q) w(p,q) c(q) / sum_q h(q) w(p,q)                       (Eq.二.1)
//   Var'(p) = sum_q h(q)^2 w(p,q)^2 Var(q) / (sum_q h(q) w(p,q))^2            (Eq.二.4)
// over the kernel's taps at step * (-R..R) inside the image: the center first (w = 1), then the
// others in row-major order.
struct Filtered {
  float color[3];
  float variance;
};
Filtered atrous_at(const Guide& g, const ImageF& color, const ImageF& variance, int step,
                   const SvgfSettings& s, int x, int y, int sg);

// Remodulation (filter.h RemodulationInputs): emission + sum over signals of factor * filtered
// for one pixel, or the input color where that is not finite. `filtered` holds 3S values.
void remodulate_at(const RemodulationInputs& r, int signals, const float* filtered, int x, int y,
                   float (&out)[3]);

// ---- A-SVGF gradient reconstruction (Schied, Peters, Dachsbacher, HPG 2018, Sec. 4) -----------

// Planes of the stratum image (one value per 3x3 stratum) while filtering: the sample's delta,
// max, confidence and previous luminance, then the guides (depth, normal, depth gradient,
// luminance) of the pixel that holds it (gradient.h reconstruct_gradient).
enum GradientPlane {
  kDelta,
  kMax,
  kConf,
  kPrev,
  kZ,
  kNx,
  kNy,
  kNz,
  kGx,
  kGy,
  kLum,
  kGradientPlanes
};

// One à-trous iteration of the strata at stratum (px, py), step `step` strata: the 5x5 B3 kernel
// times SVGF's w_z w_n (the depth tolerance across the tap's distance in full-resolution pixels)
// and a luminance weight exp(-|l_p - l_q| / (sigma_l (l_p + l_q) / 2 + 1e-4)), relative because
// the guide is a 1-spp sample; delta, max and prev are averaged over weight times confidence
// (normalised convolution), the confidence over weight. A tap in a column outside the strata
// adds weight 0 (its values read at the nearest column), rows outside are left out. Writes the
// four filtered planes of `dst`.
void gradient_atrous_at(const ImageF& src, ImageF& dst, const SvgfSettings& s, int px, int py,
                        int step);

// ---- History quality options beyond the paper (history_clamp.h) ------------------------------

// SvgfDenoiser's step 2 for one value of signal sg, channel ch at flat index o: minus the
// emission (clamped at 0) when the combined signal subtracts it, over max(albedo, eps) when
// demodulating.
float demodulated(const SignalInputs& in, int sg, int ch, size_t o);

// Sorts 8 values ascending with the 19-comparator network of history_clamp.h sort8 (Knuth,
// TAOCP vol. 3, 5.3.4, Fig. 49), min_ps / max_ps at each comparator.
void sort8(float (&v)[8]);

// The k-th largest (1..8) luminance of the 8 neighbours of (x, y) in plane sg of `lum`, the
// image mirrored at its border without repeating the edge pixel (the pixel is never its own
// neighbour).
float kth_largest_neighbour(const ImageF& lum, int sg, int x, int y, int k);

// The factor that brings luminance l down to the rank bound l_k: l_k / l where l > l_k, else
// exactly 1 (the pixel is left bit-identical).
inline float firefly_scale(float l, float l_k) {
  return l > l_k ? l_k / l : 1.0f;
}

// The fast-history clamp of plane p at (x, y): the long history clamped to mean +- sigma sd of
// the fast history's (2 radius + 1)^2 window (clamped to the image edge; two passes, mean then
// squared deviations, so mu2 - mu1^2 does not cancel), then blended with this frame's `cur` by
// alpha; `cur` itself where alpha >= 1 (no history).
float fast_box_clamped(const ImageF& fast, const ImageF& long_prev, float alpha, float cur,
                       float sigma, int radius, int x, int y, int p);

// ---- Depth gradient --------------------------------------------------------------------------

// One axis of the screen-space depth gradient from the one-sided differences a = z(+1) - z(0)
// and b = z(0) - z(-1): their mean where they agree within a factor of 2 (a smooth surface),
// else the smaller in magnitude (a silhouette on one side); a non-finite difference (the image
// border passes infinity) leaves the other, or 0.
float gradient_of(float a, float b);

// ---- The stages over whole images (rows in parallel) ------------------------------------------

// filter.h's passes.
void depth_gradient(const ImageF& depth, ImageF& out, const Exec& exec);
void estimate_variance(const Guide& g, const ImageF& moments, const ImageF& length,
                       const SvgfSettings& s, ImageF& variance, const Exec& exec);
void atrous_iteration(const Guide& g, const ImageF& color, const ImageF& variance, int step,
                      const SvgfSettings& s, ImageF& out_color, ImageF& out_variance,
                      const Exec& exec);
void atrous_iteration_remodulated(const Guide& g, const ImageF& color, const ImageF& variance,
                                  int step, const SvgfSettings& s, const RemodulationInputs& r,
                                  ImageF& out, ImageF* filtered, const Exec& exec);
// SvgfDenoiser's steps 2-4 (denoiser.cpp accumulate_block): accumulate_pixel over the image.
// Returns, with k.check, whether any input needs step 1.
bool reproject_and_accumulate(const AccumulateContext& k, const Exec& exec);
// history_clamp.h's passes.
void demodulate_and_clamp_fireflies(const SignalInputs& in, int rank, ImageF& out, ImageF& lum,
                                    const Exec& exec);
void clamp_history_to_fast_box(const ImageF& fast, const ImageF& long_prev, const ImageF& alpha,
                               float sigma, int radius, ImageF& acc, const Exec& exec);

}  // namespace afterimage::svgf::reference
