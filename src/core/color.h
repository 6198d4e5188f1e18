// Color conventions (DESIGN.md §3): linear scene-referred Rec.709, HDR float.
#pragma once

#include <algorithm>
#include <cmath>

#include "core/math.h"

namespace afterimage {

// Rec.709 luminance.
inline float luminance(Vec3f c) {
  return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z;
}

// YCoCg (seed 003, RGB2YCoCg / YCoCg2RGB): a lossless linear transform whose first axis is
// luma, so an AABB in YCoCg is tighter around neighbourhoods whose spread is mostly luma.
inline Vec3f rgb_to_ycocg(Vec3f c) {
  return {c.x * 0.25f + c.y * 0.5f + c.z * 0.25f, c.x * 0.5f - c.z * 0.5f,
          -c.x * 0.25f + c.y * 0.5f - c.z * 0.25f};
}
inline Vec3f ycocg_to_rgb(Vec3f c) {
  return {c.x + c.y - c.z, c.x + c.z, c.x - c.y - c.z};
}

// sRGB transfer function (IEC 61966-2-1).
inline float srgb_encode(float v) {
  v = std::clamp(v, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}
inline float srgb_decode(float v) {
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

// Tonemap used everywhere an HDR image is shown or compared in LDR (metrics, report, PNG):
// per-channel Reinhard x / (1 + x) after exposure. Simple, monotone, invertible and the same
// on both sides of every comparison.
inline float tonemap_reinhard(float x, float exposure = 1.0f) {
  x = std::max(0.0f, x * exposure);
  return x / (1.0f + x);
}

}  // namespace afterimage
