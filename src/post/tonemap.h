// Tonemapping and display encoding (issue 12, "Tonemapping and output"): the last stage of a
// pipeline, mapping linear Rec.709 HDR radiance to display values in [0, 1]. A stateless
// per-pixel pass: exposure, one operator, then the sRGB transfer function (IEC 61966-2-1).
//
// Operators (each a pure function of one pixel, named after what it computes):
//  * reinhard: per channel x / (1 + x) (Reinhard et al. 2002, Eq. 3; the display transform of
//    the project's metrics, core/color.h).
//  * reinhard_extended: per channel x (1 + x / w^2) / (1 + x), which maps the white point w to
//    1 (Reinhard et al. 2002, Eq. 4), clipped above w.
//  * aces_fitted: Narkowicz's 2015 rational fit of the ACES RRT + sRGB ODT filmic curve,
//    (x (2.51 x + 0.03)) / (x (2.43 x + 0.59) + 0.14) per channel after his 0.6 pre-exposure
//    ("ACES Filmic Tone Mapping Curve", 2016 blog note), clipped to [0, 1].
//  * agx: AgX-like (after Sobotka's AgX, the Blender 4 default): the color is moved into an
//    "inset" RGB space whose primaries are pulled toward white (so very bright saturated
//    colors desaturate toward white instead of clipping per channel into hue shifts), encoded
//    as log2 exposure relative to middle grey 0.18 over [-10, +6.5] EV, shaped by a smooth
//    S-curve, and moved back (outset). Our own curve and inset amounts, not Blender's LUT.
//  * clamp: min(x, 1) (no tonemap: what a naive display does).
#pragma once

#include <cmath>
#include <string>

#include "core/image.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/params.h"

namespace afterimage::post {

enum class TonemapOperator : uint8_t { Reinhard, ReinhardExtended, AcesFitted, AgX, Clamp };

struct TonemapSettings {
  float exposure = 1.0f;  // multiplies linear radiance first
  TonemapOperator op = TonemapOperator::AcesFitted;
  float white = 4.0f;  // reinhard_extended: the radiance mapped to 1
  bool srgb = true;    // encode with the sRGB transfer function (false: linear display values)

  static const ParamTable<TonemapSettings>& params();
  void set_assignment(const std::string& assignment);
  void validate() const;
  bool operator==(const TonemapSettings&) const = default;
};

const char* to_string(TonemapOperator op);

// ---- Per-channel curves (x >= 0 after exposure) ------------------------------------------

inline float reinhard_curve(float x) {
  return x / (1.0f + x);
}
inline float reinhard_extended_curve(float x, float white) {
  return std::min(1.0f, x * (1.0f + x / (white * white)) / (1.0f + x));
}
inline float aces_fitted_curve(float x) {
  x *= 0.6f;
  return std::clamp((x * (2.51f * x + 0.03f)) / (x * (2.43f * x + 0.59f) + 0.14f), 0.0f, 1.0f);
}

// AgX-like S-curve on the normalised log encoding t in [0, 1]: a logistic of slope `k` around
// t0, rescaled so that curve(0) = 0 and curve(1) = 1 exactly.
inline float agx_curve(float t) {
  constexpr float k = 9.0f, t0 = 0.606f;  // t0: middle grey's position (10 / 16.5)
  auto s = [](float u) { return 1.0f / (1.0f + std::exp(-k * (u - t0))); };
  const float lo = s(0.0f), hi = s(1.0f);
  return (s(std::clamp(t, 0.0f, 1.0f)) - lo) / (hi - lo);
}
// log2 exposure of v relative to middle grey, normalised from [-10, +6.5] EV to [0, 1].
inline float agx_log_encode(float v) {
  constexpr float kMinEv = -10.0f, kMaxEv = 6.5f;
  const float ev = std::log2(std::max(v, 1e-10f) / 0.18f);
  return (std::clamp(ev, kMinEv, kMaxEv) - kMinEv) / (kMaxEv - kMinEv);
}
// The inset: each channel keeps 1 - 2a of itself and takes a of the other two (a = 0.1), a
// matrix whose rows sum to 1, so grey stays grey; the outset is its inverse.
Vec3f agx_inset(Vec3f c);
Vec3f agx_outset(Vec3f c);
Vec3f agx(Vec3f c);

// One pixel: exposure, operator, sRGB encoding. Non-finite or negative input channels count
// as 0 (a display value is never NaN).
Vec3f tonemap_pixel(Vec3f linear, const TonemapSettings& s);

// Every pixel of a 3-plane linear HDR image; returns display values in [0, 1]. SettingsError
// for bad settings, InputError for an image without 3 planes.
ImageF tonemap(const ImageF& linear, const TonemapSettings& s, const Exec& exec = {});

}  // namespace afterimage::post
