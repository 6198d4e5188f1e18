// A-SVGF temporal gradients in the filter (Schied, Peters, Dachsbacher, "Gradient Estimation
// for Real-Time Adaptive Temporal Filtering", HPG 2018, Sec. 4 and 5): the renderer's sparse
// gradient samples (channel `gradient` = delta, max, valid at one pixel per 3x3 stratum;
// render/path_tracer.h "Gradient samples") are reconstructed at stratum resolution by a few
// edge-aware à-trous iterations, turned into the normalised change
//   lambda = min(1, |delta~| / max~)            (delta and max filtered separately, Eq. 6)
// and raise the temporal blend where the lighting changed:
//   alpha' = (1 - lambda) alpha + lambda        (Sec. 5, color and moments),
//   n'     = (1 - lambda) n                     (optional: the history length shortened).
// Rows are independent: results are bit-identical for any thread count.
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
// Writes `strata` (4 planes at stratum resolution: delta, max, confidence, lambda) and `lambda`
// (1 plane at full resolution, each pixel its stratum's lambda). Images are reallocated only if
// their shapes differ.
void reconstruct_gradient(const ImageF& gradient, const Guide& g, const ImageF& luminance,
                          const SvgfSettings& s, ImageF& strata, ImageF& lambda,
                          const Exec& exec = {});

}  // namespace afterimage::svgf
