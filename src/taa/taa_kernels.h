// Per-pixel building blocks of temporal anti-aliasing, written once as inline functions
// templated on a Highway descriptor `d` (DESIGN.md §6, tev's simdFor habit). Each works on
// hn::Vec lanes like a shader works on one pixel; the resolver runs them full-width and at
// 1 lane for tails and for the reference path (Exec::simd == false).
//
// Naming follows the seeds where they name things (seed 000: Eq.1-5; seed 003: clip_aabb,
// ClipToFiltered, VarianceNeighbourhood, LumaExponentialAccumulation, SampleHistoryBicubic,
// GaussianFilterMiddleColor). A color is three lane vectors (RGB or YCoCg).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/math.h"
#include "core/sampler_simd.h"
#include "core/simd.h"
#include "taa/settings.h"

namespace afterimage::taa {

namespace hn = hwy::HWY_NAMESPACE;

template <class D>
using V = hn::Vec<D>;
template <class D>
using VI = hn::Vec<hn::RebindToSigned<D>>;  // flat pixel indices for gathers

// Enough room to store any vector of floats (AVX-512: 16 lanes).
constexpr size_t kMaxLanes = HWY_MAX_BYTES / sizeof(float);

// Order of the 3x3 neighbourhood everywhere in this module: center, the cross (left, right,
// up, down), then the corners. The first 5 are the cross.
constexpr int kNeighborDx[9] = {0, -1, 1, 0, 0, -1, 1, -1, 1};
constexpr int kNeighborDy[9] = {0, 0, 0, -1, 1, -1, -1, 1, 1};

// ----------------------------------------------------------------------------------------
// Color vectors
// ----------------------------------------------------------------------------------------

template <class D>
struct Color3 {
  V<D> c0, c1, c2;  // R G B, or Y Co Cg
};

template <class D>
HWY_INLINE Color3<D> splat(D d, float a, float b, float c) {
  return {hn::Set(d, a), hn::Set(d, b), hn::Set(d, c)};
}
template <class D>
HWY_INLINE Color3<D> add(const Color3<D>& a, const Color3<D>& b) {
  return {hn::Add(a.c0, b.c0), hn::Add(a.c1, b.c1), hn::Add(a.c2, b.c2)};
}
template <class D>
HWY_INLINE Color3<D> sub(const Color3<D>& a, const Color3<D>& b) {
  return {hn::Sub(a.c0, b.c0), hn::Sub(a.c1, b.c1), hn::Sub(a.c2, b.c2)};
}
template <class D>
HWY_INLINE Color3<D> scale(const Color3<D>& a, V<D> s) {
  return {hn::Mul(a.c0, s), hn::Mul(a.c1, s), hn::Mul(a.c2, s)};
}
// a * s + b
template <class D>
HWY_INLINE Color3<D> mul_add(const Color3<D>& a, V<D> s, const Color3<D>& b) {
  return {hn::MulAdd(a.c0, s, b.c0), hn::MulAdd(a.c1, s, b.c1), hn::MulAdd(a.c2, s, b.c2)};
}
template <class D>
HWY_INLINE Color3<D> cmin(const Color3<D>& a, const Color3<D>& b) {
  return {hn::Min(a.c0, b.c0), hn::Min(a.c1, b.c1), hn::Min(a.c2, b.c2)};
}
template <class D>
HWY_INLINE Color3<D> cmax(const Color3<D>& a, const Color3<D>& b) {
  return {hn::Max(a.c0, b.c0), hn::Max(a.c1, b.c1), hn::Max(a.c2, b.c2)};
}
template <class D, class M>
HWY_INLINE Color3<D> select(M m, const Color3<D>& yes, const Color3<D>& no) {
  return {hn::IfThenElse(m, yes.c0, no.c0), hn::IfThenElse(m, yes.c1, no.c1),
          hn::IfThenElse(m, yes.c2, no.c2)};
}
// Linear interpolation a + t (b - a).
template <class D>
HWY_INLINE V<D> lerp(V<D> a, V<D> b, V<D> t) {
  return hn::MulAdd(hn::Sub(b, a), t, a);
}
template <class D>
HWY_INLINE V<D> saturate(D d, V<D> v) {
  return hn::Min(hn::Max(v, hn::Zero(d)), hn::Set(d, 1.0f));
}
template <class D>
HWY_INLINE auto all_finite(D, const Color3<D>& c) {
  return hn::And(hn::And(hn::IsFinite(c.c0), hn::IsFinite(c.c1)), hn::IsFinite(c.c2));
}

// Rec.709 luminance (DESIGN.md §3).
template <class D>
HWY_INLINE V<D> luminance(D d, const Color3<D>& rgb) {
  return hn::MulAdd(hn::Set(d, 0.2126f), rgb.c0,
                    hn::MulAdd(hn::Set(d, 0.7152f), rgb.c1, hn::Mul(hn::Set(d, 0.0722f), rgb.c2)));
}

// YCoCg (seed 003 RGB2YCoCg / YCoCg2RGB; Karis 2014): luma on its own axis, so a box in
// YCoCg is tight around neighbourhoods whose spread is mostly luma.
template <class D>
HWY_INLINE Color3<D> rgb_to_ycocg(D d, const Color3<D>& c) {
  const auto q = hn::Set(d, 0.25f), h = hn::Set(d, 0.5f);
  auto rb = hn::Add(c.c0, c.c2);
  return {hn::MulAdd(rb, q, hn::Mul(c.c1, h)), hn::Mul(hn::Sub(c.c0, c.c2), h),
          hn::NegMulAdd(rb, q, hn::Mul(c.c1, h))};
}
template <class D>
HWY_INLINE Color3<D> ycocg_to_rgb(D, const Color3<D>& c) {
  auto y_cg = hn::Sub(c.c0, c.c2);
  return {hn::Add(y_cg, c.c1), hn::Add(c.c0, c.c2), hn::Sub(y_cg, c.c1)};
}

// ----------------------------------------------------------------------------------------
// Neighbourhood boxes (seed 000 "重影", seed 003 Color Clamping / Variance Clipping)
// ----------------------------------------------------------------------------------------

template <class D>
struct Aabb {
  Color3<D> lo, hi;
};

template <class D>
HWY_INLINE Aabb<D> aabb_of_point(const Color3<D>& c) {
  return {c, c};
}
template <class D>
HWY_INLINE Aabb<D> aabb_extend(const Aabb<D>& b, const Color3<D>& c) {
  return {cmin(b.lo, c), cmax(b.hi, c)};
}
// Min/max box of n samples.
template <class D>
HWY_INLINE Aabb<D> minmax_box(const Color3<D>* s, int n) {
  Aabb<D> b = aabb_of_point(s[0]);
  for (int i = 1; i < n; ++i) b = aabb_extend(b, s[i]);
  return b;
}
// INSIDE's "rounded" 3x3 box: the average of the cross and 3x3 min/max boxes (Playdead 2016).
template <class D>
HWY_INLINE Aabb<D> average_boxes(D d, const Aabb<D>& a, const Aabb<D>& b) {
  const auto h = hn::Set(d, 0.5f);
  return {scale(add(a.lo, b.lo), h), scale(add(a.hi, b.hi), h)};
}
// Variance box mu +- gamma sigma (Salvi 2016, seed 000 Eq.16, seed 003
// VarianceNeighbourhood) from the moment sums m1 = sum x, m2 = sum x^2 of n samples:
// sigma = sqrt(|m2/n - mu^2|), the seed's one-pass form.
template <class D>
HWY_INLINE Aabb<D> variance_box(D d, const Color3<D>& m1, const Color3<D>& m2, float inv_n,
                                float gamma) {
  const auto in = hn::Set(d, inv_n), g = hn::Set(d, gamma);
  Color3<D> mu = scale(m1, in);
  auto sigma = [&](V<D> m2c, V<D> muc) {
    return hn::Mul(g, hn::Sqrt(hn::Abs(hn::NegMulAdd(muc, muc, hn::Mul(m2c, in)))));
  };
  Color3<D> gs{sigma(m2.c0, mu.c0), sigma(m2.c1, mu.c1), sigma(m2.c2, mu.c2)};
  return {sub(mu, gs), add(mu, gs)};
}
// The same box computed in two passes on deviations from the center sample: the one-pass
// m2/n - mu^2 cancels catastrophically on bright HDR and near-flat neighbourhoods, where
// sqrt then turns rounding noise of 1e-7 into sigma ~ 3e-4. Identical samples give exactly
// the point.
template <class D>
HWY_INLINE Aabb<D> variance_box_of(D d, const Color3<D>* s, int n, float gamma) {
  const auto in = hn::Set(d, 1.0f / float(n)), g = hn::Set(d, gamma);
  Color3<D> e[9];
  Color3<D> sum = splat(d, 0.0f, 0.0f, 0.0f);
  for (int i = 0; i < n; ++i) {
    e[i] = sub(s[i], s[0]);
    sum = add(sum, e[i]);
  }
  const Color3<D> mean_e = scale(sum, in);
  Color3<D> m2 = splat(d, 0.0f, 0.0f, 0.0f);
  for (int i = 0; i < n; ++i) {
    Color3<D> c = sub(e[i], mean_e);
    m2 = {hn::MulAdd(c.c0, c.c0, m2.c0), hn::MulAdd(c.c1, c.c1, m2.c1),
          hn::MulAdd(c.c2, c.c2, m2.c2)};
  }
  const Color3<D> mu = add(s[0], mean_e);
  Color3<D> gs{hn::Mul(g, hn::Sqrt(hn::Mul(m2.c0, in))), hn::Mul(g, hn::Sqrt(hn::Mul(m2.c1, in))),
               hn::Mul(g, hn::Sqrt(hn::Mul(m2.c2, in)))};
  return {sub(mu, gs), add(mu, gs)};
}
// NVIDIA (Salvi 2016): never let the variance box exceed the min/max box.
template <class D>
HWY_INLINE Aabb<D> intersect_boxes(const Aabb<D>& a, const Aabb<D>& b) {
  return {cmax(a.lo, b.lo), cmin(a.hi, b.hi)};
}

// ----------------------------------------------------------------------------------------
// Velocity dilation (seed 002 "Motion Vector的膨胀", seed 003 GetClosestDepthPixelCoord)
// ----------------------------------------------------------------------------------------

template <class D>
struct DilatedMotion {
  V<D> depth, mx, my;
  V<D> choice;  // index (0..8, kNeighborDx/Dy order) of the neighbour whose motion is used
};

// Picks the motion a pixel reprojects with from its 3x3 neighbourhood (arrays in
// kNeighborDx/Dy order; only the entries the mode reads must be set). Closest depth: the
// nearest surface's motion, so edge pixels follow the foreground and background pixels
// behind a moving object do not fetch the object (seed 002's example). Largest motion:
// seed 003 "Magnitude Dilation". Strict comparisons in a fixed order: ties keep the
// earlier neighbour, the center first.
template <class D>
HWY_INLINE DilatedMotion<D> dilate_velocity(D d, VelocityDilation mode, const V<D>* depth,
                                            const V<D>* mx, const V<D>* my) {
  DilatedMotion<D> r{depth[0], mx[0], my[0], hn::Zero(d)};
  if (mode == VelocityDilation::None) return r;
  const int n = mode == VelocityDilation::ClosestDepthCross5 ? 5 : 9;
  const bool largest = mode == VelocityDilation::LargestMotion;
  auto best_len2 = hn::MulAdd(mx[0], mx[0], hn::Mul(my[0], my[0]));
  for (int i = 1; i < n; ++i) {
    auto len2 = hn::MulAdd(mx[i], mx[i], hn::Mul(my[i], my[i]));
    auto take = largest ? hn::Gt(len2, best_len2) : hn::Lt(depth[i], r.depth);
    r.depth = hn::IfThenElse(take, depth[i], r.depth);
    r.mx = hn::IfThenElse(take, mx[i], r.mx);
    r.my = hn::IfThenElse(take, my[i], r.my);
    r.choice = hn::IfThenElse(take, hn::Set(d, float(i)), r.choice);
    best_len2 = hn::IfThenElse(take, len2, best_len2);
  }
  return r;
}

// ----------------------------------------------------------------------------------------
// Rectification: bringing history into the box
// ----------------------------------------------------------------------------------------

// Per-channel clamp (seed 003 Color Clamping).
template <class D>
HWY_INLINE Color3<D> clamp_to_aabb(const Aabb<D>& b, const Color3<D>& h) {
  return cmin(cmax(h, b.lo), b.hi);
}

// Playdead clip_aabb (INSIDE, GDC 2016; seed 003): move q toward the box center until it is
// on the box, i.e. center + v / max(|v / extent|) when that max exceeds 1.
template <class D>
HWY_INLINE Color3<D> clip_aabb(D d, const Aabb<D>& b, const Color3<D>& q) {
  const auto h = hn::Set(d, 0.5f), eps = hn::Set(d, 1e-8f);  // Playdead FLT_EPS
  Color3<D> center = scale(add(b.hi, b.lo), h);
  Color3<D> e = scale(sub(b.hi, b.lo), h);
  e = {hn::Add(e.c0, eps), hn::Add(e.c1, eps), hn::Add(e.c2, eps)};
  Color3<D> v = sub(q, center);
  auto ma = hn::Max(hn::Abs(hn::Div(v.c0, e.c0)),
                    hn::Max(hn::Abs(hn::Div(v.c1, e.c1)), hn::Abs(hn::Div(v.c2, e.c2))));
  auto outside = hn::Gt(ma, hn::Set(d, 1.0f));
  auto inv = hn::Div(hn::Set(d, 1.0f), hn::Max(ma, hn::Set(d, 1.0f)));
  return select<D>(outside, mul_add(v, inv, center), q);
}

// UE4 ClipToFiltered (Karis 2014; seed 003): intersect the ray from history toward the
// filtered color with the box (slab test) and move history to where the ray enters it.
// If history is inside, the entry parameter is negative and history is kept.
template <class D>
HWY_INLINE Color3<D> clip_to_filtered(D d, const Aabb<D>& b, const Color3<D>& filtered,
                                      const Color3<D>& history) {
  const auto tiny = hn::Set(d, 1.0f / 65536.0f), one = hn::Set(d, 1.0f);
  Color3<D> dir = sub(filtered, history);
  auto enter = [&](V<D> lo, V<D> hi, V<D> o, V<D> r) {
    // Keep the sign of tiny directions (UE4 drops it; harmless, but this is exact).
    r = hn::IfThenElse(hn::Lt(hn::Abs(r), tiny), hn::CopySignToAbs(tiny, r), r);
    auto inv = hn::Div(one, r);
    auto t_hi = hn::Mul(hn::Sub(hi, o), inv), t_lo = hn::Mul(hn::Sub(lo, o), inv);
    return hn::Min(t_lo, t_hi);
  };
  auto t = hn::Max(enter(b.lo.c0, b.hi.c0, history.c0, dir.c0),
                   hn::Max(enter(b.lo.c1, b.hi.c1, history.c1, dir.c1),
                           enter(b.lo.c2, b.hi.c2, history.c2, dir.c2)));
  t = saturate(d, t);
  return mul_add(dir, t, history);
}

// Convex-hull clip of one pixel (scalar; taa/convex_hull.cpp): history moved along the
// segment toward `target` to where it enters the convex hull of points[0..n). Points that
// span no volume (coplanar, collinear, identical) fall back to the same segment clipped to
// their AABB. `target` is assumed inside the hull (a convex combination of the points).
Vec3f clip_to_convex_hull(const Vec3f* points, int n, Vec3f target, Vec3f history);

// Lane wrapper: stores the lanes, clips each pixel with the scalar routine, loads back.
template <class D>
HWY_INLINE Color3<D> clip_to_convex_hull(D d, const Color3<D>* points, int n,
                                         const Color3<D>& target, const Color3<D>& history) {
  const size_t lanes = hn::Lanes(d);
  alignas(64) float buf[9][3][kMaxLanes];
  alignas(64) float t[3][kMaxLanes], h[3][kMaxLanes];
  for (int i = 0; i < n; ++i) {
    hn::StoreU(points[i].c0, d, buf[i][0]);
    hn::StoreU(points[i].c1, d, buf[i][1]);
    hn::StoreU(points[i].c2, d, buf[i][2]);
  }
  hn::StoreU(target.c0, d, t[0]);
  hn::StoreU(target.c1, d, t[1]);
  hn::StoreU(target.c2, d, t[2]);
  hn::StoreU(history.c0, d, h[0]);
  hn::StoreU(history.c1, d, h[1]);
  hn::StoreU(history.c2, d, h[2]);
  for (size_t l = 0; l < lanes; ++l) {
    Vec3f p[9];
    for (int i = 0; i < n; ++i) p[i] = {buf[i][0][l], buf[i][1][l], buf[i][2][l]};
    Vec3f r = clip_to_convex_hull(p, n, {t[0][l], t[1][l], t[2][l]}, {h[0][l], h[1][l], h[2][l]});
    h[0][l] = r.x;
    h[1][l] = r.y;
    h[2][l] = r.z;
  }
  return {hn::LoadU(d, h[0]), hn::LoadU(d, h[1]), hn::LoadU(d, h[2])};
}

// ----------------------------------------------------------------------------------------
// Blending (seed 000 Eq.2; seed 003 LumaExponentialAccumulation)
// ----------------------------------------------------------------------------------------

// s_t = alpha x_t + (1 - alpha) s_{t-1}  (seed 000 Eq.2)
template <class D>
HWY_INLINE Color3<D> blend_exponential(D, const Color3<D>& current, const Color3<D>& history,
                                       V<D> alpha) {
  return {lerp<D>(history.c0, current.c0, alpha), lerp<D>(history.c1, current.c1, alpha),
          lerp<D>(history.c2, current.c2, alpha)};
}

// Karis weight w(c) = 1 / (1 + L(c)) (seed 003 "Luma Weighted Exponential Blending").
template <class D>
HWY_INLINE V<D> karis_weight(D d, V<D> luma) {
  const auto one = hn::Set(d, 1.0f);
  return hn::Div(one, hn::Add(one, hn::Max(luma, hn::Zero(d))));
}

// Eq.2 with each side weighted by 1/(1+L): bright outliers (fireflies, specular sparkles)
// pull the result less, which suppresses HDR flicker (seed 003).
template <class D>
HWY_INLINE Color3<D> blend_luma_weighted(D d, const Color3<D>& current, const Color3<D>& history,
                                         V<D> alpha) {
  auto wc = hn::Mul(alpha, karis_weight(d, luminance(d, current)));
  auto wh = hn::Mul(hn::Sub(hn::Set(d, 1.0f), alpha), karis_weight(d, luminance(d, history)));
  auto inv = hn::Div(hn::Set(d, 1.0f), hn::Add(wc, wh));
  return scale(mul_add(current, wc, scale(history, wh)), inv);
}

// ----------------------------------------------------------------------------------------
// Blend factor (seed 003 "Dynamic/Adaptive Blending Factor")
// ----------------------------------------------------------------------------------------

// alpha = max(alpha_min, 1 / N): N equal weights reproduce the box filter of Eq.1 for a pixel
// with N samples; the floor turns it into the exponential filter of Eq.2/3.
template <class D>
HWY_INLINE V<D> alpha_from_sample_count(D d, V<D> n, V<D> alpha_min) {
  return hn::Max(alpha_min, hn::Div(hn::Set(d, 1.0f), hn::Max(n, hn::Set(d, 1.0f))));
}

// Velocity weighting (seed 003 ①, UE4): more current frame when moving, where ghosting is
// worse than flicker. alpha -> alpha_max at `full_px` pixels per frame.
template <class D>
HWY_INLINE V<D> alpha_from_velocity(D d, V<D> alpha, V<D> mx, V<D> my, float alpha_max,
                                    float full_px) {
  auto speed = hn::Sqrt(hn::MulAdd(mx, mx, hn::Mul(my, my)));
  auto t = saturate(d, hn::Mul(speed, hn::Set(d, 1.0f / full_px)));
  return lerp<D>(alpha, hn::Set(d, alpha_max), t);
}

// Depth weighting (seed 003 ②): distant geometry flickers most and ghosts least visibly, so
// alpha falls toward alpha_far as sqrt(near_distance / depth) falls (the seed's
// lerp(0.025, alpha, sqrt(depth)) with reversed-Z depth). Sky (kBackgroundDepth) keeps alpha.
template <class D>
HWY_INLINE V<D> alpha_from_depth(D d, V<D> alpha, V<D> depth, float alpha_far, float near_distance,
                                 float background_depth) {
  auto closeness = hn::Sqrt(saturate(d, hn::Div(hn::Set(d, near_distance), depth)));
  auto a = lerp<D>(hn::Set(d, alpha_far), alpha, closeness);
  return hn::IfThenElse(hn::Ge(depth, hn::Set(d, background_depth)), alpha, a);
}

// Karis 2014: lower alpha when history is near the clamp box, which softens the temporal
// change that clamping causes (distance measured along luma, relative to half the extent).
template <class D>
HWY_INLINE V<D> alpha_from_clamp_distance(D d, V<D> alpha, V<D> luma_history, V<D> luma_lo,
                                          V<D> luma_hi, float scale_at_surface) {
  auto dist = hn::Min(hn::Sub(luma_history, luma_lo), hn::Sub(luma_hi, luma_history));
  auto half = hn::Max(hn::Mul(hn::Sub(luma_hi, luma_lo), hn::Set(d, 0.5f)), hn::Set(d, 1e-6f));
  auto t = saturate(d, hn::Div(dist, half));
  return hn::Mul(alpha, lerp<D>(hn::Set(d, scale_at_surface), hn::Set(d, 1.0f), t));
}

// INSIDE (Playdead 2016): feedback = lerp(fmin, fmax, (1 - |Lc - Lh| / max(Lc, Lh, 0.2))^2);
// alpha = 1 - feedback. Similar lumas keep more history (stability), different lumas less.
template <class D>
HWY_INLINE V<D> alpha_from_luma_difference(D d, V<D> luma_current, V<D> luma_history,
                                           float feedback_min, float feedback_max) {
  auto denom = hn::Max(luma_current, hn::Max(luma_history, hn::Set(d, 0.2f)));
  auto unbiased_diff = hn::Div(hn::Abs(hn::Sub(luma_current, luma_history)), denom);
  auto w = hn::Sub(hn::Set(d, 1.0f), saturate(d, unbiased_diff));
  auto feedback = lerp<D>(hn::Set(d, feedback_min), hn::Set(d, feedback_max), hn::Mul(w, w));
  return hn::Sub(hn::Set(d, 1.0f), feedback);
}

// ----------------------------------------------------------------------------------------
// Current-frame filter (seed 003 "Filter Current Color")
// ----------------------------------------------------------------------------------------

// Filter weights of the 9 neighbours for this frame. The sample of neighbour (dx, dy) was
// taken at (dx + jitter.x, dy + jitter.y) relative to the output pixel center (DESIGN.md §3),
// so the weights depend on the actual sample distance, not the pixel distance; they are the
// same for every pixel of a frame. Unnormalised (normalised per pixel after luma weighting).
std::array<float, 9> current_filter_weights(CurrentFilter kind, float sigma, Vec2f jitter);

// ----------------------------------------------------------------------------------------
// Sharpening (seed 000 Eq.5)
// ----------------------------------------------------------------------------------------

// c + s (4c - up - down - left - right), then clamped to the 3x3 [lo, hi] of the resolved
// image: only the overshoot is removed, HDR values above 1 stay (no saturate, unlike U4).
template <class D>
HWY_INLINE V<D> sharpen_laplacian(D d, V<D> c, V<D> up, V<D> down, V<D> left, V<D> right,
                                  float strength, V<D> lo, V<D> hi) {
  auto lap =
      hn::Sub(hn::Mul(hn::Set(d, 4.0f), c), hn::Add(hn::Add(up, down), hn::Add(left, right)));
  auto s = hn::MulAdd(hn::Set(d, strength), lap, c);
  return hn::Min(hn::Max(s, lo), hi);
}

// ----------------------------------------------------------------------------------------
// Loads
// ----------------------------------------------------------------------------------------

// Lanes x + dx .. of `row` (width `width`), clamped to the edge: a contiguous load inside,
// a gather of clamped indices at the borders.
template <class D, class T>
HWY_INLINE hn::Vec<D> load_row_shifted(D d, const T* row, int x, int dx, int width) {
  const int n = int(hn::Lanes(d));
  const int xs = x + dx;
  if (xs >= 0 && xs + n <= width) return hn::LoadU(d, row + xs);
  const hn::RebindToSigned<D> di;
  auto idx = hn::Min(hn::Max(hn::Iota(di, xs), hn::Zero(di)), hn::Set(di, width - 1));
  return hn::GatherIndex(d, row, idx);
}

// Non-finite depth is background (DESIGN.md §3: loaders map it to kBackgroundDepth).
template <class D>
HWY_INLINE V<D> sanitize_depth(D d, V<D> depth, float background) {
  return hn::IfThenElse(hn::IsFinite(depth), depth, hn::Set(d, background));
}

// ----------------------------------------------------------------------------------------
// History fetch (seed 000 "重投影"/"模糊处理", seed 003 "History Filter")
// ----------------------------------------------------------------------------------------

// Three planes of one image (history color), read by gathers.
struct Planes3 {
  const float* p[3] = {nullptr, nullptr, nullptr};
  int width = 0, height = 0;
};

// Flat index of pixel (ix, iy) (integer-valued floats), clamped to the image.
template <class D>
HWY_INLINE VI<D> clamped_pixel_index(D d, int width, int height, V<D> ix, V<D> iy) {
  const hn::RebindToSigned<D> di;
  ix = hn::Min(hn::Max(ix, hn::Zero(d)), hn::Set(d, float(width - 1)));
  iy = hn::Min(hn::Max(iy, hn::Zero(d)), hn::Set(d, float(height - 1)));
  return hn::Add(hn::Mul(hn::ConvertTo(di, iy), hn::Set(di, width)), hn::ConvertTo(di, ix));
}

template <class D>
HWY_INLINE Color3<D> gather3(D d, const Planes3& img, VI<D> idx) {
  return {hn::GatherIndex(d, img.p[0], idx), hn::GatherIndex(d, img.p[1], idx),
          hn::GatherIndex(d, img.p[2], idx)};
}

// The 2x2 pixels whose centers surround (x, y) and the bilinear fractions.
template <class D>
struct Footprint {
  VI<D> i00, i10, i01, i11;
  V<D> fx, fy;
};
template <class D>
HWY_INLINE Footprint<D> bilinear_footprint(D d, int width, int height, V<D> x, V<D> y) {
  const auto half = hn::Set(d, 0.5f), one = hn::Set(d, 1.0f);
  auto tx = hn::Sub(x, half), ty = hn::Sub(y, half);
  auto x0 = hn::Floor(tx), y0 = hn::Floor(ty);
  auto x1 = hn::Add(x0, one), y1 = hn::Add(y0, one);
  return {clamped_pixel_index(d, width, height, x0, y0),
          clamped_pixel_index(d, width, height, x1, y0),
          clamped_pixel_index(d, width, height, x0, y1),
          clamped_pixel_index(d, width, height, x1, y1),
          hn::Sub(tx, x0),
          hn::Sub(ty, y0)};
}

// Bilinear fetch of three planes; optionally the min/max of the four taps (anti-ringing).
template <class D>
HWY_INLINE Color3<D> bilinear3(D d, const Planes3& img, const Footprint<D>& f,
                               Aabb<D>* taps_box = nullptr) {
  Color3<D> a = gather3(d, img, f.i00), b = gather3(d, img, f.i10);
  Color3<D> c = gather3(d, img, f.i01), e = gather3(d, img, f.i11);
  if (taps_box) *taps_box = {cmin(cmin(a, b), cmin(c, e)), cmax(cmax(a, b), cmax(c, e))};
  auto lerp2 = [&](V<D> va, V<D> vb, V<D> vc, V<D> ve) {
    auto top = hn::MulAdd(hn::Sub(vb, va), f.fx, va);
    auto bot = hn::MulAdd(hn::Sub(ve, vc), f.fx, vc);
    return hn::MulAdd(hn::Sub(bot, top), f.fy, top);
  };
  return {lerp2(a.c0, b.c0, c.c0, e.c0), lerp2(a.c1, b.c1, c.c1, e.c1),
          lerp2(a.c2, b.c2, c.c2, e.c2)};
}

// HLSL Load of the pixel containing (x, y): no resampling blur (seed 000, static scenes).
template <class D>
HWY_INLINE Color3<D> sample_history_point(D d, const Planes3& img, V<D> x, V<D> y) {
  return gather3(d, img, clamped_pixel_index(d, img.width, img.height, hn::Floor(x), hn::Floor(y)));
}

// Bilinear history (seed 000: Sample with a linear sampler).
template <class D>
HWY_INLINE Color3<D> sample_history_bilinear(D d, const Planes3& img, V<D> x, V<D> y,
                                             Aabb<D>* footprint_box = nullptr) {
  return bilinear3(d, img, bilinear_footprint(d, img.width, img.height, x, y), footprint_box);
}

// Activision 5-tap Catmull-Rom (Filmic SMAA 2016; seed 003 SampleHistoryBicubic): the
// 9-tap layout without its corners, renormalised. On a GPU each tap is one bilinear fetch;
// here a fetch is a gather per texel, and the outer taps sit exactly on texel centers along
// one axis (their bilinear fraction there is 0), so the 5 taps read only 12 distinct texels:
// the 2x2 around (x, y) (center tap, also the anti-ringing box) and 2 texels per outer tap.
// Same weights and result as 5 bilinear fetches (20 gathers), with 12 gathers per plane.
template <class D>
HWY_INLINE Color3<D> sample_history_catmull_rom_5(D d, const Planes3& img, V<D> x, V<D> y,
                                                  Aabb<D>* footprint_box = nullptr) {
  const int w = img.width, h = img.height;
  const auto one = hn::Set(d, 1.0f), half = hn::Set(d, 0.5f);
  auto ax = catmull_rom_axis(d, x), ay = catmull_rom_axis(d, y);
  // Texel columns / rows -1, 0, 1, 2 around the cell; tc1 - 0.5 is the integer index of 0.
  const auto ix0 = hn::Sub(ax.tc0, half), iy0 = hn::Sub(ay.tc0, half);
  const V<D> cx[4] = {ix0, hn::Add(ix0, one), hn::Add(ix0, hn::Set(d, 2.0f)),
                      hn::Add(ix0, hn::Set(d, 3.0f))};
  const V<D> cy[4] = {iy0, hn::Add(iy0, one), hn::Add(iy0, hn::Set(d, 2.0f)),
                      hn::Add(iy0, hn::Set(d, 3.0f))};
  auto texel = [&](int i, int j) {
    return gather3(d, img, clamped_pixel_index(d, w, h, cx[i], cy[j]));
  };
  // Fractions of the merged middle taps inside the cell (bilinear fx / fy of tc12).
  const auto fx = hn::Sub(hn::Sub(ax.tc12, half), cx[1]),
             fy = hn::Sub(hn::Sub(ay.tc12, half), cy[1]);
  auto lerp3 = [&](const Color3<D>& a, const Color3<D>& b, V<D> t) {
    return Color3<D>{lerp<D>(a.c0, b.c0, t), lerp<D>(a.c1, b.c1, t), lerp<D>(a.c2, b.c2, t)};
  };
  const Color3<D> t11 = texel(1, 1), t21 = texel(2, 1), t12 = texel(1, 2), t22 = texel(2, 2);
  if (footprint_box)
    *footprint_box = {cmin(cmin(t11, t21), cmin(t12, t22)), cmax(cmax(t11, t21), cmax(t12, t22))};
  const Color3<D> center = lerp3(lerp3(t11, t21, fx), lerp3(t12, t22, fx), fy);
  const Color3<D> up = lerp3(texel(1, 0), texel(2, 0), fx);
  const Color3<D> down = lerp3(texel(1, 3), texel(2, 3), fx);
  const Color3<D> left = lerp3(texel(0, 1), texel(0, 2), fy);
  const Color3<D> right = lerp3(texel(3, 1), texel(3, 2), fy);
  auto cw0 = hn::Mul(ax.w12, ay.w0), cw1 = hn::Mul(ax.w0, ay.w12), cw2 = hn::Mul(ax.w12, ay.w12);
  auto cw3 = hn::Mul(ax.w3, ay.w12), cw4 = hn::Mul(ax.w12, ay.w3);
  Color3<D> s = scale(center, cw2);
  s = mul_add(up, cw0, s);
  s = mul_add(left, cw1, s);
  s = mul_add(right, cw3, s);
  s = mul_add(down, cw4, s);
  auto inv = hn::Div(one, hn::Add(hn::Add(hn::Add(cw0, cw1), hn::Add(cw2, cw3)), cw4));
  return scale(s, inv);
}

// MJP's 9-tap Catmull-Rom: 3x3 bilinear taps at tc0 / tc12 / tc3 of each axis (exact
// 16-tap Catmull-Rom away from the borders; seed 003 link).
template <class D>
HWY_INLINE Color3<D> sample_history_catmull_rom_9(D d, const Planes3& img, V<D> x, V<D> y,
                                                  Aabb<D>* footprint_box = nullptr) {
  const int w = img.width, h = img.height;
  auto ax = catmull_rom_axis(d, x), ay = catmull_rom_axis(d, y);
  const V<D> px[3] = {ax.tc0, ax.tc12, ax.tc3}, wx[3] = {ax.w0, ax.w12, ax.w3};
  const V<D> py[3] = {ay.tc0, ay.tc12, ay.tc3}, wy[3] = {ay.w0, ay.w12, ay.w3};
  Color3<D> s = splat(d, 0.0f, 0.0f, 0.0f);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) {
      Aabb<D>* box = (i == 1 && j == 1) ? footprint_box : nullptr;
      s = mul_add(bilinear3(d, img, bilinear_footprint(d, w, h, px[i], py[j]), box),
                  hn::Mul(wx[i], wy[j]), s);
    }
  return s;
}

