// Per-pixel building blocks of temporal anti-aliasing, written once as inline functions
// templated on a Highway descriptor `d` (DESIGN.md §6, tev's simdFor habit). Each works on
// hn::Vec lanes like a shader works on one pixel; the resolver runs them full-width and at
// 1 lane for tails and for the reference path (Exec::simd == false).
//
// Naming follows the seeds where they name things (seed 000: Eq.1-5; seed 003: clip_aabb,
// ClipToFiltered, VarianceNeighbourhood, LumaExponentialAccumulation, SampleHistoryBicubic,
// GaussianFilterMiddleColor). A color is three lane vectors (RGB or YCoCg, core/lanes.h).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/error.h"
#include "core/lanes.h"
#include "core/math.h"
#include "core/neighborhood.h"
#include "core/simd.h"
#include "reproject/gather.h"
#include "taa/settings.h"

namespace afterimage::taa {

// Lane colors, boxes, luminance and YCoCg: core/lanes.h; neighbourhood order and loads:
// core/neighborhood.h; history position, footprint, consistency tests and gathers:
// reproject/.

// ----------------------------------------------------------------------------------------
// Neighbourhood boxes (seed 000 "重影", seed 003 Color Clamping / Variance Clipping);
// aabb_of_point / aabb_extend / minmax_box are in core/lanes.h.
// ----------------------------------------------------------------------------------------

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
#pragma GCC unroll 9
  for (int i = 0; i < n; ++i) {
    e[i] = sub(s[i], s[0]);
    sum = add(sum, e[i]);
  }
  const Color3<D> mean_e = scale(sum, in);
  Color3<D> m2 = splat(d, 0.0f, 0.0f, 0.0f);
#pragma GCC unroll 9
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

// Motion of pixels whose motion vector is not finite: "unknown" is treated as off-screen.
inline constexpr float kUnknownMotion = 1e9f;

// Both components become kUnknownMotion where either is not finite.
template <class D>
HWY_INLINE void replace_unknown_motion(D d, V<D>& mx, V<D>& my) {
  const auto ok = hn::And(hn::IsFinite(mx), hn::IsFinite(my));
  mx = hn::IfThenElse(ok, mx, hn::Set(d, kUnknownMotion));
  my = hn::IfThenElse(ok, my, hn::Set(d, kUnknownMotion));
}

// Picks the motion a pixel reprojects with from its 3x3 neighbourhood (kNeighborDx/Dy
// order). Closest depth: the nearest surface's motion, so edge pixels follow the foreground
// and background pixels behind a moving object do not fetch the object (seed 002's example).
// Largest motion: seed 003 "Magnitude Dilation". Strict comparisons in a fixed order: ties keep
// the earlier neighbour, the center first. Non-finite motion is kUnknownMotion.
// Streamed: `load(i, depth, mx, my)` gives neighbour i (depth sanitized, motion as stored) when
// it is needed and `on_take(i, take)` says in which lanes it became the choice, so only the
// running choice is live, not 27 vectors; the closest-depth modes check the motion's
// finiteness once, on the chosen neighbour (the choice depends on depth alone).
// The loop over the neighbours has a compile-time count and is unrolled: with the count known
// only at run time, GCC kept it a loop whose running choice and id lived on the stack (a masked
// store per neighbour, reloaded by the next one) and whose neighbour offsets came from tables.
template <int kCount, bool kLargest, class D, class Load, class OnTake>
HWY_INLINE DilatedMotion<D> dilate_velocity_unrolled(D d, Load&& load, OnTake&& on_take) {
  DilatedMotion<D> r{hn::Zero(d), hn::Zero(d), hn::Zero(d), hn::Zero(d)};
  load(0, r.depth, r.mx, r.my);
  if (kLargest) replace_unknown_motion(d, r.mx, r.my);
  auto best_len2 = kLargest ? hn::MulAdd(r.mx, r.mx, hn::Mul(r.my, r.my)) : hn::Zero(d);
#pragma GCC unroll 9
  for (int i = 1; i < kCount; ++i) {
    V<D> depth, mx, my;
    load(i, depth, mx, my);
    hn::Mask<D> take;
    if (kLargest) {
      replace_unknown_motion(d, mx, my);
      const auto len2 = hn::MulAdd(mx, mx, hn::Mul(my, my));
      take = hn::Gt(len2, best_len2);
      best_len2 = hn::IfThenElse(take, len2, best_len2);
    } else {
      take = hn::Lt(depth, r.depth);
    }
    r.depth = hn::IfThenElse(take, depth, r.depth);
    r.mx = hn::IfThenElse(take, mx, r.mx);
    r.my = hn::IfThenElse(take, my, r.my);
    r.choice = hn::IfThenElse(take, hn::Set(d, float(i)), r.choice);
    on_take(i, take);
  }
  if (!kLargest) replace_unknown_motion(d, r.mx, r.my);
  return r;
}
template <class D, class Load, class OnTake>
HWY_INLINE DilatedMotion<D> dilate_velocity_streamed(D d, VelocityDilation mode, Load&& load,
                                                     OnTake&& on_take) {
  switch (mode) {
    case VelocityDilation::None:
      return dilate_velocity_unrolled<1, false>(d, load, on_take);
    case VelocityDilation::ClosestDepthCross5:
      return dilate_velocity_unrolled<5, false>(d, load, on_take);
    case VelocityDilation::LargestMotion:
      return dilate_velocity_unrolled<9, true>(d, load, on_take);
    case VelocityDilation::ClosestDepthBox9:
      break;
  }
  return dilate_velocity_unrolled<9, false>(d, load, on_take);
}

// The same over arrays (only the entries the mode reads must be set).
template <class D>
HWY_INLINE DilatedMotion<D> dilate_velocity(D d, VelocityDilation mode, const V<D>* depth,
                                            const V<D>* mx, const V<D>* my) {
  return dilate_velocity_streamed(
      d, mode,
      [&](int i, V<D>& de, V<D>& x, V<D>& y) {
        de = depth[i];
        x = mx[i];
        y = my[i];
      },
      [](int, hn::Mask<D>) {});
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
  // History strictly inside the box in every lane (converged, trusted content mostly): on each
  // axis lo - o < 0 < hi - o, so the two slab parameters, scaled by the same finite 1 / r,
  // never both exceed 0 (a NaN product only with r infinite, whose 1 / r = 0 zeroes the other),
  // and saturate (max(t, +0) returns +0 for t <= 0 or NaN) makes t = +0: the same result
  // without the three divisions (9cd7e5f; docs/perf/profile-taa-resolve.md).
  const auto inside =
      hn::And(hn::And(hn::And(hn::Lt(b.lo.c0, history.c0), hn::Lt(history.c0, b.hi.c0)),
                      hn::And(hn::Lt(b.lo.c1, history.c1), hn::Lt(history.c1, b.hi.c1))),
              hn::And(hn::Lt(b.lo.c2, history.c2), hn::Lt(history.c2, b.hi.c2)));
  if (hn::AllTrue(d, inside)) return mul_add(dir, hn::Zero(d), history);
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

// Convex-hull clip of one pixel (scalar; taa/kernels.cpp): history moved along the
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
// Current-color filter and rectification of one pixel (steps 2 and 6 of resolver.h)
// ----------------------------------------------------------------------------------------

// Weighted mean of the 3x3 current samples (kNeighborDx/Dy order) with this frame's
// jitter-dependent weights (current_filter_weights), optionally times 1/(1+L) per sample
// (seed 003 GaussianFilterMiddleColor).
template <class D>
HWY_INLINE Color3<D> filter_current_color(D d, const Color3<D>* nb,
                                          const std::array<float, 9>& weights, bool luma_weight) {
  Color3<D> acc = splat(d, 0.0f, 0.0f, 0.0f);
  auto wsum = hn::Zero(d);
  for (int i = 0; i < 9; ++i) {
    auto wi = hn::Set(d, weights[size_t(i)]);
    if (luma_weight) wi = hn::Mul(wi, karis_weight(d, luminance(d, nb[i])));
    acc = mul_add(nb[i], wi, acc);
    wsum = hn::Add(wsum, wi);
  }
  // A filter with negative lobes (Mitchell-Netravali) undershoots beside a bright edge; color
  // stays non-negative (a no-op for the Gaussians, whose weights are positive).
  return cmax(scale(acc, hn::Div(hn::Set(d, 1.0f), wsum)), splat(d, 0.0f, 0.0f, 0.0f));
}

// History brought into the neighbourhood's box, and where it sat along luma relative to the
// box (for alpha_from_clamp_distance).
template <class D>
struct RectifiedHistory {
  Color3<D> history;  // RGB
  V<D> luma, luma_lo, luma_hi;
};

// The box of the current samples `nb` the settings ask for (min/max, rounded, variance,
// intersected; in RGB or YCoCg), before it is grown to the filtered color: a function of the
// 3x3 samples only, so TAAU computes it once per input pixel (taau/upscaler.cpp).
// The sample count is a template parameter so the loops here and in minmax_box /
// variance_box_of are unrolled with the samples in registers (see dilate_velocity_unrolled).
template <int kSamples, class D>
HWY_INLINE Aabb<D> neighborhood_box_of(D d, const TaaSettings& s, const Color3<D>* nb) {
  const bool ycocg = s.color_space == ColorSpace::YCoCg;
  Color3<D> sc[9];
#pragma GCC unroll 9
  for (int i = 0; i < kSamples; ++i) sc[i] = ycocg ? rgb_to_ycocg(d, nb[i]) : nb[i];
  const Aabb<D> minmax = s.neighborhood == Neighborhood::Rounded
                             ? average_boxes(d, minmax_box(sc, 5), minmax_box(sc, 9))
                             : minmax_box(sc, kSamples);
  Aabb<D> box = minmax;
  if (s.box == BoxShape::Variance) {
    box = variance_box_of(d, sc, kSamples, s.variance_gamma);
    if (s.variance_intersect_minmax) box = intersect_boxes(box, minmax);
  }
  return box;
}
template <class D>
HWY_INLINE Aabb<D> neighborhood_box(D d, const TaaSettings& s, const Color3<D>* nb) {
  return s.neighborhood == Neighborhood::Cross5 ? neighborhood_box_of<5>(d, s, nb)
                                                : neighborhood_box_of<9>(d, s, nb);
}

// The box grown to a half-extent of at least floor * max(luma, 0) + 1e-6 around its center in
// the chroma channels (YCoCg's Co and Cg; every channel in RGB, where chroma is spread over
// all three; settings.h box_floor): clipping toward a point along a direction has no
// continuous answer when the box is flat in a channel the history deviates in by rounding. A
// flat luma is a flat region, where any clip target is the same color.
template <class D>
HWY_INLINE Aabb<D> box_with_floor(D d, const Aabb<D>& b, V<D> luma, float floor, bool ycocg) {
  const auto f = hn::MulAdd(hn::Set(d, floor), hn::Max(luma, hn::Zero(d)), hn::Set(d, 1e-6f));
  auto grow = [&](V<D> lo, V<D> hi, V<D>& out_lo, V<D>& out_hi) {
    const auto extra = hn::Max(hn::Sub(f, hn::Mul(hn::Sub(hi, lo), hn::Set(d, 0.5f))), hn::Zero(d));
    out_lo = hn::Sub(lo, extra);
    out_hi = hn::Add(hi, extra);
  };
  Aabb<D> r = b;
  if (!ycocg) grow(b.lo.c0, b.hi.c0, r.lo.c0, r.hi.c0);
  grow(b.lo.c1, b.hi.c1, r.lo.c1, r.hi.c1);
  grow(b.lo.c2, b.hi.c2, r.lo.c2, r.hi.c2);
  return r;
}

// The second half of rectify_history: the neighbourhood box (neighborhood_box, in the
// settings' color space) grown to the filtered color and by `relax`, then the history
// rectified against it. Not for Rectify::ConvexHull, which needs the samples themselves.
template <class D>
HWY_INLINE RectifiedHistory<D> rectify_with_box(D d, const TaaSettings& s, Aabb<D> box,
                                                const Color3<D>& filtered, const Color3<D>& history,
                                                V<D> relax) {
  const bool ycocg = s.color_space == ColorSpace::YCoCg;
  const Color3<D> ft = ycocg ? rgb_to_ycocg(d, filtered) : filtered;
  const Color3<D> hs = ycocg ? rgb_to_ycocg(d, history) : history;
  if (s.box == BoxShape::Variance && s.variance_include_filtered) box = aabb_extend(box, ft);
  if (s.box_floor > 0.0f)
    box = box_with_floor(d, box, ycocg ? ft.c0 : luminance(d, ft), s.box_floor, ycocg);
  if (s.confidence) box = {sub(box.lo, {relax, relax, relax}), add(box.hi, {relax, relax, relax})};
  RectifiedHistory<D> r{history, hs.c0, box.lo.c0, box.hi.c0};  // YCoCg: Y is luma
  if (!ycocg) {
    r.luma = luminance(d, hs);
    r.luma_lo = luminance(d, box.lo);
    r.luma_hi = luminance(d, box.hi);
  }
  Color3<D> hr = hs;
  switch (s.rectify) {
    case Rectify::None:
      return r;
    case Rectify::Clamp:
      hr = clamp_to_aabb(box, hs);
      break;
    case Rectify::ClipCenter:
      hr = clip_aabb(d, box, hs);
      break;
    case Rectify::ClipFiltered:
      hr = clip_to_filtered(d, box, ft, hs);
      break;
    case Rectify::ConvexHull:
      AI_CHECK(false);  // rectify_history handles it
      break;
  }
  r.history = ycocg ? ycocg_to_rgb(d, hr) : hr;
  return r;
}

// Builds the box the settings ask for (neighborhood_box, grown to the filtered color), widens it
// by `relax` on every side (history confidence), and rectifies `history` (clamp / clip to
// center / clip toward the filtered color: rectify_with_box; convex hull: against the samples
// themselves, not widened).
template <class D>
HWY_INLINE RectifiedHistory<D> rectify_history(D d, const TaaSettings& s, const Color3<D>* nb,
                                               const Color3<D>& filtered, const Color3<D>& history,
                                               V<D> relax) {
  if (s.rectify != Rectify::ConvexHull)
    return rectify_with_box(d, s, neighborhood_box(d, s, nb), filtered, history, relax);
  const bool ycocg = s.color_space == ColorSpace::YCoCg;
  const int n_nb = s.neighborhood == Neighborhood::Cross5 ? 5 : 9;
  Color3<D> sc[9];
  for (int i = 0; i < n_nb; ++i) sc[i] = ycocg ? rgb_to_ycocg(d, nb[i]) : nb[i];
  const Color3<D> ft = ycocg ? rgb_to_ycocg(d, filtered) : filtered;
  const Color3<D> hs = ycocg ? rgb_to_ycocg(d, history) : history;
  Aabb<D> box = neighborhood_box(d, s, nb);
  if (s.box == BoxShape::Variance && s.variance_include_filtered) box = aabb_extend(box, ft);
  if (s.confidence) box = {sub(box.lo, {relax, relax, relax}), add(box.hi, {relax, relax, relax})};
  RectifiedHistory<D> r{history, hs.c0, box.lo.c0, box.hi.c0};
  if (!ycocg) {
    r.luma = luminance(d, hs);
    r.luma_lo = luminance(d, box.lo);
    r.luma_hi = luminance(d, box.hi);
  }
  r.history = ycocg ? ycocg_to_rgb(d, clip_to_convex_hull(d, sc, n_nb, ft, hs))
                    : clip_to_convex_hull(d, sc, n_nb, ft, hs);
  return r;
}

// ----------------------------------------------------------------------------------------
// Blend factor (seed 003 "Dynamic/Adaptive Blending Factor")
// ----------------------------------------------------------------------------------------

// alpha = max(alpha_min, 1 / N): N equal weights reproduce the box filter of Eq.1 for a pixel
// with N samples; the floor turns it into the exponential filter of Eq.2/3.
template <class D>
HWY_INLINE V<D> inverse_sample_count(D d, V<D> n) {
  return hn::Div(hn::Set(d, 1.0f), hn::Max(n, hn::Set(d, 1.0f)));
}
template <class D>
HWY_INLINE V<D> alpha_from_sample_count(D d, V<D> n, V<D> alpha_min) {
  return hn::Max(alpha_min, inverse_sample_count(d, n));
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
// History confidence: how far the history may be trusted (issue 10)
// ----------------------------------------------------------------------------------------
// A neighbourhood box built from one jittered frame cannot hold what many frames average to
// where the scene is finer than a pixel: a thin pole that 3 of 16 jitter positions hit is
// absent from most frames' 3x3 box, so rectification pulls converged history back to the
// background every frame and still content never converges. What tells aliasing from a real
// change is the pixel's own sample distribution over time: each pixel keeps the running mean
// and variance of its raw samples' luma (reprojected like history). A new sample inside that
// distribution is the same signal seen through another jitter position; one far outside it is
// a change (a light moved, a surface was uncovered). Seed 003 "Depth Weighted" ① makes the
// same distinction from depth: depth that changes at zero velocity is geometric aliasing, to
// be clamped less; here it is the color that decides, which also catches lighting changes.
// FSR2's locks (thin features trusted until their luma changes) and its low-motion box
// enlargement are the same idea in other forms.

// Exponentially weighted luma statistics of a pixel's raw samples: mean, variance from
// successive differences, the last sample, the mean of the 3x3 neighbourhood's luma variance,
// the variance about the mean, and the drift (the mean deviation of new samples from the mean).
template <class D>
struct LumaMoments {
  V<D> mean, var, last, var_spatial, var_mean;
  V<D> recent_motion;  // largest 3x3 speed seen lately (px/frame), decaying
  V<D> drift;
};
constexpr int kLumaMomentPlanes = 7;
// What the neighbours of a pixel read of its moments besides the mean and the drift, derived
// from them when they are stored: 1 / neighbor_change_spread and drift_spread.
constexpr int kSpreadPlanes = 2;

// Update with weight a of the new sample x: mean' = mean + a (x - mean); the variance from
// successive differences, var' = (1 - a) var + a (x - last)^2 / 2 (von Neumann 1941: the mean
// square successive difference is 2 sigma^2 for independent samples). Unlike the spread
// around the mean, it does not grow when the signal drifts (a light sweeping slowly over a
// floor), only when consecutive samples disagree (jitter hitting and missing a thin pole).
// The neighbourhood variance var_s is averaged the same way: whether the pixel's
// surroundings usually hold an edge or a thin feature. a = 0 changes nothing (a held pixel);
// a = 1 restarts at x with zero variance. No m2 - m1^2 difference, so no cancellation at high
// luminance. The variance about the mean is the usual exponentially weighted one,
// var_m' = (1 - a) (var_m + a (x - mean)^2) (Finch 2009, "Incremental calculation of weighted
// mean and variance").
// The drift is the running mean of x - mean, with weight max(a, drift_alpha): zero on average
// for any stationary signal, however skewed (the mean is the running mean of x), and the
// mean's lag behind a trend otherwise (about slope / a). a = 1 restarts it at 0.
template <class D>
HWY_INLINE LumaMoments<D> update_luma_moments(D d, const LumaMoments<D>& m, V<D> x, V<D> var_s,
                                              V<D> a, float drift_alpha) {
  const auto step = hn::Sub(x, m.last);
  const auto keep = hn::Sub(hn::Set(d, 1.0f), a);
  const auto one = hn::Set(d, 1.0f);
  const auto a_drift =
      hn::IfThenElseZero(hn::Gt(a, hn::Zero(d)), hn::Max(a, hn::Set(d, drift_alpha)));
  const auto drift = hn::IfThenElseZero(
      hn::Lt(a, one), hn::MulAdd(a_drift, hn::Sub(hn::Sub(x, m.mean), m.drift), m.drift));
  return {hn::MulAdd(a, hn::Sub(x, m.mean), m.mean),
          hn::MulAdd(hn::Mul(hn::Mul(a, hn::Set(d, 0.5f)), step), step, hn::Mul(keep, m.var)),
          hn::IfThenElse(hn::Gt(a, hn::Zero(d)), x, m.last),  // a = 0: a held pixel keeps all
          hn::MulAdd(a, var_s, hn::Mul(keep, m.var_spatial)),
          hn::Mul(keep, hn::MulAdd(hn::Mul(a, hn::Sub(x, m.mean)), hn::Sub(x, m.mean), m.var_mean)),
          m.recent_motion,
          drift};
}

// The spread a drift is measured against: the successive-difference sigma plus the floors.
// Stationary, a drift of weight 1/8 has a standard deviation of about a quarter of it; a light
// ramping at rate r per frame gives a drift of about r / a_mean while the successive
// differences stay near r.
template <class D>
HWY_INLINE V<D> drift_spread(D d, const LumaMoments<D>& m, float rel_floor, float abs_floor) {
  return hn::Add(hn::Sqrt(hn::Max(m.var, hn::Zero(d))),
                 hn::MulAdd(hn::Set(d, rel_floor), hn::Abs(m.mean), hn::Set(d, abs_floor)));
}

// Whether the pixel's variation over time looks like jitter aliasing: white (or, with a
// low-discrepancy jitter sequence, anti-correlated) from frame to frame. The von Neumann ratio
// of the successive-difference variance to the variance about the mean is about 1 for
// independent samples and above 1 for anti-correlated ones; a coherent change has few large
// steps and a wide spread about the mean: a light blinking with period P frames gives 4 / P, a
// shadow sweeping over the pixel far less. 0 at ratio <= lo, 1 at ratio >= hi, linear between;
// a flat pixel (both variances under floor^2) counts as white.
template <class D>
HWY_INLINE V<D> temporal_whiteness(D d, const LumaMoments<D>& m, float lo, float hi, float floor) {
  const auto f2 = hn::Set(d, floor * floor);
  const auto num = hn::Add(hn::NegMulAdd(hn::Set(d, lo), m.var_mean, m.var), f2);
  const auto den = hn::MulAdd(hn::Set(d, hi - lo), m.var_mean, f2);
  // Blocks where every lane saturates (flat pixels, white or anti-correlated jitter: most of a
  // converged frame) skip the division with the same bits: for a positive den, num <= 0 gives a
  // quotient <= 0 (or NaN for -inf / inf), which saturate makes +0, and num >= den with den
  // finite a quotient >= 1, made exactly 1 (9cd7e5f; docs/perf/profile-taa-resolve.md).
  const auto pos = hn::Gt(den, hn::Zero(d));
  const auto sat1 = hn::And(hn::And(hn::Ge(num, den), hn::IsFinite(den)), pos);
  const auto sat0 = hn::And(hn::Le(num, hn::Zero(d)), pos);
  if (hn::AllTrue(d, hn::Or(sat1, sat0))) return hn::IfThenElseZero(sat1, hn::Set(d, 1.0f));
  return saturate(d, hn::Div(num, den));
}

// The temporal spread that may be blamed on aliasing: the successive-difference sigma,
// but no more than the neighbourhood has shown on average. A blinking panel's interior
// alternates over time in a flat neighbourhood, so its variance is a change, not aliasing;
// a thin pole's pixel alternates next to an edge that most frames' 3x3 windows contain.
template <class D>
HWY_INLINE V<D> aliasing_sigma(D d, const LumaMoments<D>& m) {
  return hn::Sqrt(hn::Max(hn::Min(m.var, m.var_spatial), hn::Zero(d)));
}

// Variance of the luma of n neighbourhood samples (two passes on deviations from the first,
// as variance_box_of).
template <class D>
HWY_INLINE V<D> neighborhood_luma_variance(D d, const V<D>* luma, int n) {
  auto sum = hn::Zero(d);
  for (int i = 1; i < n; ++i) sum = hn::Add(sum, hn::Sub(luma[i], luma[0]));
  const auto in = hn::Set(d, 1.0f / float(n));
  const auto mean_e = hn::Mul(sum, in);
  auto m2 = hn::Zero(d);
  for (int i = 0; i < n; ++i) {
    const auto c = hn::Sub(hn::Sub(luma[i], luma[0]), mean_e);
    m2 = hn::MulAdd(c, c, m2);
  }
  return hn::Mul(m2, in);
}

// How many standard deviations the sample x lies from the pixel's distribution. The spread
// adds this frame's spatial standard deviation of the 3x3 luma (sigma_s, weight beta): a
// sample that differs from its own neighbours (a thin pole hit at the center) is aliasing
// until proven otherwise, while a change inside a flat region (a shadow, a panel switching
// off) has sigma_s = 0 and is measured against the temporal spread alone. Its floor
// rel_floor * |mean| + abs_floor keeps a flat, noiseless pixel from calling a rounding
// difference a change.
template <class D>
HWY_INLINE V<D> luma_change_zscore(D d, V<D> x, const LumaMoments<D>& m, V<D> sigma_s, float beta,
                                   float rel_floor, float abs_floor) {
  const auto spread =
      hn::Add(hn::MulAdd(hn::Set(d, beta), sigma_s, aliasing_sigma(d, m)),
              hn::MulAdd(hn::Set(d, rel_floor), hn::Abs(m.mean), hn::Set(d, abs_floor)));
  return hn::Div(hn::Abs(hn::Sub(x, m.mean)), spread);
}

// The spread a neighbour's change is measured against, from its own moments: like
// luma_change_zscore's without the spatial term, with the aliasing spread counted only as far
// as the neighbour's variation is white. A neighbour that has switched with a blinking lamp
// before remembers those steps in its variance for many frames; they are coherent changes, not
// aliasing, so they must not widen the spread that tells the next switch. The resolver stores
// its reciprocal with the moments (one division per pixel instead of eight per neighbourhood).
template <class D>
HWY_INLINE V<D> neighbor_change_spread(D d, const LumaMoments<D>& m, const TaaSettings& s) {
  const auto white = temporal_whiteness(d, m, s.confidence_white_lo, s.confidence_white_hi,
                                        s.confidence_abs_floor);
  return hn::MulAdd(white, aliasing_sigma(d, m),
                    hn::MulAdd(hn::Set(d, s.confidence_rel_floor), hn::Abs(m.mean),
                               hn::Set(d, s.confidence_abs_floor)));
}

// 1 below z_lo standard deviations, 0 above z_hi, linear between.
template <class D>
HWY_INLINE V<D> confidence_from_zscore(D d, V<D> z, float z_lo, float z_hi) {
  return saturate(d, hn::Mul(hn::Sub(hn::Set(d, z_hi), z), hn::Set(d, 1.0f / (z_hi - z_lo))));
}

// 1 at rest, falling linearly to 0 at full_px pixels per frame: resampled history blurs and
// drifts with motion (Catmull-Rom is exact only at whole-pixel offsets), so moving content
// keeps the neighbourhood's rectification (FSR2 enlarges the box only at low motion).
template <class D>
HWY_INLINE V<D> confidence_from_speed(D d, V<D> speed, float full_px) {
  return saturate(d, hn::NegMulAdd(speed, hn::Set(d, 1.0f / full_px), hn::Set(d, 1.0f)));
}
template <class D>
HWY_INLINE V<D> confidence_from_motion(D d, V<D> mx, V<D> my, float full_px) {
  return confidence_from_speed(d, hn::Sqrt(hn::MulAdd(mx, mx, hn::Mul(my, my))), full_px);
}

// The largest nearby speed a pixel remembers: this frame's, or the remembered one decayed.
template <class D>
HWY_INLINE V<D> remembered_speed(D d, V<D> remembered, V<D> speed, float decay) {
  return hn::Max(speed, hn::Mul(remembered, hn::Set(d, decay)));
}

// What a pixel's 8 neighbours say, read from their stored moments without reprojection
// (confidence fades out by confidence_motion_px, half a pixel, so a neighbour read in place is
// at most half a pixel off its own history): the largest change z score (a
// blinking panel switches its whole interior, whose flat pixels see it at once, while the edge
// pixel's own spread, panel on or off through jitter, is as wide as aliasing) and the sums of
// their drifts and drift spreads. `load(plane, i)` reads neighbour i (core/neighborhood.h
// order) of a plane; the spreads were derived when the moments were stored
// (neighbor_change_spread's reciprocal, drift_spread). Non-finite values count for nothing.
template <class D>
struct NeighborEvidence {
  V<D> z_max, drift_sum, drift_spread_sum;
};
template <class D, class Load>
HWY_INLINE NeighborEvidence<D> neighbor_evidence(D d, const V<D> (&lumas)[9], Load&& load,
                                                 const float* mean, const float* drift,
                                                 const float* inv_spread,
                                                 const float* drift_spread_plane) {
  NeighborEvidence<D> e{hn::Zero(d), hn::Zero(d), hn::Zero(d)};
#pragma GCC unroll 8
  for (int i = 1; i < 9; ++i) {
    const auto zq = hn::Mul(hn::Abs(hn::Sub(lumas[i], load(mean, i))), load(inv_spread, i));
    e.z_max = hn::Max(e.z_max, hn::IfThenElseZero(hn::IsFinite(zq), zq));
    const auto dq = load(drift, i), sq = load(drift_spread_plane, i);
    const auto ok = hn::And(hn::IsFinite(dq), hn::IsFinite(sq));
    e.drift_sum = hn::Add(e.drift_sum, hn::IfThenElseZero(ok, dq));
    e.drift_spread_sum = hn::Add(e.drift_spread_sum, hn::IfThenElseZero(ok, sq));
  }
  return e;
}

// The luma moments stored for the pixel nearest (x, y) (the history position: a bilinear read
// beside an emitter's edge would mix in the edge pixel's variance), or a restart at this
// sample's luma where they are not finite or not `usable`; `ok` says which lanes kept them.
template <class D>
HWY_INLINE LumaMoments<D> fetch_luma_moments(D d,
                                             const reproject::Planes<kLumaMomentPlanes>& planes,
                                             V<D> x, V<D> y, V<D> luma_x, hn::Mask<D> usable,
                                             hn::Mask<D>& ok) {
  const reproject::Pixel<D, kLumaMomentPlanes> m = reproject::sample_point(d, planes, x, y);
  ok = usable;
  for (int c = 0; c < kLumaMomentPlanes; ++c) ok = hn::And(ok, hn::IsFinite(m.v[c]));
  return {hn::IfThenElse(ok, m.v[0], luma_x), hn::IfThenElseZero(ok, m.v[1]),
          hn::IfThenElse(ok, m.v[2], luma_x), hn::IfThenElseZero(ok, m.v[3]),
          hn::IfThenElseZero(ok, m.v[4]),     hn::IfThenElseZero(ok, m.v[5]),
          hn::IfThenElseZero(ok, m.v[6])};
}

// Stores the updated moments `m` with this frame's remembered speed, and the two spreads the
// neighbours' rules read (neighbor_change_spread's reciprocal, drift_spread), at offset `o`:
// derived once per pixel here instead of once per neighbour read.
template <class D>
HWY_INLINE void store_luma_moments(D d, const LumaMoments<D>& m, V<D> recent_motion,
                                   float* const* out_moments, float* const* out_spreads, size_t o,
                                   const TaaSettings& s) {
  const LumaMoments<D> stored{m.mean,     m.var,         m.last, m.var_spatial,
                              m.var_mean, recent_motion, m.drift};
  const V<D> planes[kLumaMomentPlanes] = {stored.mean,        stored.var,      stored.last,
                                          stored.var_spatial, stored.var_mean, stored.recent_motion,
                                          stored.drift};
  for (int c = 0; c < kLumaMomentPlanes; ++c) hn::StoreU(planes[c], d, out_moments[c] + o);
  hn::StoreU(hn::Div(hn::Set(d, 1.0f), neighbor_change_spread(d, stored, s)), d,
             out_spreads[0] + o);
  hn::StoreU(drift_spread(d, stored, s.confidence_rel_floor, s.confidence_abs_floor), d,
             out_spreads[1] + o);
}

// The confidence a pixel's own moments (read at its history position, valid where `valid`)
// give: the z score of this sample (confidence_z_lo..hi), the factor of the remembered 3x3
// speed (`from_speed`, confidence_from_speed) and the whiteness of its variation.
template <class D>
HWY_INLINE V<D> own_confidence(D d, V<D> luma_x, const LumaMoments<D>& moments, hn::Mask<D> valid,
                               V<D> sigma_spatial, V<D> from_speed, const TaaSettings& s) {
  auto z = luma_change_zscore(d, luma_x, moments, sigma_spatial, s.confidence_spatial,
                              s.confidence_rel_floor, s.confidence_abs_floor);
  z = hn::IfThenElse(valid, z, hn::Set(d, 1e30f));
  const auto conf =
      hn::Mul(confidence_from_zscore(d, z, s.confidence_z_lo, s.confidence_z_hi), from_speed);
  return hn::Mul(conf, temporal_whiteness(d, moments, s.confidence_white_lo, s.confidence_white_hi,
                                          s.confidence_abs_floor));
}

// own_confidence times what the neighbourhood's change withdraws: the neighbours' largest
// change z (confidence_neighbor_z, none at twice it) and the 3x3 drift against the 3x3 spread
// (confidence_drift_z). A lighting trend moves every pixel of the neighbourhood the same way,
// while aliasing's drifts, each zero on average, mostly cancel (one pixel's drift under Halton
// jitter is too noisy: static moire). Geometry rules are the caller's (TAA's depth / id tests).
// moments.recent_motion is updated with `speed`.
template <class D>
HWY_INLINE V<D> history_confidence(D d, V<D> luma_x, LumaMoments<D>& moments, hn::Mask<D> valid,
                                   V<D> sigma_spatial, const NeighborEvidence<D>& nb, V<D> speed,
                                   const TaaSettings& s) {
  moments.recent_motion =
      remembered_speed(d, moments.recent_motion, speed, s.confidence_motion_memory);
  const auto from_speed = confidence_from_speed(d, moments.recent_motion, s.confidence_motion_px);
  // Every factor is saturated to [+0, 1], so where the speed factor is +0 in every lane (moving
  // content: the bench frame's 0.7 px/frame pan) the product is +0 whatever the z scores and
  // the whiteness say: skip their 3 divisions and 2 square roots (same bits; fb2ca45).
  if (hn::AllTrue(d, hn::Eq(from_speed, hn::Zero(d)))) return hn::Zero(d);
  auto conf = own_confidence(d, luma_x, moments, valid, sigma_spatial, from_speed, s);
  conf = hn::Mul(conf, confidence_from_zscore(d, nb.z_max, s.confidence_neighbor_z,
                                              2.0f * s.confidence_neighbor_z));
  if (s.confidence_drift_z > 0.0f) {
    const auto zd =
        hn::Div(hn::Abs(hn::Add(nb.drift_sum, moments.drift)),
                hn::Add(nb.drift_spread_sum,
                        drift_spread(d, moments, s.confidence_rel_floor, s.confidence_abs_floor)));
    conf = hn::Mul(
        conf, confidence_from_zscore(d, zd, s.confidence_drift_z, 2.0f * s.confidence_drift_z));
  }
  return conf;
}

// The current color a pixel blends into its history (with blend_filtered and confidence): the
// raw sample where the history is fully trusted, the filtered color anywhere else. Still,
// trusted content then converges to the box-filtered pixel of an SSAA reference (the filtered
// color would set a blur floor), while partly trusted pixels do not add the raw sample's
// jitter noise. Chosen on the demo's tuning scenes (FLIP sum .1438 with a blend in proportion
// to the confidence, .1433 / .1426 / .1424 with its 4th / 32nd / 256th power, .1424 with this
// step; temporal error lower on six of seven; room's PSNR 39.22 -> 39.01 dB).
template <class D>
HWY_INLINE Color3<D> confident_blend_source(D d, const Color3<D>& raw, const Color3<D>& filtered,
                                            V<D> confidence) {
  return select<D>(hn::Ge(confidence, hn::Set(d, 1.0f)), raw, filtered);
}

// Fresh history (fresh_filter_sigma): after a reset (disocclusion, camera cut) the blend's
// 1/N box average rebuilds the history from a handful of jittered samples, and with the
// narrow current filter each of them moves the output by (x - mean) / N: visible shimmer for
// the first frames. The color shown blends a wider Gaussian, which changes less with the
// jitter, handed over to the current filter linearly as the frames kept (N - 1) reach
// `frames`; the history stored keeps the current filter's color, so none of the wider blur
// persists in it (blended into the history, it lingered for tens of frames where trust lowers
// alpha to 1/64, and cost a cold-started SVGF + TAA 0.7 dB). FSR 2's upsample pass likewise
// reshapes its reconstruction kernel for a new sample (bIsNewSample, fKernelBias).
template <class D>
HWY_INLINE V<D> fresh_filter_handover(D d, V<D> frames_kept, float frames) {
  return saturate(d, hn::Mul(frames_kept, hn::Set(d, 1.0f / frames)));
}

template <class D>
HWY_INLINE Color3<D> fresh_blend_source(D, const Color3<D>& wide, const Color3<D>& current,
                                        V<D> handover) {
  return {lerp<D>(wide.c0, current.c0, handover), lerp<D>(wide.c1, current.c1, handover),
          lerp<D>(wide.c2, current.c2, handover)};
}

// How far the neighbourhood box is widened on every side: k temporal standard deviations,
// scaled by confidence. A trusted pixel keeps a history that differs from this frame's
// neighbourhood by as much as its own samples differ over time (the thin pole absent from
// this frame), and no more, so a real change still gets clipped to within k sigma.
// The same, given aliasing_sigma(d, m) (the resolver has it from the confidence's z score).
template <class D>
HWY_INLINE V<D> box_relaxation(D d, V<D> sigma_alias, V<D> confidence, float k) {
  return hn::Mul(hn::Mul(confidence, hn::Set(d, k)), sigma_alias);
}
template <class D>
HWY_INLINE V<D> box_relaxation(D d, const LumaMoments<D>& m, V<D> confidence, float k) {
  return box_relaxation(d, aliasing_sigma(d, m), confidence, k);
}

// ----------------------------------------------------------------------------------------
// Current-frame filter (seed 003 "Filter Current Color")
// ----------------------------------------------------------------------------------------

// Filter weights of the 9 neighbours for this frame. The sample of neighbour (dx, dy) was
// taken at (dx + jitter.x, dy + jitter.y) relative to the output pixel center (DESIGN.md §3),
// so the weights depend on the actual sample distance, not the pixel distance; they are the
// same for every pixel of a frame. Unnormalised (normalised per pixel after luma weighting).
std::array<float, 9> current_filter_weights(CurrentFilter kind, float sigma, Vec2f jitter);

// The Mitchell-Netravali cubic k(x) with parameters (B, C) (Mitchell & Netravali, "Reconstruction
// Filters in Computer Graphics", SIGGRAPH 1988): B = 0, C = 0.5 is Catmull-Rom, B = C = 1/3 the
// recommended compromise between blur and ringing.
float mitchell_netravali(float x, float b, float c);

// ----------------------------------------------------------------------------------------
// History sampler (the gathers themselves are reproject/gather.h)
// ----------------------------------------------------------------------------------------

// The reproject sampler a TAA setting selects: static mode reads the nearest pixel (no
// resampling blur, seed 000), otherwise the configured filter.
inline reproject::HistoryFilter history_filter(HistorySampler sampler, bool static_mode) {
  if (static_mode) return reproject::HistoryFilter::Point;
  switch (sampler) {
    case HistorySampler::Bilinear:
      return reproject::HistoryFilter::Bilinear;
    case HistorySampler::CatmullRom5:
      return reproject::HistoryFilter::CatmullRom5;
    case HistorySampler::CatmullRom9:
      return reproject::HistoryFilter::CatmullRom9;
    case HistorySampler::Bicubic16:
      break;
  }
  return reproject::HistoryFilter::CatmullRom16;
}

}  // namespace afterimage::taa
