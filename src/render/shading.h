// Pure per-sample functions of the renderer: random numbers, camera rays, motion vectors,
// BRDF and light sampling. Header-only so tests can call every formula directly.
#pragma once

#include <cmath>
#include <cstdint>

#include "core/math.h"
#include "render/scene.h"

namespace afterimage::render {

// ---- Deterministic random numbers --------------------------------------------------------
// Counter-based: the numbers of a sample depend only on (seed, frame, pixel, sample index),
// never on which thread runs it, so renders are identical for any thread count.

// SplitMix64 finaliser (Steele et al. 2014): a bijective 64-bit mix.
inline uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// Small per-pixel generator seeded from a hashed key.
struct Rng {
  uint64_t state;
  explicit Rng(uint64_t key) : state(mix64(key)) {}
  uint64_t next() { return mix64(state += 0x9e3779b97f4a7c15ULL); }
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)
};

inline uint64_t pixel_key(uint64_t seed, int frame, int x, int y, int pass) {
  uint64_t k = mix64(seed ^ 0x5851f42d4c957f2dULL);
  k = mix64(k ^ uint64_t(uint32_t(frame)));
  k = mix64(k ^ (uint64_t(uint32_t(y)) << 32 | uint32_t(x)));
  return mix64(k ^ uint64_t(uint32_t(pass)));
}

// Position of sample `k` of `n * n` stratified samples inside pixel (x, y): one uniform
// point per cell of an n x n grid over [x, x+1) x [y, y+1) (pixel coordinates, y down).
inline Vec2d stratified_sample(int x, int y, int n, int k, Rng& rng) {
  const int a = k % n, b = k / n;
  const double u = rng.uniform(), v = rng.uniform();
  return {x + (a + u) / n, y + (b + v) / n};
}

// ---- Camera rays and motion vectors --------------------------------------------------------

struct Ray {
  Vec3d origin;
  Vec3d dir;  // unit
};

// Primary ray through the pixel-space position `p` (x right, y down) of a camera with
// inverse view-projection `inv_vp`: the segment between the unprojected near (NDC z = -1)
// and far (NDC z = +1) points. Using the *unjittered* VP at the jittered position equals
// rasterising with jittered_projection at the pixel center (DESIGN.md §3 Jitter).
inline Ray camera_ray(const Mat4& inv_vp, Vec2d p, int width, int height) {
  const double nx = 2.0 * p.x / width - 1.0, ny = 1.0 - 2.0 * p.y / height;
  const Vec4d a = inv_vp * Vec4d(nx, ny, -1.0, 1.0);
  const Vec4d b = inv_vp * Vec4d(nx, ny, 1.0, 1.0);
  const Vec3d pa = a.xyz() / a.w, pb = b.xyz() / b.w;
  return {pa, normalize(pb - pa)};
}

// Pixel position (x right, y down) of a homogeneous world point under a view-projection.
inline Vec2d project_homogeneous(const Mat4& vp, const Vec4d& p, int width, int height) {
  const Vec4d c = vp * p;
  return {(c.x / c.w + 1.0) * 0.5 * width, (1.0 - c.y / c.w) * 0.5 * height};
}

// Motion vector of a surface point (DESIGN.md §3): p_prev - p_curr in pixels, both under
// *unjittered* view-projections. `world_prev` is the same material point at the previous
// frame time (object motion: M_prev * M_curr^-1 * world_curr; seed 003 "Object Motion
// Vector"); for static objects it equals `world_curr` and this is seed 003's camera motion
// vector (reproject with the previous VP, subtract the current position).
inline Vec2d surface_motion(const Mat4& vp_prev, const Mat4& vp_curr, Vec3d world_prev,
                            Vec3d world_curr, int width, int height) {
  return project_homogeneous(vp_prev, Vec4d(world_prev, 1.0), width, height) -
         project_homogeneous(vp_curr, Vec4d(world_curr, 1.0), width, height);
}

// Motion of a direction at infinity (sky): w = 0 drops the camera translation, so only the
// rotation (and projection change) moves the background.
inline Vec2d direction_motion(const Mat4& vp_prev, const Mat4& vp_curr, Vec3d dir, int width,
                              int height) {
  return project_homogeneous(vp_prev, Vec4d(dir, 0.0), width, height) -
         project_homogeneous(vp_curr, Vec4d(dir, 0.0), width, height);
}

