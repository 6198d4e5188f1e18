// The display transform every LDR metric is computed after (DESIGN.md §3-4): both images go
// through the *same* per-channel Reinhard tonemap (core/color.h tonemap_reinhard) and sRGB
// encoding (srgb_encode), so PSNR / SSIM / temporal error / ghosting / sharpness compare what
// a viewer would see, and bright HDR outliers do not dominate the error.
#pragma once

#include "core/color.h"
#include "core/image.h"
#include "core/parallel.h"

namespace afterimage::metrics {

struct DisplaySettings {
  float exposure = 1.0f;  // multiplies linear radiance before the tonemap; > 0
  // false: the input is already display-referred (e.g. decoded from a PNG), so the only step
  // is sRGB encoding, which returns the file's code values / 255.
  bool tonemap = true;
  void validate() const;  // throws SettingsError
};

// Linear value -> display value in [0, 1].
inline float display_value(float linear, const DisplaySettings& s) {
  return srgb_encode(s.tonemap ? tonemap_reinhard(linear, s.exposure) : linear);
}
// Linear value -> tonemapped *linear* value in [0, 1] (what LDR-FLIP takes; its sRGB encoding
// is display_value).
inline float tonemapped_linear_value(float linear, const DisplaySettings& s) {
  return s.tonemap ? tonemap_reinhard(linear, s.exposure) : std::clamp(linear, 0.0f, 1.0f);
}

// Every plane of `linear` through display_value / tonemapped_linear_value.
ImageF to_display(const ImageF& linear, const DisplaySettings& s, const Exec& ex = {});
ImageF to_tonemapped_linear(const ImageF& linear, const DisplaySettings& s, const Exec& ex = {});
// Rec.709 luma of a display RGB image (weights of DESIGN.md §3 applied to display values):
// one plane.
ImageF luma(const ImageF& rgb, const Exec& ex = {});

// Throws InputError("<what>: ...") unless a and b are non-empty with equal size and channels.
void check_same_shape(const ImageF& a, const ImageF& b, const char* what);

}  // namespace afterimage::metrics
