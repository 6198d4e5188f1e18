// The spatial passes of SVGF (Schied et al., HPG 2017, Sec. 4.2-4.3) as pure functions over
// images, shared by SvgfDenoiser and the tests: depth gradient, variance estimation and one
// edge-avoiding à-trous iteration. Images hold S illumination signals (diffuse and specular,
// or one combined signal): color 3S planes (signal s in planes 3s..3s+2), variance S planes,
// moments 2S planes (signal s: mean in plane 2s, central variance in 2s+1; svgf_kernels.h).
// reference.h states each pass plainly, pixel by pixel; --simd off runs that, otherwise the fast
// schedule (filter_fast.h), with the same bits. Rows are independent: results are bit-identical
// for any thread count.
#pragma once

#include <cstdint>

#include "core/image.h"
#include "core/parallel.h"
#include "svgf/settings.h"

namespace afterimage::svgf {

// At most this many signals are filtered apart.
inline constexpr int kMaxSignals = 2;

// The geometry that drives the edge-stopping weights: linear view depth (1 plane), unit normal
// (3; zero for background, which then never mixes with anything), depth gradient dZ/dx, dZ/dy
// per pixel (2). All finite.
struct Guide {
  const ImageF* depth = nullptr;
  const ImageF* normal = nullptr;
  const ImageF* gradient = nullptr;
};

// Screen-space depth gradient per pixel (2 planes) from depth alone, for frames without a
// depth_gradient channel: per axis the central difference where the two one-sided differences
// agree, else the one of smaller magnitude, so a pixel beside a silhouette takes its own
// surface's slope instead of half the depth step (a step would otherwise widen the depth
// tolerance of the edge-stopping weight until it accepts the other surface). One-sided at the
// image border. `out` is reallocated only if its shape differs.
void depth_gradient(const ImageF& depth, ImageF& out, const Exec& exec = {});

// Per-pixel luminance variance (Sec. 4.2): the temporal estimate (the moments' central variance)
// where the history length n >= temporal_variance_frames, else the spatial estimate over the
// (2 spatial_radius + 1)^2 window of accumulated moments, weighted by the depth and normal
// edge-stopping functions (center weight 1). `moments` 2S planes, `length` 1 plane; writes
// `variance` (S planes, reallocated if its shape differs).
void estimate_variance(const Guide& g, const ImageF& moments, const ImageF& length,
                       const SvgfSettings& s, ImageF& variance, const Exec& exec = {});

// One à-trous iteration with step `step` (2^i) over color (3S planes) and variance (S planes):
//   c'(p)   = sum_q h(q) w(p,q) c(q) / sum_q h(q) w(p,q)                       (seed 001 Eq.二.1)
//   Var'(p) = sum_q h(q)^2 w(p,q)^2 Var(q) / (sum_q h(q) w(p,q))^2            (Eq.二.4)
// with h the 5x5 B3 kernel at offsets step * (-2..2) (or, with atrous_kernel = 3x3, the linear
// B-spline (1/4, 1/2, 1/4)^2 at step * (-1..1)), w = w_z w_n w_l (Eq.二.2) and the
// luminance weight normalised by sigma_l sqrt(g3x3(Var)) (Eq.二.3; the 3x3 Gaussian only
// drives the weight). Taps outside the image are left out (the sums renormalise). Writes
// out_color / out_variance (reallocated if their shapes differ; must not alias the inputs).
void atrous_iteration(const Guide& g, const ImageF& color, const ImageF& variance, int step,
                      const SvgfSettings& s, ImageF& out_color, ImageF& out_variance,
                      const Exec& exec = {});

// Remodulation (denoiser.h step 7), the inverse of the demodulation: color = emission + sum over
// signals of factor * filtered, the factor per signal max(albedo, eps) for a demodulated signal,
// the albedo itself for the renderer's demodulated diffuse (color = emission + albedo diffuse +
// specular), else 1; where that is not finite, the (sanitised) input color.
enum class Remodulation : uint8_t { One, Demodulated, Albedo };
struct RemodulationInputs {
  Remodulation factor[kMaxSignals] = {};
  float albedo_epsilon = 1e-3f;
  const ImageF* emission = nullptr;  // 3 planes, or null: none
  const ImageF* albedo = nullptr;    // 3 planes; needed when a factor is not One
  const ImageF* color = nullptr;     // 3 planes: the output where remodulation overflows
};

// The last à-trous iteration with remodulation in its store (no separate pass over the image):
// `out` (3 planes, reallocated if its shape differs) receives the remodulated color of what
// atrous_iteration would write to out_color; no variance is computed (nothing reads the last
// iteration's). `filtered`, when not null, also receives atrous_iteration's out_color (a single
// iteration is also the first, whose output is the color history).
void atrous_iteration_remodulated(const Guide& g, const ImageF& color, const ImageF& variance,
                                  int step, const SvgfSettings& s, const RemodulationInputs& r,
                                  ImageF& out, ImageF* filtered = nullptr, const Exec& exec = {});

}  // namespace afterimage::svgf