// ---- Shading -----------------------------------------------------------------------------

// Tangent-frame slope (s_u, s_v) of a material's bump at a surface UV, |s| <= bump_slope
// (scene.h Bump). Point sampled, like material_albedo.
inline Vec2d bump_slope(const Material& m, Vec2d uv) {
  const double f = m.bump_frequency, s = m.bump_slope;
  switch (m.bump) {
    case Bump::None:
      return {0.0, 0.0};
    case Bump::Sine: {
      // Gradient of sin(a) sin(b) over (a, b), whose length is at most 1.
      const double a = 2.0 * kPi * f * uv.x, b = 2.0 * kPi * f * uv.y;
      return {s * std::cos(a) * std::sin(b), s * std::sin(a) * std::cos(b)};
    }
    case Bump::Flakes: {
      // One tilt per cell, uniform over the disc of radius s: a hash of the cell, so every
      // point of a flake (and every frame) sees the same tilt.
      const auto i = int64_t(std::floor(uv.x * f)), j = int64_t(std::floor(uv.y * f));
      const uint64_t h1 = mix64(mix64(uint64_t(i) ^ 0x632be59bd9b4e019ULL) ^ uint64_t(j));
      const uint64_t h2 = mix64(h1);
      const double r = s * std::sqrt(double(h1 >> 11) * 0x1.0p-53);
      const double phi = 2.0 * kPi * double(h2 >> 11) * 0x1.0p-53;
      return {r * std::cos(phi), r * std::sin(phi)};
    }
  }
  return {0.0, 0.0};
}

// Bump-mapped shading normal: unit n tilted by the slope (s_u, s_v) in the tangent frame
// T = dp/du made orthogonal to n, B = n x T oriented along dp/dv: normalize(n - s_u T - s_v B).
// A zero slope returns n unchanged; a degenerate dp/du falls back to any frame around n.
inline Vec3d perturb_normal(Vec3d n, Vec3d dpdu, Vec3d dpdv, Vec2d slope) {
  if (slope.x == 0.0 && slope.y == 0.0) return n;
  Vec3d t = dpdu - n * dot(n, dpdu);
  if (!(length(t) > 1e-12)) t = cross(std::abs(n.x) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0}, n);
  t = normalize(t);
  Vec3d b = cross(n, t);
  if (dot(b, dpdv) < 0.0) b = -b;
  return normalize(n - t * slope.x - b * slope.y);
}

// Lambert + normalised Blinn-Phong BRDF times cos(theta_l), for unit n (toward the viewer),
// v (toward the viewer) and l (toward the light). The (s + 8) / (8 pi) factor keeps the
// lobe's energy roughly constant as the exponent changes (Akenine-Moller et al., RTR4 7.8).
inline Vec3d brdf_cos(Vec3d albedo, double ks, double shininess, Vec3d n, Vec3d v, Vec3d l) {
  const double nl = dot(n, l);
  if (nl <= 0.0) return Vec3d(0.0);
  Vec3d f = albedo * (1.0 / kPi);
  if (ks > 0.0) {
    const Vec3d h = normalize(v + l);
    const double nh = std::max(0.0, dot(n, h));
    f += Vec3d(ks * (shininess + 8.0) / (8.0 * kPi) * std::pow(nh, shininess));
  }
  return f * nl;
}

// brdf_cos split into its two lobes, so that the diffuse part can be demodulated (stored
// without the albedo) and cached across frames (issue 13): brdf_cos = albedo * diffuse +
// specular, both already multiplied by cos(theta_l) (0 below the horizon).
struct BrdfCosSplit {
  double diffuse = 0.0;   // cos(theta_l) / pi
  double specular = 0.0;  // ks (s + 8) / (8 pi) (n.h)^s cos(theta_l)
};
inline BrdfCosSplit brdf_cos_split(double ks, double shininess, Vec3d n, Vec3d v, Vec3d l) {
  const double nl = dot(n, l);
  if (nl <= 0.0) return {};
  BrdfCosSplit r{nl / kPi, 0.0};
  if (ks > 0.0) {
    const Vec3d h = normalize(v + l);
    const double nh = std::max(0.0, dot(n, h));
    r.specular = ks * (shininess + 8.0) / (8.0 * kPi) * std::pow(nh, shininess) * nl;
  }
  return r;
}

