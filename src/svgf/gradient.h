// A-SVGF temporal gradients in the filter (Schied, Peters, Dachsbacher, "Gradient Estimation
// for Real-Time Adaptive Temporal Filtering", HPG 2018, Sec. 4 and 5): the renderer's sparse
// gradient samples (channel `gradient` = delta, max, valid at one pixel per 3x3 stratum;
// render/path_tracer.h "Gradient samples") are reconstructed at stratum resolution by a few
// edge-aware à-trous iterations, turned into the normalised change
//   lambda = min(1, |delta~| / max~)            (delta and max filtered separately, Eq. 6)
// and raise the temporal blend where the lighting changed:
//   alpha' = (1 - lambda) alpha + lambda        (Sec. 5, color and moments),
//   n'     = (1 - lambda) n                     (optional: the history length shortened).
// Beyond the paper (SvgfSettings::gradient_relight): the history is first RELIT, multiplied by
// the reconstructed luminance ratio now / prev = 1 + delta~ / prev~ (prev = the previous
// frame's sample luminance, recovered from (delta, max); filtered like delta and max). Why:
// the paper's rule can only discard history, and after a moderate change (the lamp of
// room_light adds 20-30% to the right half of the room: lambda ~0.2-0.3 there, as the
// references' own normalised change) it keeps (1 - lambda)(1 - alpha) of the stale history,
// i.e. a bias of ~10% of the luminance that no later gradient sees (the next frames' samples
// agree with each other); discarding more costs as much 1-spp noise as it removes bias (lambda
// forced to 1: display error 2 frames after the switch .0191, worse than the paper's .0187).
// The gradient samples measure the change itself, so the history is corrected instead of
// dropped. Static scenes re-trace bit-identical samples: delta 0, ratio exactly 1.
// The à-trous over the strata is stated plainly in reference.h (gradient_atrous_at), which
// --simd off runs; the lanes give the same bits. Rows are independent: results are
// bit-identical for any thread count.
#pragma once

#include <algorithm>
#include <cmath>

#include "core/image.h"
#include "core/parallel.h"
#include "svgf/filter.h"
#include "svgf/settings.h"

namespace afterimage::svgf {

// Side of a gradient stratum in pixels (render::kGradientStratum; svgf does not depend on
// render/).
inline constexpr int kGradientStratumSize = 3;

// The normalised temporal change of one stratum: min(1, |delta| / max), 0 where max <= 0 or
// either value is not finite (no usable gradient: plain temporal accumulation).
// `scale` multiplies the ratio (SvgfSettings::gradient_scale; 1 = the paper).
inline float gradient_lambda(float delta, float max, float scale = 1.0f) {
  if (!(max > 0.0f) || !std::isfinite(delta) || !std::isfinite(max)) return 0.0f;
  return std::min(1.0f, scale * std::abs(delta) / max);
}

// The temporal blend factor raised by lambda in [0, 1]: (1 - lambda) alpha + lambda (lambda 0:
// alpha unchanged; 1: history dropped).
inline float gradient_alpha(float alpha, float lambda) {
  return (1.0f - lambda) * alpha + lambda;
}

// The previous frame's luminance of a gradient sample: delta = now - prev and max = max(now,
// prev), so prev = max - max(delta, 0).
inline float gradient_sample_previous(float delta, float max) {
  return max - std::max(delta, 0.0f);
}

// Largest factor gradient_relight scales the history by (or 1 / it): beyond a 4x change the
// history is too far off to be worth correcting, and lambda (~1 there) discards it anyway.
inline constexpr float kMaxRelight = 4.0f;

// The history's relighting factor from a reconstructed (delta, prev): now / prev = 1 + delta /
// prev, clamped to [1 / kMaxRelight, kMaxRelight]; 1 where prev <= 0 or either value is not
// finite (nothing to scale, or no usable gradient).
inline float gradient_relight(float delta, float prev) {
  if (!(prev > 0.0f) || !std::isfinite(delta) || !std::isfinite(prev)) return 1.0f;
  return std::clamp(1.0f + delta / prev, 1.0f / kMaxRelight, kMaxRelight);
}

// A usable gradient sample: valid set and delta, max finite (a NaN never enters the filter).
inline bool gradient_sample_usable(float delta, float max, float valid) {
  return valid > 0.0f && std::isfinite(delta) && std::isfinite(max) && max >= 0.0f;
}

// Reconstructs the sparse gradient of a frame. `gradient` 3 planes (delta, max, valid) at full
// resolution, `g` the frame's geometry, `luminance` 1 plane (the noisy input's luminance, the
// third edge-stopping guide). Per stratum the guide is the pixel holding the sample, else the
// stratum's center pixel (clamped to the image). `iterations` (>= 0) à-trous passes of the 5x5
// B3 kernel at stratum steps 2^i, weights w_z w_n (SVGF's, Eq. 2.2 with sigma_z, sigma_n; the
// depth tolerance scaled by the 3 px stratum) and a luminance weight
// exp(-|l_p - l_q| / (sigma_l (l_p + l_q) / 2 + 1e-4)) with the settings' sigma_l (relative: the
// guide is a 1-spp sample, whose noise scales with its value), over the
// samples' confidence (normalised convolution: empty strata take their neighbours' values).
// The samples' previous luminance (gradient_sample_previous) is filtered with the same weights.
// Writes `strata` (5 planes at stratum resolution: delta, max, confidence, lambda, relight
// factor), `lambda` (1 plane at full resolution, each pixel its stratum's lambda) and, when
// given, `relight` (likewise, the stratum's gradient_relight factor). Images are reallocated
// only if their shapes differ.
void reconstruct_gradient(const ImageF& gradient, const Guide& g, const ImageF& luminance,
                          const SvgfSettings& s, ImageF& strata, ImageF& lambda,
                          ImageF* relight = nullptr, const Exec& exec = {});

}  // namespace afterimage::svgf
