// OpenCV's multi-frame non-local means as a peer denoiser (issue 11, "Peers and baselines"):
// cv::fastNlMeansDenoisingColoredMulti (Buades, Coll, Morel, "A non-local algorithm for image
// denoising", CVPR 2005, with a temporal window), what a user without a real-time denoiser
// reaches for. It works on 8-bit images, so each HDR frame goes through the project's display
// transform (metrics/display.h: Reinhard, then sRGB) to 8 bits, is denoised with its
// neighbours, and comes back through the exact inverse of that transform — `eval` then scores
// it like any other method (its metrics apply the same display transform).
#pragma once

#include <string>
#include <vector>

#include "core/image.h"
#include "core/parallel.h"
#include "core/params.h"

namespace afterimage::peers {

struct NlmSettings {
  float h = 10.0f;        // luminance filter strength (OpenCV's h, 8-bit units)
  float h_color = 10.0f;  // chroma filter strength (hColor)
  int window = 5;         // temporal window (odd): the frame and (window - 1) / 2 each side
  int template_size = 7;  // patch size (odd)
  int search_size = 21;   // search window (odd)
  float exposure = 1.0f;  // before the display transform, as `eval --exposure`

  static const ParamTable<NlmSettings>& params();
  void validate() const { params().validate(*this); }
};

// HDR <-> 8-bit code values through the display transform and its inverse. The inverse maps
// code 255 to the radiance of code 254.5 (Reinhard's inverse has a pole at display 1).
unsigned char display_code(float linear, float exposure);
float linear_from_code(float code, float exposure);

// The temporal window actually used for frame k of n: `window`, shrunk (odd, centred) where
// the sequence does not have (window - 1) / 2 frames on both sides.
int nlm_window_at(size_t k, size_t n, int window);

// Frame k of `noisy` (RGB, all the same size) denoised with its temporal window. InputError
// for an empty sequence, mixed sizes or non-RGB images; SettingsError for bad settings.
ImageF opencv_nlm_frame(const std::vector<ImageF>& noisy, size_t k, const NlmSettings& s,
                        const Exec& ex = {});

}  // namespace afterimage::peers
