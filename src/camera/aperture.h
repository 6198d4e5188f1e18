// Aperture sampling of the thin lens (issue 12): uniform points on a disc or a regular
// N-blade polygon from two numbers in [0, 1)^2. Pure and header-only, so the renderer and the
// tests use the same mapping. Both maps are continuous enough to keep stratification: a
// stratified (u, v) gives stratified lens positions.
#pragma once

#include <cmath>

#include "camera/camera.h"
#include "core/math.h"

namespace afterimage {

// Shirley-Chiu concentric mapping of the unit square onto the unit disc (uniform density,
// PBRT-v3 13.6.2 ConcentricSampleDisk): squares around the center go to rings.
inline Vec2d concentric_disc(Vec2d u) {
  const double a = 2.0 * u.x - 1.0, b = 2.0 * u.y - 1.0;
  if (a == 0.0 && b == 0.0) return {0.0, 0.0};
  double r, theta;
  if (std::abs(a) > std::abs(b)) {
    r = a;
    theta = (kPi / 4.0) * (b / a);
  } else {
    r = b;
    theta = kPi / 2.0 - (kPi / 4.0) * (a / b);
  }
  return {r * std::cos(theta), r * std::sin(theta)};
}

// Vertex k of the regular `blades`-gon inscribed in the unit circle, the first at
// `rotation_rad` counter-clockwise from +x.
inline Vec2d polygon_vertex(int blades, double rotation_rad, int k) {
  const double a = rotation_rad + 2.0 * kPi * k / blades;
  return {std::cos(a), std::sin(a)};
}

// Uniform point in that polygon (blades >= 3) as a triangle fan around the center: u.x picks
// one of the `blades` equal-area triangles (center, v_k, v_k+1) and, rescaled, with u.y gives a
// uniform point in it (sqrt warp of the radial coordinate, PBRT-v3 13.6.5 style).
inline Vec2d polygon_sample(Vec2d u, int blades, double rotation_rad) {
  const double x = u.x * blades;
  int k = int(std::floor(x));
  if (k >= blades) k = blades - 1;
  if (k < 0) k = 0;
  const double s = std::sqrt(x - k);  // radial: density grows linearly with distance
  const Vec2d a = polygon_vertex(blades, rotation_rad, k),
              b = polygon_vertex(blades, rotation_rad, k + 1);
  return (a * (1.0 - u.y) + b * u.y) * s;
}

// A point of the lens's aperture shape scaled to circumradius 1 (disc or polygon, rotated).
inline Vec2d aperture_sample(const ThinLens& lens, Vec2d u) {
  if (lens.blades >= 3)
    return polygon_sample(u, lens.blades, lens.blade_rotation_deg * kPi / 180.0);
  return concentric_disc(u);
}

// Whether p (circumradius-1 units) lies in the aperture shape, with tolerance eps (tests).
inline bool inside_aperture(const ThinLens& lens, Vec2d p, double eps = 1e-12) {
  if (lens.blades < 3) return p.x * p.x + p.y * p.y <= 1.0 + eps;
  // Inside every edge: the apothem cos(pi / N) along each edge's outward normal.
  const double rot = lens.blade_rotation_deg * kPi / 180.0, half = kPi / lens.blades;
  for (int k = 0; k < lens.blades; ++k) {
    const double a = rot + 2.0 * kPi * k / lens.blades + half;
    if (p.x * std::cos(a) + p.y * std::sin(a) > std::cos(half) + eps) return false;
  }
  return true;
}

}  // namespace afterimage
