// Spatial upscaling of a whole image (the baselines TAAU is measured against, issue 10):
// separable Catmull-Rom bicubic (Keys a = -0.5) and Lanczos-3, with pixel centers mapped as
// in DESIGN.md §3 (output center X + 0.5 sits at input (X + 0.5) * w / W), edges clamped.
// Scalar and simple: a baseline, not a kernel to time.
#pragma once

#include "core/image.h"
#include "core/parallel.h"

namespace afterimage::taau {

enum class ResampleFilter { CatmullRom, Lanczos3 };

// Every channel of `in` resampled to width x height (any sizes >= 1); rows in parallel,
// deterministic.
ImageF resample_image(const ImageF& in, int width, int height, ResampleFilter filter,
                      const Exec& ex = {});

// The 1D kernels (exposed for tests): Catmull-Rom of |x| < 2, Lanczos-3 of |x| < 3.
double catmull_rom_kernel(double x);
double lanczos3_kernel(double x);

}  // namespace afterimage::taau
