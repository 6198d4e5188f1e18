// Depth of field by simulated heat diffusion (issue 12; seed 004 "Depth of Field": the image
// as a heat distribution, each pixel's circle of confusion its conductivity, the in-focus
// region a perfect insulator): Kass, Lefohn, Owens, "Interactive Depth of Field Using
// Simulated Diffusion on a GPU", Pixar Technical Memo 06-01, 2006. DofSettings::mode=diffusion.
//
// One implicit step of the heat equation dy/dt = div(g grad y) with the pinhole image x as the
// initial state, solved by alternating directions (ADI): first every row, then every column of
// the rows' result, each a tridiagonal system
//   y_i + g_{i-1} (y_i - y_{i-1}) + g_i (y_i - y_{i+1}) = x_i
// (Thomas algorithm, one line per task: deterministic; image borders insulated). Because the
// conductance g_i between neighbours i and i+1 is one value shared by the pair, the operator's
// columns sum to one: the image's sum (energy) is conserved, and a constant stays constant
// (up to float rounding: the factored operator is stored in float, the sweeps run in double).
//
// Conductance at depth discontinuities: one value from the pair, the smaller of the two
// pixels' conductivities, so an in-focus pixel (CoC radius < 0.5 px: conductivity 0) is an
// insulator — neither does a blurred background spread over a sharp object nor the object
// into the background. Conductivity of a pixel of CoC radius r: scale * r^2 / 8. With uniform
// g one implicit step along a line is a symmetric filter of variance 2 g per axis (its Fourier
// response is 1 / (1 + 2 g (1 - cos w))), and a disc of radius r has variance r^2 / 4 per axis:
// g = r^2 / 8 gives the diffusion the second moment of the thin lens's disc (the paper's
// conductivity proportional to the squared CoC, with the constant fixed by that match).
// `steps` > 1 splits the same blur into several implicit steps of g / steps (same variance,
// a kernel closer to a Gaussian than the single step's exponential tails).
//
// The near field: one layer cannot let a blurred foreground spread over a sharp background
// (the insulating edge stops it); Kass et al. diffuse separate layers and composite them
// front to back. From one image the only layer we can separate is the near field (CoC < 0,
// radius >= 0.5 px): its premultiplied color and coverage (1 on it, 0 elsewhere) diffuse on
// their own — near pixels with their own conductivity, the pixels around with the largest near
// radius of the 3x3 tiles around them — and are composited over the one-layer result:
// out = near + (1 - near_alpha) * rest; in the rest, near and other pixels then exchange no
// heat (else the near blur would count twice). Optional (diffusion_near_layer, off: it
// measured worse on `focus`, see DofSettings); without near pixels it changes nothing.
#pragma once

#include "core/image.h"
#include "core/parallel.h"
#include "frame/frame.h"
#include "post/dof.h"

namespace afterimage::post {

// Conductivity of a pixel of CoC radius r (pixels): 0 in the focus field (r < 0.5), else
// scale * r^2 / 8 (the variance match above).
inline float diffusion_conductivity(float radius, float scale) {
  return radius < 0.5f ? 0.0f : scale * radius * radius * 0.125f;
}
// Conductance between two neighbours: the smaller conductivity (a sharp pixel insulates).
inline float pair_conductance(float a, float b) {
  return a < b ? a : b;
}

// One line of the implicit step (Thomas algorithm): solves
//   (1 + g[i-1] + g[i]) y[i] - g[i-1] y[i-1] - g[i] y[i+1] = x[i],  i in [0, n),
// with g[-1] = g[n-1] = 0 (insulated ends; g[n-1] is ignored). `scratch` holds 2n values.
// y may alias x.
void solve_heat_line(const double* g, const double* x, double* y, int n, double* scratch);

// The pass (mode=diffusion); called by depth_of_field after its checks of the frame, color
// and lens (the lens is not a pinhole).
ImageF depth_of_field_diffusion(const Frame& frame, const ImageF& color, const DofSettings& s,
                                const Exec& exec = {});

}  // namespace afterimage::post