// Color of a shaded G-buffer sample from its parts: `base` (emission + albedo * ambient, or
// the sky), the demodulated direct diffuse light (irradiance / pi) and the direct specular
// light. The renderer and the shading cache (issue 13) both compose through this one function.
template <class V3>
inline V3 compose_shading(V3 base, V3 albedo, V3 diffuse, V3 specular) {
  return base + albedo * diffuse + specular;
}

// One light sample seen from a shading point: direction, shadow-ray length and the
// irradiance-like weight E such that the contribution is brdf_cos(...) * E when unoccluded.
struct LightSample {
  Vec3d dir;        // unit, toward the light
  double distance;  // shadow ray stops here (before the light's own geometry)
  Vec3d weight;     // radiance * solid angle (sphere), irradiance (directional, point)
};

// Samples light `l` from point `p`. Quad lights: the point at `uv` (its center for hard
// shadows). Sphere lights: `uv` = (0.5, 0.5) aims at the center
// (hard shadow, the G-buffer default); other uv sample the cone subtended by the sphere
// uniformly in solid angle (PBRT-v3 14.2.2 / 13.6 "sampling a cone"). Either way the weight
// is L * Omega with the exact solid angle Omega = 2 pi (1 - cos theta_max), so hard and soft
// shadows agree on unoccluded irradiance. Returns false if p is inside the light.
inline bool sample_light(const Light& l, Vec3d p, Vec2d uv, bool center, LightSample* s) {
  const Vec3d c = to_double(l.color);
  switch (l.type) {
    case LightType::Directional:
      *s = {normalize(l.position), 1e30, c};
      return true;
    case LightType::Point: {
      const Vec3d d = l.position - p;
      const double r2 = dot(d, d);
      if (r2 <= 0.0) return false;
      const double r = std::sqrt(r2);
      *s = {d / r, r * (1.0 - 1e-6), c / r2};
      return true;
    }
    case LightType::Sphere: {
      const Vec3d d = l.position - p;
      const double dist = length(d);
      if (dist <= l.radius * 1.0001) return false;
      const Vec3d w = d / dist;
      const double sin2 = (l.radius * l.radius) / (dist * dist);
      const double cos_max = std::sqrt(std::max(0.0, 1.0 - sin2));
      const double omega = 2.0 * kPi * (1.0 - cos_max);
      // The light's tessellated mesh lies inside its sphere: stop short of the sphere.
      const double stop = (dist - l.radius) * (1.0 - 1e-4);
      if (center) {
        *s = {w, stop, c * omega};
        return true;
      }
      const double cos_t = 1.0 - uv.x * (1.0 - cos_max);
      const double sin_t = std::sqrt(std::max(0.0, 1.0 - cos_t * cos_t));
      const double phi = 2.0 * kPi * uv.y;
      // Orthonormal basis around w (Duff et al. 2017, "Building an orthonormal basis").
      const double sign = std::copysign(1.0, w.z);
      const double a = -1.0 / (sign + w.z), b = w.x * w.y * a;
      const Vec3d t1{1.0 + sign * w.x * w.x * a, sign * b, -sign * w.x};
      const Vec3d t2{b, sign + w.y * w.y * a, -w.y};
      const Vec3d dir =
          normalize(t1 * (sin_t * std::cos(phi)) + t2 * (sin_t * std::sin(phi)) + w * cos_t);
      *s = {dir, stop, c * omega};
      return true;
    }
    case LightType::Quad: {
      // The point at `uv` of the parallelogram (its center for hard shadows), weighted as one
      // sample of uniform area sampling: L A cos(theta_l) / d^2 (PBRT-v3 14.2.2, area lights).
      const Vec3d q = l.position + l.edge_u * (uv.x - 0.5) + l.edge_v * (uv.y - 0.5);
      const Vec3d d = q - p, nq = cross(l.edge_u, l.edge_v);
      const double dist = length(d), area = length(nq);
      if (!(dist > 0.0)) return false;
      const Vec3d w = d / dist;
      const double cos_l = -dot(w, nq) / area;
      if (cos_l <= 0.0) return false;  // behind the emitting side
      *s = {w, dist * (1.0 - 1e-4), c * (area * cos_l / (dist * dist))};
      return true;
    }
  }
  return false;
}

}  // namespace afterimage::render
