// Scalar parts of the TAA building blocks: the per-frame current-filter weights and the
// convex-hull clip (one pixel at a time; called per lane by the templated wrapper).
#include <algorithm>
#include <cmath>

#include "taa/taa_kernels.h"

namespace afterimage::taa {

float mitchell_netravali(float x, float b, float c) {
  // Mitchell & Netravali 1988: the two-parameter (B, C) family of piecewise cubics.
  x = std::abs(x);
  const float x2 = x * x, x3 = x2 * x;
  if (x < 1.0f)
    return ((12.0f - 9.0f * b - 6.0f * c) * x3 + (-18.0f + 12.0f * b + 6.0f * c) * x2 +
            (6.0f - 2.0f * b)) /
           6.0f;
  if (x < 2.0f)
    return ((-b - 6.0f * c) * x3 + (6.0f * b + 30.0f * c) * x2 + (-12.0f * b - 48.0f * c) * x +
            (8.0f * b + 24.0f * c)) /
           6.0f;
  return 0.0f;
}

std::array<float, 9> current_filter_weights(CurrentFilter kind, float sigma, Vec2f jitter) {
  std::array<float, 9> w{};
  if (kind == CurrentFilter::None) {
    w[0] = 1.0f;
    return w;
  }
  for (int k = 0; k < 9; ++k) {
    // Neighbour (dx, dy)'s sample sits at (dx + jitter.x, dy + jitter.y) from our center.
    float sx = float(kNeighborDx[k]) + jitter.x, sy = float(kNeighborDy[k]) + jitter.y;
    float r2 = sx * sx + sy * sy;
    if (kind == CurrentFilter::MitchellNetravali) {
      // Separable, B = C = 1/3 (the pair Mitchell & Netravali recommend): negative lobes
      // between 1 and 2 pixels, so the filtered color is sharper than the Gaussians'.
      w[size_t(k)] = mitchell_netravali(sx, 1.0f / 3.0f, 1.0f / 3.0f) *
                     mitchell_netravali(sy, 1.0f / 3.0f, 1.0f / 3.0f);
      continue;
    }
    w[size_t(k)] = kind == CurrentFilter::Gaussian ? std::exp(-r2 / (2.0f * sigma * sigma))
                                                   // UE4/HDRP: Gaussian fit of a 3.3-wide
                                                   // Blackman-Harris window.
                                                   : std::exp(-2.29f * r2);
  }
  return w;
}

namespace {

// Slab clip of the segment history -> target against an AABB (the UE4 clip, in double):
// the degenerate-hull fallback, which keeps the "move along the segment" meaning.
Vec3d clip_segment_to_aabb(Vec3d lo, Vec3d hi, Vec3d target, Vec3d history) {
  double t = 0.0;
  for (int a = 0; a < 3; ++a) {
    double o = history[a], r = target[a] - o;
    if (o >= lo[a] && o <= hi[a]) continue;  // inside this slab: no constraint from it
    if (std::abs(r) < 1e-30) return target;  // cannot reach the slab along the segment
    double bound = o < lo[a] ? lo[a] : hi[a];
    t = std::max(t, (bound - o) / r);
  }
  t = std::clamp(t, 0.0, 1.0);
  return history + (target - history) * t;
}

}  // namespace

// Convex-hull clip (seed 000 Fig.8(b): the polygon around the neighbourhood colors is the
// tightest volume; seed 003 Fig.14). The hull of <= 9 points is the intersection of the
// half-spaces of every supporting triangle plane: plane (i, j, k) is a hull face plane iff
// all points lie on one side of it. Along the segment h + t (c - h) with c inside, a face
// n.x <= e that h violates is satisfied from t_f = (n.h - e) / (n.h - n.c) on; the entry
// point is t = max_f t_f. O(n^4) = 756 dot products for 9 points — a reference option.
Vec3f clip_to_convex_hull(const Vec3f* points, int n, Vec3f target_f, Vec3f history_f) {
  Vec3d p[9];
  n = std::min(n, 9);
  Vec3d lo(1e300), hi(-1e300);
  for (int i = 0; i < n; ++i) {
    p[i] = to_double(points[i]);
    lo = vmin(lo, p[i]);
    hi = vmax(hi, p[i]);
  }
  const Vec3d h = to_double(history_f), c = to_double(target_f);
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  if (!(extent > 0.0)) return to_float(clip_segment_to_aabb(lo, hi, c, h));  // one point
  // Distances below tol count as "on the plane" (float inputs carry ~1e-7 relative error).
  const double tol = 1e-6 * extent;
  bool solid = false;  // found a face with points strictly behind it: the hull has volume
  double t = 0.0;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      for (int k = j + 1; k < n; ++k) {
        Vec3d nrm = cross(p[j] - p[i], p[k] - p[i]);
        double len = length(nrm);
        if (!(len > 1e-12 * extent * extent)) continue;  // collinear / repeated points
        nrm = nrm / len;
        double e = dot(nrm, p[i]);
        bool pos = false, neg = false;
        for (int m = 0; m < n; ++m) {
          double s = dot(nrm, p[m]) - e;
          pos |= s > tol;
          neg |= s < -tol;
        }
        if (pos == neg) continue;  // points on both sides (not a face), or all coplanar
        solid = true;
        if (pos) {  // orient outward: every point satisfies n.x <= e
          nrm = -nrm;
          e = -e;
        }
        double sh = dot(nrm, h) - e;
        if (sh <= 0.0) continue;  // history inside this half-space
        double sc = dot(nrm, c) - e;
        double t_face = sh - sc > 0.0 ? sh / (sh - sc) : 1.0;
        t = std::max(t, t_face);
      }
  if (!solid) return to_float(clip_segment_to_aabb(lo, hi, c, h));
  if (t <= 0.0) return history_f;  // inside the hull: identity
  t = std::min(t, 1.0);
  return to_float(h + (c - h) * t);
}

}  // namespace afterimage::taa
