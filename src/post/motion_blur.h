// Motion blur as a post process over the G-buffer (issue 12; seed 004 "Motion Blur"):
// McGuire, Hennessy, Bukowski, Osman, "A Reconstruction Filter for Plausible Motion Blur"
// (I3D 2012), with the mirrored sample pairs of Jimenez, "Next Generation Post Processing in
// Call of Duty: Advanced Warfare" (SIGGRAPH 2014).
//
// The exposure of a frame is `shutter` of the frame interval centred on the frame time, so a
// point moving by m pixels per frame sweeps m * shutter pixels, centred on where it is drawn.
// Velocities are clamped to `max_radius` pixels of half-length. Per tile of max_radius x
// max_radius pixels the largest velocity (TileMax), then the largest of the 3x3 tiles around
// (NeighborMax) bound what can blur into a pixel; pixels whose neighbourhood is still keep
// their color exactly (the early exit). Otherwise `samples` taps along the neighbourhood's
// dominant velocity, placed symmetrically in mirrored pairs with a per-pixel jitter of half a
// sample (against banding), each weighted by McGuire's cone (a tap moving over this pixel), the
// reverse cone (this pixel moving over the tap) and the cylinder pair (both moving together),
// each gated by a soft depth comparison so that a still background is never smeared over a
// moving foreground and a foreground smears over the background.
#pragma once

#include <cmath>
#include <string>

#include "core/image.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/params.h"
#include "frame/frame.h"

namespace afterimage::post {

struct MotionBlurSettings {
  float shutter = 0.5f;      // fraction of the frame interval the shutter is open (180 degrees)
  int max_radius = 20;       // pixels: half-length clamp of the blur and the tile size
  int samples = 15;          // taps along the dominant velocity (odd: the centre is the pixel)
  float soft_depth = 0.02f;  // relative depth extent of the soft comparison

  static const ParamTable<MotionBlurSettings>& params();
  void set_assignment(const std::string& assignment);
  void validate() const;
};

// ---- Per-pixel functions (McGuire et al. 2012, Sec. 3) ------------------------------------

// Half-length blur vector of a pixel: motion m (p_prev - p_curr) reversed to the direction of
// travel, times the shutter, halved, clamped to `max_radius` (keeps direction).
inline Vec2d blur_half_vector(float mx, float my, float shutter, int max_radius) {
  Vec2d v{-0.5 * shutter * mx, -0.5 * shutter * my};
  const double len = std::sqrt(v.x * v.x + v.y * v.y);
  if (!(len <= max_radius))
    v = len > 0 && std::isfinite(len) ? v * (max_radius / len) : Vec2d{0, 0};
  return v;
}
// 1 - |x - y| / |v|, clamped: a tap y whose blur of half-length |v| reaches x.
inline double cone_weight(double distance, double v_len) {
  return std::clamp(1.0 - distance / std::max(v_len, 1e-6), 0.0, 1.0);
}
// 1 - smoothstep(0.95 |v|, 1.05 |v|, distance): both inside the same blur.
inline double cylinder_weight(double distance, double v_len) {
  const double a = 0.95 * v_len, b = 1.05 * v_len;
  if (distance <= a) return 1.0;
  if (distance >= b) return 0.0;
  const double t = (distance - a) / (b - a);
  return 1.0 - t * t * (3.0 - 2.0 * t);
}
// clamp(1 - (z_a - z_b) / (extent * min(z_a, z_b)), 0, 1): 1 when a is in front of b (or level).
inline double soft_depth_compare(double z_a, double z_b, double extent) {
  return std::clamp(1.0 - (z_a - z_b) / (extent * std::min(z_a, z_b)), 0.0, 1.0);
}

// The pass: `frame` gives color, depth and motion. SettingsError for bad settings, InputError
// for a frame without depth or motion. Non-finite motion counts as still.
ImageF motion_blur(const Frame& frame, const ImageF& color, const MotionBlurSettings& s,
                   const Exec& exec = {});

}  // namespace afterimage::post
