// Building blocks of taa/taa_kernels.h against hand-computed values (seed 000 / 003
// formulas). Most checks run at full SIMD width and at 1 lane. The lane colors are tested in
// core_lanes_test.cpp, the history gathers in reproject_test.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "lane_test_util.h"
#include "taa/taa_kernels.h"

using namespace afterimage;
using namespace afterimage::taa;
using namespace afterimage::test;

namespace {

// Per-lane colors from a vector of Vec3f (size = lanes).
template <class D>
Color3<D> load3(D d, const std::vector<Vec3f>& v) {
  const size_t n = hn::Lanes(d);
  std::vector<float> a(n), b(n), e(n);
  for (size_t i = 0; i < n; ++i) {
    a[i] = v[i].x;
    b[i] = v[i].y;
    e[i] = v[i].z;
  }
  return {hn::LoadU(d, a.data()), hn::LoadU(d, b.data()), hn::LoadU(d, e.data())};
}

Vec3f random_color(std::mt19937& rng, float lo, float hi) {
  std::uniform_real_distribution<float> u(lo, hi);
  return {u(rng), u(rng), u(rng)};
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Boxes
// ---------------------------------------------------------------------------------------

TEST(TaaKernels, VarianceBoxOfIdenticalSamplesIsThePoint) {
  for (Vec3f c : {Vec3f{0.3f, 0.7f, 0.1f}, Vec3f{1234.5f, 0.001f, 77.7f}}) {
    Color3<FullTag> s[9];
    for (auto& x : s) x = set3(kFull, c);
    for (float gamma : {1.0f, 2.5f}) {
      Aabb<FullTag> b = variance_box_of(kFull, s, 9, gamma);
      for (Vec3f v : lanes_of(kFull, b.lo)) EXPECT_EQ(v, c);
      for (Vec3f v : lanes_of(kFull, b.hi)) EXPECT_EQ(v, c);
    }
  }
}

TEST(TaaKernels, VarianceBoxIsMeanPlusMinusGammaSigma) {
  // Two samples 0 and 2 per channel: mu = 1, sigma = 1 (population).
  Color3<OneTag> s[2] = {set3(kOne, {0, 10, 5}), set3(kOne, {2, 14, 5})};
  Aabb<OneTag> b = variance_box_of(kOne, s, 2, 1.5f);
  expect_near3(lane0(kOne, b.lo), {1 - 1.5f, 12 - 3.0f, 5}, 1e-5f);
  expect_near3(lane0(kOne, b.hi), {1 + 1.5f, 12 + 3.0f, 5}, 1e-5f);
  // The seed's one-pass form from the moment sums agrees on well-conditioned data.
  std::mt19937 rng(8);
  Color3<FullTag> r[9];
  Color3<FullTag> m1 = splat(kFull, 0, 0, 0), m2 = m1;
  for (auto& x : r) {
    x = set3(kFull, random_color(rng, 0, 2));
    m1 = add(m1, x);
    m2 = {hn::MulAdd(x.c0, x.c0, m2.c0), hn::MulAdd(x.c1, x.c1, m2.c1),
          hn::MulAdd(x.c2, x.c2, m2.c2)};
  }
  Aabb<FullTag> two = variance_box_of(kFull, r, 9, 1.0f);
  Aabb<FullTag> one = variance_box(kFull, m1, m2, 1.0f / 9.0f, 1.0f);
  expect_near3(lane0(kFull, two.lo), lane0(kFull, one.lo), 1e-5f);
  expect_near3(lane0(kFull, two.hi), lane0(kFull, one.hi), 1e-5f);
}

TEST(TaaKernels, MinMaxRoundedAndIntersectedBoxes) {
  Color3<OneTag> s[9];
  for (int i = 0; i < 9; ++i) s[i] = set3(kOne, {float(i), -float(i), 1.0f});
  Aabb<OneTag> cross = minmax_box(s, 5), box = minmax_box(s, 9);
  expect_near3(lane0(kOne, cross.lo), {0, -4, 1}, 0);
  expect_near3(lane0(kOne, box.hi), {8, 0, 1}, 0);
  Aabb<OneTag> r = average_boxes(kOne, cross, box);  // INSIDE rounded box
  expect_near3(lane0(kOne, r.hi), {6, 0, 1}, 0);
  expect_near3(lane0(kOne, r.lo), {0, -6, 1}, 0);
  Aabb<OneTag> a{set3(kOne, {0, 0, 0}), set3(kOne, {2, 2, 2})};
  Aabb<OneTag> c{set3(kOne, {1, -1, 0.5f}), set3(kOne, {3, 1, 1.5f})};
  Aabb<OneTag> in = intersect_boxes(a, c);
  expect_near3(lane0(kOne, in.lo), {1, 0, 0.5f}, 0);
  expect_near3(lane0(kOne, in.hi), {2, 1, 1.5f}, 0);
}

// ---------------------------------------------------------------------------------------
// Rectification
// ---------------------------------------------------------------------------------------

namespace {
// Distance of p outside box (0 inside) and whether p is on the surface.
float outside_distance(Vec3f p, Vec3f lo, Vec3f hi) {
  float d = 0;
  for (int a = 0; a < 3; ++a) d = std::max({d, lo[a] - p[a], p[a] - hi[a]});
  return d;
}
float surface_distance(Vec3f p, Vec3f lo, Vec3f hi) {
  float m = 1e30f;
  for (int a = 0; a < 3; ++a) m = std::min({m, std::abs(p[a] - lo[a]), std::abs(p[a] - hi[a])});
  return m;
}
// |cross(b - a, c - a)| / |b - a|: distance of c from the line through a, b.
float line_distance(Vec3f a, Vec3f b, Vec3f c) {
  Vec3f u = b - a;
  return length(cross(u, c - a)) / std::max(length(u), 1e-20f);
}
}  // namespace

TEST(TaaKernels, ClampIsPerChannel) {
  Aabb<OneTag> b{set3(kOne, {0, 0, 0}), set3(kOne, {1, 1, 1})};
  expect_near3(lane0(kOne, clamp_to_aabb(b, set3(kOne, {2, -1, 0.5f}))), {1, 0, 0.5f}, 0);
}

TEST(TaaKernels, ClipAabbHandValues) {
  // Playdead clip toward the center: (3, .5, .5) vs unit cube -> (1, .5, .5).
  Aabb<OneTag> b{set3(kOne, {0, 0, 0}), set3(kOne, {1, 1, 1})};
  expect_near3(lane0(kOne, clip_aabb(kOne, b, set3(kOne, {3, 0.5f, 0.5f}))), {1, 0.5f, 0.5f},
               1e-6f);
  // (2, 2, .5): center (.5,.5,.5), v = (1.5, 1.5, 0), max |v/e| = 3 -> (1, 1, .5).
  expect_near3(lane0(kOne, clip_aabb(kOne, b, set3(kOne, {2, 2, 0.5f}))), {1, 1, 0.5f}, 1e-6f);
  // Inside: unchanged (bit exact).
  EXPECT_EQ(lane0(kOne, clip_aabb(kOne, b, set3(kOne, {0.2f, 0.9f, 0.4f}))),
            (Vec3f{0.2f, 0.9f, 0.4f}));
}

TEST(TaaKernels, ClipToFilteredHandValues) {
  // UE4 clip: from h = (3, .5, .5) toward f = (.5, .5, .5): enters at x = 1.
  Aabb<OneTag> b{set3(kOne, {0, 0, 0}), set3(kOne, {1, 1, 1})};
  expect_near3(lane0(kOne, clip_to_filtered(kOne, b, set3(kOne, {0.5f, 0.5f, 0.5f}),
                                            set3(kOne, {3, 0.5f, 0.5f}))),
               {1, 0.5f, 0.5f}, 1e-6f);
  // h = (2, 2, 0), f = (0, 1, 0): the x slab is entered at t = .5, the y slab at t = 1, so
  // the ray enters the box at t = 1: the target itself (on the surface).
  expect_near3(lane0(kOne, clip_to_filtered(kOne, b, set3(kOne, {0, 1, 0}), set3(kOne, {2, 2, 0}))),
               {0, 1, 0}, 1e-6f);
  // h = (2, 1.5, .5), f = (0, .5, .5): x enters t = .5 (y = 1), y enters t = .5 -> (1, 1, .5).
  expect_near3(lane0(kOne, clip_to_filtered(kOne, b, set3(kOne, {0, 0.5f, 0.5f}),
                                            set3(kOne, {2, 1.5f, 0.5f}))),
               {1, 1, 0.5f}, 1e-6f);
  EXPECT_EQ(lane0(kOne, clip_to_filtered(kOne, b, set3(kOne, {0.5f, 0.5f, 0.5f}),
                                         set3(kOne, {0.1f, 0.2f, 0.3f}))),
            (Vec3f{0.1f, 0.2f, 0.3f}));
}

// A point outside the box lands on the box surface, on the line to the target.
TEST(TaaKernels, ClipsLandOnSurfaceAlongTheLine) {
  std::mt19937 rng(7);
  const size_t n = hn::Lanes(kFull);
  for (int it = 0; it < 100; ++it) {
    std::vector<Vec3f> lo(n), hi(n), f(n), h(n);
    for (size_t l = 0; l < n; ++l) {
      lo[l] = random_color(rng, -1, 1);
      hi[l] = lo[l] + random_color(rng, 0.1f, 3);
      Vec3f t = random_color(rng, 0.05f, 0.95f);
      f[l] = lo[l] + (hi[l] - lo[l]) * t;
      do h[l] = random_color(rng, -6, 6);
      while (outside_distance(h[l], lo[l], hi[l]) < 0.05f);
    }
    Aabb<FullTag> b{load3(kFull, lo), load3(kFull, hi)};
    auto rc = lanes_of(kFull, clip_aabb(kFull, b, load3(kFull, h)));
    auto rf = lanes_of(kFull, clip_to_filtered(kFull, b, load3(kFull, f), load3(kFull, h)));
    for (size_t l = 0; l < n; ++l) {
      Vec3f c = (lo[l] + hi[l]) * 0.5f;
      EXPECT_LT(outside_distance(rc[l], lo[l], hi[l]), 1e-5f);
      EXPECT_LT(surface_distance(rc[l], lo[l], hi[l]), 1e-5f);
      EXPECT_LT(line_distance(h[l], c, rc[l]), 1e-4f);
      EXPECT_LT(outside_distance(rf[l], lo[l], hi[l]), 1e-5f);
      EXPECT_LT(surface_distance(rf[l], lo[l], hi[l]), 1e-5f);
      EXPECT_LT(line_distance(h[l], f[l], rf[l]), 1e-4f);
      // Between history and target.
      EXPECT_LE(dot(rf[l] - h[l], f[l] - h[l]), dot(f[l] - h[l], f[l] - h[l]) + 1e-4f);
      EXPECT_GE(dot(rf[l] - h[l], f[l] - h[l]), -1e-4f);
    }
  }
}

// ---------------------------------------------------------------------------------------
// Convex hull
// ---------------------------------------------------------------------------------------

namespace {
struct Plane {
  Vec3d n;
  double e;  // n.x <= e inside
};
// Independent brute force: planes of all triangles with every point on one side.
std::vector<Plane> hull_planes(const std::vector<Vec3f>& pts) {
  std::vector<Plane> r;
  const int n = int(pts.size());
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      for (int k = j + 1; k < n; ++k) {
        Vec3d a = to_double(pts[i]), b = to_double(pts[j]), c = to_double(pts[k]);
        Vec3d nn = cross(b - a, c - a);
        if (length(nn) < 1e-9) continue;
        nn = normalize(nn);
        double e = dot(nn, a), mx = -1e30, mn = 1e30;
        for (const auto& p : pts) {
          double s = dot(nn, to_double(p)) - e;
          mx = std::max(mx, s);
          mn = std::min(mn, s);
        }
        if (mx <= 1e-6)
          r.push_back({nn, e});
        else if (mn >= -1e-6)
          r.push_back({-nn, -e});
      }
  return r;
}
double max_violation(const std::vector<Plane>& planes, Vec3f p) {
  double m = -1e30;
  for (const auto& pl : planes) m = std::max(m, dot(pl.n, to_double(p)) - pl.e);
  return m;
}
}  // namespace

TEST(TaaKernels, ConvexHullOfCubeHandValues) {
  std::vector<Vec3f> pts;
  for (int i = 0; i < 8; ++i) pts.push_back({float(i & 1), float((i >> 1) & 1), float(i >> 2)});
  pts.push_back({0.5f, 0.5f, 0.5f});
  const Vec3f c{0.5f, 0.5f, 0.5f};
  expect_near3(clip_to_convex_hull(pts.data(), 9, c, {3, 0.5f, 0.5f}), {1, 0.5f, 0.5f}, 1e-6f);
  expect_near3(clip_to_convex_hull(pts.data(), 9, c, {2, 2, 0.5f}), {1, 1, 0.5f}, 1e-6f);
  // Inside: identity, bit exact.
  EXPECT_EQ(clip_to_convex_hull(pts.data(), 9, c, {0.1f, 0.9f, 0.3f}), (Vec3f{0.1f, 0.9f, 0.3f}));
}

TEST(TaaKernels, ConvexHullOfTetrahedronCutsTheCorner) {
  // Tetrahedron (0,0,0), (1,0,0), (0,1,0), (0,0,1): the face x + y + z = 1. From (1,1,1)
  // toward (.1,.1,.1): 3 - 2.7 t = 1 -> t = 2/2.7, point (x = 1 - .9 t) each.
  std::vector<Vec3f> pts = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  Vec3f r = clip_to_convex_hull(pts.data(), 4, {0.1f, 0.1f, 0.1f}, {1, 1, 1});
  float t = 2.0f / 2.7f, v = 1.0f - 0.9f * t;
  expect_near3(r, {v, v, v}, 1e-6f);
  // The AABB clip would have kept (1,1,1) (it is a corner of the box): the hull is tighter.
  EXPECT_NEAR(r.x + r.y + r.z, 1.0f, 1e-6f);
}

TEST(TaaKernels, ConvexHullRandomPointsLandOnAFace) {
  std::mt19937 rng(11);
  for (int it = 0; it < 300; ++it) {
    const int n = 4 + it % 6;  // 4..9 points
    std::vector<Vec3f> pts(static_cast<size_t>(n));
    for (auto& p : pts) p = random_color(rng, 0, 2);
    Vec3f target{0, 0, 0};
    for (auto& p : pts) target = target + p * (1.0f / float(n));  // centroid: inside
    const auto planes = hull_planes(pts);
    ASSERT_FALSE(planes.empty());
    Vec3f h = random_color(rng, -3, 5);
    Vec3f r = clip_to_convex_hull(pts.data(), n, target, h);
    const double viol_h = max_violation(planes, h);
    if (viol_h <= 0) {
      EXPECT_EQ(r, h);  // inside: identity
    } else {
      // On the hull boundary: no plane violated, at least one (nearly) tight.
      EXPECT_NEAR(max_violation(planes, r), 0.0, 1e-5) << "iteration " << it;
      EXPECT_LT(line_distance(h, target, r), 1e-4f);
      // Hull within AABB: the hull clip goes at least as far toward the target.
      Vec3f lo = pts[0], hi = pts[0];
      for (auto& p : pts) {
        lo = vmin(lo, p);
        hi = vmax(hi, p);
      }
      EXPECT_LT(outside_distance(r, lo, hi), 1e-5f);
    }
  }
}

TEST(TaaKernels, ConvexHullDegenerateFallsBackToAabb) {
  // Identical points: everything clips to the point (target is that point).
  std::vector<Vec3f> same(9, Vec3f{0.4f, 0.5f, 0.6f});
  expect_near3(clip_to_convex_hull(same.data(), 9, {0.4f, 0.5f, 0.6f}, {3, -1, 2}),
               {0.4f, 0.5f, 0.6f}, 1e-6f);
  // Coplanar (z = 0.25) square: AABB clip toward the target.
  std::vector<Vec3f> flat = {
      {0, 0, 0.25f}, {1, 0, 0.25f}, {0, 1, 0.25f}, {1, 1, 0.25f}, {0.5f, 0.5f, 0.25f}};
  Vec3f r = clip_to_convex_hull(flat.data(), 5, {0.5f, 0.5f, 0.25f}, {3, 0.5f, 0.25f});
  expect_near3(r, {1, 0.5f, 0.25f}, 1e-6f);
  r = clip_to_convex_hull(flat.data(), 5, {0.5f, 0.5f, 0.25f}, {0.5f, 0.5f, 2.25f});
  expect_near3(r, {0.5f, 0.5f, 0.25f}, 1e-6f);
  // Collinear points.
  std::vector<Vec3f> line = {{0, 0, 0}, {1, 1, 1}, {0.5f, 0.5f, 0.5f}};
  r = clip_to_convex_hull(line.data(), 3, {0.5f, 0.5f, 0.5f}, {2, 0.5f, 0.5f});
  expect_near3(r, {1, 0.5f, 0.5f}, 1e-6f);
  for (float v : {r.x, r.y, r.z}) EXPECT_TRUE(std::isfinite(v));
}

TEST(TaaKernels, ConvexHullLaneWrapperMatchesScalar) {
  std::mt19937 rng(3);
  const size_t n = hn::Lanes(kFull);
  std::vector<std::vector<Vec3f>> pts(9, std::vector<Vec3f>(n));
  std::vector<Vec3f> tgt(n), h(n);
  for (size_t l = 0; l < n; ++l) {
    Vec3f c{0, 0, 0};
    for (int i = 0; i < 9; ++i) {
      pts[size_t(i)][l] = random_color(rng, 0, 1);
      c = c + pts[size_t(i)][l] * (1.0f / 9);
    }
    tgt[l] = c;
    h[l] = random_color(rng, -1, 2);
  }
  Color3<FullTag> pv[9];
  for (int i = 0; i < 9; ++i) pv[i] = load3(kFull, pts[size_t(i)]);
  auto r = lanes_of(kFull, clip_to_convex_hull(kFull, pv, 9, load3(kFull, tgt), load3(kFull, h)));
  for (size_t l = 0; l < n; ++l) {
    Vec3f p[9];
    for (int i = 0; i < 9; ++i) p[i] = pts[size_t(i)][l];
    EXPECT_EQ(r[l], clip_to_convex_hull(p, 9, tgt[l], h[l]));
  }
}

// ---------------------------------------------------------------------------------------
// Dilation
// ---------------------------------------------------------------------------------------

TEST(TaaKernels, DilateVelocityPicksClosestOrLargest) {
  // Order: center, left, right, up, down, up-left, up-right, down-left, down-right.
  const float depth[9] = {10, 10, 5, 10, 10, 2, 10, 10, 10};
  const float mxv[9] = {0, 0, 20, 0, 0, -3, 0, 0, 7};
  const float myv[9] = {0, 0, 1, 0, 0, -4, 0, 0, 7};
  V<OneTag> dep[9], mx[9], my[9];
  for (int i = 0; i < 9; ++i) {
    dep[i] = hn::Set(kOne, depth[i]);
    mx[i] = hn::Set(kOne, mxv[i]);
    my[i] = hn::Set(kOne, myv[i]);
  }
  auto none = dilate_velocity(kOne, VelocityDilation::None, dep, mx, my);
  EXPECT_EQ(hn::GetLane(none.mx), 0.0f);
  // Cross: the right neighbour (depth 5) is closest -> (20, 1), seed 002's example.
  auto cross = dilate_velocity(kOne, VelocityDilation::ClosestDepthCross5, dep, mx, my);
  EXPECT_EQ(hn::GetLane(cross.mx), 20.0f);
  EXPECT_EQ(hn::GetLane(cross.my), 1.0f);
  EXPECT_EQ(hn::GetLane(cross.depth), 5.0f);
  EXPECT_EQ(hn::GetLane(cross.choice), 2.0f);
  // Box: the up-left corner (depth 2) wins.
  auto box = dilate_velocity(kOne, VelocityDilation::ClosestDepthBox9, dep, mx, my);
  EXPECT_EQ(hn::GetLane(box.mx), -3.0f);
  EXPECT_EQ(hn::GetLane(box.depth), 2.0f);
  // Largest |v|: (20, 1) has 401 > 98.
  auto big = dilate_velocity(kOne, VelocityDilation::LargestMotion, dep, mx, my);
  EXPECT_EQ(hn::GetLane(big.mx), 20.0f);
  // Ties keep the center.
  V<OneTag> flat[9];
  for (auto& v : flat) v = hn::Set(kOne, 3.0f);
  auto tie = dilate_velocity(kOne, VelocityDilation::ClosestDepthBox9, flat, mx, my);
  EXPECT_EQ(hn::GetLane(tie.choice), 0.0f);
}

// ---------------------------------------------------------------------------------------
// Blending and alpha
// ---------------------------------------------------------------------------------------

TEST(TaaKernels, BlendExponentialIsEq2) {
  auto r =
      blend_exponential(kOne, set3(kOne, {1, 2, 3}), set3(kOne, {3, 2, 1}), hn::Set(kOne, 0.25f));
  expect_near3(lane0(kOne, r), {0.25f * 1 + 0.75f * 3, 2, 0.25f * 3 + 0.75f * 1}, 1e-6f);
}

TEST(TaaKernels, BlendLumaWeightedHandValue) {
  // L(3,3,3) = 3 -> w = 1/4; L(1,1,1) = 1 -> w = 1/2; alpha = .5:
  // (.5*.25*3 + .5*.5*1) / (.5*.25 + .5*.5) = .625 / .375.
  auto r =
      blend_luma_weighted(kOne, set3(kOne, {3, 3, 3}), set3(kOne, {1, 1, 1}), hn::Set(kOne, 0.5f));
  expect_near3(lane0(kOne, r), Vec3f(0.625f / 0.375f), 1e-5f);
  EXPECT_NEAR(lane0(kOne, karis_weight(kOne, hn::Set(kOne, 3.0f))), 0.25f, 1e-7f);
}

TEST(TaaKernels, AlphaRulesHandValues) {
  auto g = [](V<OneTag> v) { return hn::GetLane(v); };
  auto S = [](float v) { return hn::Set(kOne, v); };
  // Sample count: max(alpha_min, 1/N).
  EXPECT_FLOAT_EQ(g(alpha_from_sample_count(kOne, S(4), S(0.1f))), 0.25f);
  EXPECT_FLOAT_EQ(g(alpha_from_sample_count(kOne, S(20), S(0.1f))), 0.1f);
  EXPECT_FLOAT_EQ(g(alpha_from_sample_count(kOne, S(1), S(0.1f))), 1.0f);
  // Velocity: 0.04 -> 0.2 at 40 px; 20 px -> halfway 0.12.
  EXPECT_NEAR(g(alpha_from_velocity(kOne, S(0.04f), S(12), S(16), 0.2f, 40.0f)), 0.12f, 1e-6f);
  EXPECT_NEAR(g(alpha_from_velocity(kOne, S(0.04f), S(400), S(0), 0.2f, 40.0f)), 0.2f, 1e-6f);
  // INSIDE: equal luma -> feedback max 0.97 -> alpha 0.03; Lc = 1, Lh = .5: diff .5,
  // weight .5, feedback .88 + .25 * .09 = .9025.
  EXPECT_NEAR(g(alpha_from_luma_difference(kOne, S(1), S(1), 0.88f, 0.97f)), 0.03f, 1e-6f);
  EXPECT_NEAR(g(alpha_from_luma_difference(kOne, S(1), S(0.5f), 0.88f, 0.97f)), 0.0975f, 1e-6f);
  // Depth: near keeps alpha, 4x the distance -> halfway to the far alpha, sky keeps alpha.
  EXPECT_NEAR(g(alpha_from_depth(kOne, S(0.1f), S(5), 0.02f, 10.0f, 1e10f)), 0.1f, 1e-7f);
  EXPECT_NEAR(g(alpha_from_depth(kOne, S(0.1f), S(40), 0.02f, 10.0f, 1e10f)), 0.06f, 1e-6f);
  EXPECT_NEAR(g(alpha_from_depth(kOne, S(0.1f), S(1e10f), 0.02f, 10.0f, 1e10f)), 0.1f, 1e-7f);
  // Karis: on the surface -> alpha * scale; at the center -> alpha.
  EXPECT_NEAR(g(alpha_from_clamp_distance(kOne, S(0.1f), S(1), S(1), S(3), 0.5f)), 0.05f, 1e-7f);
  EXPECT_NEAR(g(alpha_from_clamp_distance(kOne, S(0.1f), S(2), S(1), S(3), 0.5f)), 0.1f, 1e-7f);
  EXPECT_NEAR(g(alpha_from_clamp_distance(kOne, S(0.1f), S(1.5f), S(1), S(3), 0.5f)), 0.075f,
              1e-7f);
}

TEST(TaaKernels, CurrentFilterWeightsUseJitteredDistance) {
  auto none = current_filter_weights(CurrentFilter::None, 0.5f, {0.3f, 0.1f});
  EXPECT_EQ(none[0], 1.0f);
  for (int i = 1; i < 9; ++i) EXPECT_EQ(none[size_t(i)], 0.0f);
  auto g = current_filter_weights(CurrentFilter::Gaussian, 1.0f, {0.0f, 0.0f});
  EXPECT_NEAR(g[0], 1.0f, 1e-7f);
  EXPECT_NEAR(g[1], std::exp(-0.5f), 1e-7f);
  EXPECT_NEAR(g[5], std::exp(-1.0f), 1e-7f);
  // Jitter (+.5, 0): left neighbour's sample is at (-.5, 0), right's at (1.5, 0).
  auto j = current_filter_weights(CurrentFilter::Gaussian, 1.0f, {0.5f, 0.0f});
  EXPECT_NEAR(j[0], std::exp(-0.125f), 1e-7f);
  EXPECT_NEAR(j[1], std::exp(-0.125f), 1e-7f);
  EXPECT_NEAR(j[2], std::exp(-1.125f), 1e-7f);
  EXPECT_NEAR(j[3], std::exp(-0.625f), 1e-7f);  // up: (.5, -1)
  auto bh = current_filter_weights(CurrentFilter::BlackmanHarris, 1.0f, {0.0f, 0.0f});
  EXPECT_NEAR(bh[1], std::exp(-2.29f), 1e-7f);
}

// Mitchell & Netravali's cubic family: Catmull-Rom (B = 0, C = 1/2) interpolates (1 at 0, 0 at
// the other integers, 0.5625 at 1/2); B = C = 1/3 has k(0) = (6 - 2B) / 6 = 8/9 and k(1) = B / 6
// = 1/18; every member with B + 2C = 1 sums to 1 over integer shifts (partition of unity), and
// the 1/3 pair is negative between 1 and 2. The 3x3 weights are the separable product.
TEST(TaaKernels, MitchellNetravaliHandValues) {
  EXPECT_FLOAT_EQ(mitchell_netravali(0.0f, 0.0f, 0.5f), 1.0f);
  EXPECT_NEAR(mitchell_netravali(1.0f, 0.0f, 0.5f), 0.0f, 1e-7f);
  EXPECT_FLOAT_EQ(mitchell_netravali(0.5f, 0.0f, 0.5f), 0.5625f);
  const float b = 1.0f / 3.0f;
  EXPECT_NEAR(mitchell_netravali(0.0f, b, b), 8.0f / 9.0f, 1e-6f);
  EXPECT_NEAR(mitchell_netravali(-1.0f, b, b), 1.0f / 18.0f, 1e-6f);
  EXPECT_LT(mitchell_netravali(1.5f, b, b), 0.0f);
  EXPECT_EQ(mitchell_netravali(2.0f, b, b), 0.0f);
  for (float f : {0.0f, 0.25f, 0.7f}) {
    float sum = 0.0f;
    for (int i = -2; i <= 2; ++i) sum += mitchell_netravali(f + float(i), b, b);
    EXPECT_NEAR(sum, 1.0f, 1e-6f) << f;
  }
  auto w = current_filter_weights(CurrentFilter::MitchellNetravali, 1.0f, {0.5f, 0.0f});
  // Left neighbour's sample at (-0.5, 0), right's at (1.5, 0): negative lobe.
  EXPECT_NEAR(w[1], mitchell_netravali(-0.5f, b, b) * mitchell_netravali(0.0f, b, b), 1e-7f);
  EXPECT_LT(w[2], 0.0f);
  // A bright sample alone in the negative lobe would pull the filtered color below zero: it is
  // clamped at 0 (non-negative color never leaves the filter).
  Color3<FullTag> nb[9];
  for (auto& c : nb) c = set3(kFull, {0.0f, 0.0f, 0.0f});
  nb[2] = set3(kFull, {1000.0f, 1000.0f, 1000.0f});
  const Vec3f f = lane0(kFull, filter_current_color(kFull, nb, w, false));
  EXPECT_EQ(f, (Vec3f{0.0f, 0.0f, 0.0f}));
  // ... while a bright center keeps its weighted mean.
  nb[2] = set3(kFull, {0.0f, 0.0f, 0.0f});
  nb[0] = set3(kFull, {1.0f, 2.0f, 3.0f});
  float wsum = 0.0f;
  for (float x : w) wsum += x;
  expect_near3(lane0(kFull, filter_current_color(kFull, nb, w, false)),
               {w[0] / wsum, 2 * w[0] / wsum, 3 * w[0] / wsum}, 1e-5f);
}

TEST(TaaKernels, HistoryFilterFollowsSamplerAndStaticMode) {
  using reproject::HistoryFilter;
  EXPECT_EQ(history_filter(HistorySampler::CatmullRom9, true), HistoryFilter::Point);
  EXPECT_EQ(history_filter(HistorySampler::Bilinear, false), HistoryFilter::Bilinear);
  EXPECT_EQ(history_filter(HistorySampler::CatmullRom5, false), HistoryFilter::CatmullRom5);
  EXPECT_EQ(history_filter(HistorySampler::CatmullRom9, false), HistoryFilter::CatmullRom9);
  EXPECT_EQ(history_filter(HistorySampler::Bicubic16, false), HistoryFilter::CatmullRom16);
}

// ---------------------------------------------------------------------------------------
// Division-free blocks (9cd7e5f, fb2ca45; docs/perf/profile-taa-resolve.md): clip_to_filtered,
// temporal_whiteness and history_confidence skip their divisions in blocks where every lane
// gives a known result. Lane 0 below never does, so the full-width call divides in every lane,
// while each lane evaluated alone (1 lane) takes the shortcut where it may: the bits must agree.
// ---------------------------------------------------------------------------------------

namespace {

bool same_bits(float a, float b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

template <class D>
V<D> load_lanes(D d, const std::vector<float>& v) {
  return hn::LoadU(d, v.data());
}

// Per-lane moments (only the fields the confidence reads vary; the others are fixed).
struct MomentsLane {
  float mean, var, var_spatial, var_mean, recent_motion, drift;
};
template <class D>
LumaMoments<D> moments_of(D d, const std::vector<MomentsLane>& m) {
  auto field = [&](float MomentsLane::*f) {
    std::vector<float> v(hn::Lanes(d));
    for (size_t i = 0; i < v.size(); ++i) v[i] = m[i].*f;
    return hn::LoadU(d, v.data());
  };
  return {field(&MomentsLane::mean),     field(&MomentsLane::var),
          field(&MomentsLane::mean),     field(&MomentsLane::var_spatial),
          field(&MomentsLane::var_mean), field(&MomentsLane::recent_motion),
          field(&MomentsLane::drift)};
}

}  // namespace

TEST(TaaKernels, ClipToFilteredInsideBlocksMatchTheSlabTest) {
  const size_t n = hn::Lanes(kFull);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<Vec3f> lo(n), hi(n), f(n), h(n);
    for (size_t i = 0; i < n; ++i) {
      lo[i] = {-1.0f, -0.5f, -2.0f};
      hi[i] = {1.0f, 0.5f, 2.0f};
      f[i] = {u(rng), 0.5f * u(rng), 2.0f * u(rng)};
      // Strictly inside (a signed zero now and then: history + 0 * dir must keep its bits).
      h[i] = {0.99f * u(rng), trial % 3 == 0 ? -0.0f : 0.49f * u(rng), 1.99f * u(rng)};
    }
    h[0] = {1.5f, 0.0f, 0.0f};  // outside: the full-width call runs the slab test
    const Aabb<FullTag> b{load3(kFull, lo), load3(kFull, hi)};
    const auto full = lanes_of(kFull, clip_to_filtered(kFull, b, load3(kFull, f), load3(kFull, h)));
    for (size_t i = 0; i < n; ++i) {
      const Aabb<OneTag> b1{set3(kOne, lo[i]), set3(kOne, hi[i])};
      const Vec3f one = lane0(kOne, clip_to_filtered(kOne, b1, set3(kOne, f[i]), set3(kOne, h[i])));
      EXPECT_TRUE(same_bits(one.x, full[i].x) && same_bits(one.y, full[i].y) &&
                  same_bits(one.z, full[i].z))
          << "trial " << trial << " lane " << i;
    }
  }
}

TEST(TaaKernels, SaturatedWhitenessMatchesTheDivision) {
  const size_t n = hn::Lanes(kFull);
  // var / var_mean: flat (both 0: ratio 1), white (1), anti-correlated (2), coherent (0.1, 0),
  // huge and tiny values; lane 0 in between (0.7: not saturated).
  const float var[] = {0.7f, 0.0f, 1.0f, 2.0f, 0.1f, 0.0f, 1e30f, 1e-30f, 3e38f, 0.9f, 0.5f};
  const float var_mean[] = {1.0f, 0.0f, 1.0f, 1.0f, 1.0f, 5.0f, 1e30f, 0.0f, 3e38f, 1.0f, 1.0f};
  const size_t kinds = sizeof var / sizeof var[0];
  std::vector<MomentsLane> m(n);
  for (size_t i = 0; i < n; ++i)
    m[i] = {0.5f, var[i % kinds], 0.0f, var_mean[i % kinds], 0.0f, 0.0f};
  const auto full =
      lanes(kFull, temporal_whiteness(kFull, moments_of(kFull, m), 0.5f, 0.9f, 1e-3f));
  EXPECT_GT(full[0], 0.0f);
  EXPECT_LT(full[0], 1.0f);
  for (size_t i = 0; i < n; ++i) {
    const float one =
        lane0(kOne, temporal_whiteness(kOne, moments_of(kOne, {m[i]}), 0.5f, 0.9f, 1e-3f));
    EXPECT_TRUE(same_bits(one, full[i])) << "lane " << i << ": " << one << " vs " << full[i];
  }
}

TEST(TaaKernels, HistoryConfidenceOfFastLanesMatchesTheFullRule) {
  const size_t n = hn::Lanes(kFull);
  TaaSettings s;
  s.confidence = true;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<MomentsLane> m(n);
    std::vector<float> luma(n), sigma(n), speed(n), zmax(n), dsum(n), dspread(n);
    for (size_t i = 0; i < n; ++i) {
      m[i] = {u(rng), 0.01f * u(rng), 0.01f * u(rng), 0.01f * u(rng), u(rng), 0.01f * u(rng)};
      luma[i] = m[i].mean + 0.1f * u(rng);
      sigma[i] = 0.1f * u(rng);
      // At or beyond confidence_motion_px (speed factor +0), or in a remembered motion above it.
      speed[i] = s.confidence_motion_px * (1.0f + u(rng));
      if (i % 3 == 1) {
        speed[i] = 0.0f;
        m[i].recent_motion = 2.0f * s.confidence_motion_px;
      }
      zmax[i] = 10.0f * u(rng);
      dsum[i] = 0.1f * u(rng);
      dspread[i] = u(rng);
    }
    speed[0] = 0.0f;  // at rest: the full-width call computes every factor
    m[0].recent_motion = 0.0f;
    auto eval = [&](auto d, size_t first) {
      auto part = [&](const std::vector<float>& v) {
        return std::vector<float>(v.begin() + first, v.begin() + first + hn::Lanes(d));
      };
      LumaMoments<decltype(d)> mo = moments_of(
          d, std::vector<MomentsLane>(m.begin() + first, m.begin() + first + hn::Lanes(d)));
      const NeighborEvidence<decltype(d)> nb{load_lanes(d, part(zmax)), load_lanes(d, part(dsum)),
                                             load_lanes(d, part(dspread))};
      const auto conf =
          history_confidence(d, load_lanes(d, part(luma)), mo, hn::FirstN(d, hn::Lanes(d)),
                             load_lanes(d, part(sigma)), nb, load_lanes(d, part(speed)), s);
      return std::make_pair(lanes(d, conf), lanes(d, mo.recent_motion));
    };
    const auto full = eval(kFull, 0);
    for (size_t i = 0; i < n; ++i) {
      const auto one = eval(kOne, i);
      EXPECT_TRUE(same_bits(one.first[0], full.first[i])) << "trial " << trial << " lane " << i;
      EXPECT_TRUE(same_bits(one.second[0], full.second[i])) << "trial " << trial << " lane " << i;
    }
  }
}
