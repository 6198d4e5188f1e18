// SSIM: Wang, Bovik, Sheikh, Simoncelli, "Image Quality Assessment: From Error Visibility to
// Structural Similarity", IEEE TIP 2004. Gaussian-weighted statistics (11x11 window,
// sigma = 1.5), K1 = 0.01, K2 = 0.03, population (not sample) covariances, data range 1.
//
// Border convention (scikit-image's structural_similarity, which tests/data/ssim checks us
// against): local statistics are filtered with the window truncated at radius
// r = int(3.5 sigma + 0.5) = 5 (so 11 taps), with mirror ("reflect") padding, and the *mean*
// SSIM averages only pixels at least r from every border, where the window lies inside the
// image. The map (ssim_map) covers every pixel, borders from the mirrored statistics.
#pragma once

#include "core/image.h"
#include "core/parallel.h"

namespace afterimage::metrics {

struct SsimSettings {
  double k1 = 0.01;
  double k2 = 0.03;
  double sigma = 1.5;       // Gaussian window std dev in pixels
  double truncate = 3.5;    // window radius = int(truncate * sigma + 0.5)
  double data_range = 1.0;  // L of the paper: C1 = (K1 L)^2, C2 = (K2 L)^2
  void validate() const;    // throws SettingsError
  int radius() const;
};

// Mean SSIM of one pair of planes. Throws InputError if the sizes differ or the image is
// smaller than the window (2r + 1 in either direction).
double ssim(PlaneView reference, PlaneView test, const SsimSettings& s = {}, const Exec& ex = {});

// Mean over channels of the per-channel mean SSIM (scikit-image's channel_axis convention).
double ssim_channels(const ImageF& reference, const ImageF& test, const SsimSettings& s = {},
                     const Exec& ex = {});

// Per-pixel SSIM of one pair of planes (1 plane).
ImageF ssim_map(PlaneView reference, PlaneView test, const SsimSettings& s = {},
                const Exec& ex = {});

}  // namespace afterimage::metrics
