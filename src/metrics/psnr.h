// PSNR. Images are compared as given; metrics.h applies the display transform first
// (display.h) for the tonemapped PSNR and passes linear HDR for psnr_linear_hdr.
#pragma once

#include "core/image.h"
#include "core/parallel.h"

namespace afterimage::metrics {

// 10 log10(peak^2 / mse) in dB; +infinity (std::numeric_limits<double>::infinity()) when
// mse == 0, i.e. identical images.
double psnr_from_mse(double mse, double peak = 1.0);

// Mean over every pixel and channel of (a - b)^2, accumulated in double, deterministic for
// any thread count. This is also the mean of the per-channel MSEs, so psnr(a, b) on RGB is
// the PSNR of the mean channel MSE (the usual RGB PSNR; scikit-image's convention).
double mean_squared_error(const ImageF& a, const ImageF& b, const Exec& ex = {});

// PSNR of images with values in [0, peak] (peak = 1 for display values).
double psnr(const ImageF& reference, const ImageF& test, double peak = 1.0, const Exec& ex = {});

// PSNR on linear HDR values. HDR has no fixed white, so the peak is the maximum value over
// every channel of the reference (1 if the reference has no positive value); report `peak`
// next to the number, since it changes with the content.
struct LinearPsnr {
  double psnr = 0.0;
  double peak = 1.0;
};
LinearPsnr psnr_linear_hdr(const ImageF& reference, const ImageF& test, const Exec& ex = {});

}  // namespace afterimage::metrics
