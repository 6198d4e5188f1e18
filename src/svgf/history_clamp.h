// History quality options of SVGF beyond the paper (issue 11 "Beyond the paper"), each a
// setting of SvgfSettings that is off in svgf-paper:
//   1. fast-history clamp (ReLAX, NVIDIA NRD: "history clamping" of the slow history to the
//      responsive one): a second, short history of the demodulated signal is accumulated beside
//      the long one with alpha = max(fast_alpha_min, 1/(n+1)); before blending, the long
//      history is clamped per channel to mean +- fast_clamp_sigma * stddev of the fast history
//      over a (2r + 1)^2 window. Where lighting changed the fast history has followed within a
//      few frames and the long one is pulled along; where it has not, the box is as wide as the
//      noise and the long history passes.
//   2. firefly rank clamp: each pixel's luminance of the demodulated input is clamped to the
//      k-th largest luminance of its 8 neighbours, chroma kept (the color is scaled). A
//      single-pixel spike is above all 8 neighbours; a smooth gradient has at least 3
//      neighbours at or above each pixel, so k <= 3 leaves it exactly unchanged.
//   3. accumulation stated in seconds: a time constant tau gives alpha = 1 - exp(-dt / tau) for
//      a frame interval dt (the exponential moving average then decays by exp(-t / tau) in t
//      seconds whatever the frame rate), and a history cap of T seconds is round(T / dt) frames.
// The passes are stated plainly in reference.h, which --simd off runs; the lanes give the same
// bits. Rows are independent: results are bit-identical for any thread count.
#pragma once

#include "core/image.h"
#include "core/lanes.h"
#include "core/parallel.h"
#include "svgf/filter.h"
#include "svgf/settings.h"

namespace afterimage::svgf {

// ---- Per-pixel functions ---------------------------------------------------------------------

// v clamped to [mean - sigma sd, mean + sigma sd] (the fast history's box).
template <class D>
HWY_INLINE V<D> clamp_to_deviation_box(D d, V<D> v, V<D> mean, V<D> sd, float sigma) {
  const auto r = hn::Mul(hn::Set(d, sigma), sd);
  return hn::Min(hn::Max(v, hn::Sub(mean, r)), hn::Add(mean, r));
}

// Sorts 8 lane vectors ascending in place: the 19-comparator network for n = 8 (Knuth, TAOCP
// vol. 3, 5.3.4, Fig. 49), branch-free, so every lane sees the same operations.
inline constexpr int kSort8Pairs[19][2] = {{0, 2}, {1, 3}, {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6},
                                           {3, 7}, {0, 1}, {2, 3}, {4, 5}, {6, 7}, {2, 4}, {3, 5},
                                           {1, 4}, {3, 6}, {1, 2}, {3, 4}, {5, 6}};
template <class D>
HWY_INLINE void sort8(V<D> (&v)[8]) {
  for (const auto& p : kSort8Pairs) {
    const auto lo = hn::Min(v[p[0]], v[p[1]]);
    v[p[1]] = hn::Max(v[p[0]], v[p[1]]);
    v[p[0]] = lo;
  }
}

// The factor that brings luminance l down to the rank bound l_k: l_k / l where l > l_k, else
// exactly 1 (the pixel is left bit-identical). l_k >= 0, so l > l_k implies l > 0.
template <class D>
HWY_INLINE V<D> firefly_scale(D d, V<D> l, V<D> l_k) {
  return hn::IfThenElse(hn::Gt(l, l_k), hn::Div(l_k, l), hn::Set(d, 1.0f));
}

// ---- Passes ------------------------------------------------------------------------------------

// The demodulation of SvgfDenoiser's step 2, as plain inputs: signal s, channel c is plane
// `signal[3s + c]`, minus the emission when `subtract_emission` (clamped at 0), divided by
// max(albedo, albedo_epsilon) when `demodulate`.
struct SignalInputs {
  int w = 0, h = 0, signals = 1;
  const float* signal[3 * kMaxSignals] = {};
  bool subtract_emission = false, demodulate = false;
  const float* emission[3] = {};  // null: none
  const float* albedo[3] = {};
  float albedo_epsilon = 1e-3f;
};

// Demodulates the signals into `out` (3S planes) and clamps fireflies: each pixel's luminance
// to the k-th largest (k = `rank`, 1..8) of its 8 neighbours' luminances, the image mirrored at
// its border (the pixel is never its own neighbour), by scaling its color. `lum` is scratch (S
// planes). Both are reallocated only if their shapes differ.
void demodulate_and_clamp_fireflies(const SignalInputs& in, int rank, ImageF& out, ImageF& lum,
                                    const Exec& exec = {});

// Step 4 with the fast-history clamp: for every plane p of `acc` (3S planes, holding this
// frame's demodulated signal on entry), acc = cur where alpha >= 1 (no history), else
//   lerp(clamp(long_prev, mean_p +- sigma sd_p), cur, alpha),
// mean_p and sd_p (population) over the (2 radius + 1)^2 window of `fast` plane p around the
// pixel, clamped to the image edge. `long_prev` 3S planes, `alpha` 1 plane.
void clamp_history_to_fast_box(const ImageF& fast, const ImageF& long_prev, const ImageF& alpha,
                               float sigma, int radius, ImageF& acc, const Exec& exec = {});

// ---- Accumulation in seconds -----------------------------------------------------------------

// The frame interval in seconds: time - prev_time when both are finite and it is positive (the
// frames' `afterimage:time`), else 1 / fallback_fps.
double frame_time_step(double time, double prev_time, float fallback_fps);
// alpha of an exponential moving average with time constant tau seconds at interval dt:
// 1 - exp(-dt / tau), clamped to the range alpha_min accepts [0.001, 1].
float alpha_for_time_constant(double dt, double tau);
// A history cap of `seconds` at interval dt: round(seconds / dt) frames, at least 1, at most
// the range history_cap accepts (1024).
int history_cap_for_seconds(double dt, double seconds);
// `s` with alpha_min, moments_alpha_min and history_cap replaced by their *_seconds
// counterparts converted at dt where those are > 0; the others unchanged.
SvgfSettings settings_at_time_step(const SvgfSettings& s, double dt);

}  // namespace afterimage::svgf