// Full 16-tap Catmull-Rom bicubic (Keys a = -0.5): the reference of the two above.
template <class D>
HWY_INLINE Color3<D> sample_history_catmull_rom_16(D d, const Planes3& img, V<D> x, V<D> y,
                                                   Aabb<D>* footprint_box = nullptr) {
  const auto half = hn::Set(d, 0.5f);
  auto tx = hn::Sub(x, half), ty = hn::Sub(y, half);
  auto x0 = hn::Floor(tx), y0 = hn::Floor(ty);
  auto wx4 = catmull_rom_weights(d, hn::Sub(tx, x0)), wy4 = catmull_rom_weights(d, hn::Sub(ty, y0));
  const V<D> wx[4] = {wx4.w0, wx4.w1, wx4.w2, wx4.w3}, wy[4] = {wy4.w0, wy4.w1, wy4.w2, wy4.w3};
  Color3<D> s = splat(d, 0.0f, 0.0f, 0.0f);
  Color3<D> inner[4];
  int k = 0;
  for (int j = 0; j < 4; ++j) {
    auto yy = hn::Add(y0, hn::Set(d, float(j - 1)));
    Color3<D> row = splat(d, 0.0f, 0.0f, 0.0f);
    for (int i = 0; i < 4; ++i) {
      auto xx = hn::Add(x0, hn::Set(d, float(i - 1)));
      Color3<D> t = gather3(d, img, clamped_pixel_index(d, img.width, img.height, xx, yy));
      if ((i == 1 || i == 2) && (j == 1 || j == 2)) inner[k++] = t;
      row = mul_add(t, wx[i], row);
    }
    s = mul_add(row, wy[j], s);
  }
  if (footprint_box) *footprint_box = minmax_box(inner, 4);
  return s;
}

}  // namespace afterimage::taa
