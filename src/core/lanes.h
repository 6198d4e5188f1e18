// Lane types every per-pixel kernel shares (DESIGN.md §2 core/, §6 "per-pixel math written
// once, templated on the lane type"): a color is three lane vectors (RGB or YCoCg), a box is
// two colors. Functions are templated on a Highway descriptor `d`; they run full-width and
// at 1 lane (core/simd.h for_each_lane_block). Kernels are compiled with -ffp-contract=off
// (afterimage_exact_fp): every MulAdd here is written on purpose, and the order of the
// operations is part of the output (resolves are compared bit-exactly).
#pragma once

#include <cstddef>

#include "core/simd.h"

namespace afterimage {

template <class D>
using V = hn::Vec<D>;
template <class D>
using VI = hn::Vec<hn::RebindToSigned<D>>;  // flat pixel indices for gathers

// Enough room to store any vector of floats (AVX-512: 16 lanes).
constexpr size_t kMaxLanes = HWY_MAX_BYTES / sizeof(float);

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
// Operand order of Min/Max matters for NaN and signed zeros (x86 returns the second operand):
// keep it when moving code.
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
// Linear interpolation a + t (b - a). Call it as lerp<D>(...): core/math.h's scalar
// lerp<T> would otherwise match hn::Vec arguments through their operators (Mul then Add).
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

// Rec.709 luminance (DESIGN.md §3; scalar twin in core/color.h).
template <class D>
HWY_INLINE V<D> luminance(D d, const Color3<D>& rgb) {
  return hn::MulAdd(hn::Set(d, 0.2126f), rgb.c0,
                    hn::MulAdd(hn::Set(d, 0.7152f), rgb.c1, hn::Mul(hn::Set(d, 0.0722f), rgb.c2)));
}

// YCoCg (seed 003 RGB2YCoCg / YCoCg2RGB; Karis 2014): luma on its own axis, so a box in
// YCoCg is tight around neighbourhoods whose spread is mostly luma (scalar twin in
// core/color.h).
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
// Boxes (seed 000 "重影", seed 003 Color Clamping / Variance Clipping)
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
// Min/max box of n samples, accumulated in index order.
template <class D>
HWY_INLINE Aabb<D> minmax_box(const Color3<D>* s, int n) {
  Aabb<D> b = aabb_of_point(s[0]);
#pragma GCC unroll 9
  for (int i = 1; i < n; ++i) b = aabb_extend(b, s[i]);
  return b;
}

}  // namespace afterimage
