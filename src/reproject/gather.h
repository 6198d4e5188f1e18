// History gathers: N float planes of one image (history color, moments, ...) resampled at
// lane positions (x, y) in pixel coordinates (DESIGN.md §3), clamped to the edge. One
// lane-templated implementation for any N; the scalar core/sampler.h is the readable
// reference every sampler is tested against per plane (tests/reproject_test.cpp).
// Seed 000 "重投影"/"模糊处理", seed 003 "History Filter". The 3-plane forms were
// taa_kernels.h's sample_history_*; the per-plane operations are unchanged (resolves stay
// bit-identical), including the operand order of Min/Max in the footprint boxes.
#pragma once

#include "core/image.h"
#include "core/lanes.h"
#include "reproject/footprint.h"

namespace afterimage::reproject {

// N planes of one image, read by gathers.
template <int N>
struct Planes {
  const float* p[N] = {};
  int width = 0, height = 0;
};
// Planes first .. first + N - 1 of `img`.
template <int N>
inline Planes<N> planes_of(const ImageF& img, int first = 0) {
  Planes<N> r;
  for (int c = 0; c < N; ++c) r.p[c] = img.plane(first + c);
  r.width = img.width();
  r.height = img.height();
  return r;
}

// N plane values for every lane, and a per-plane box of them.
template <class D, int N>
struct Pixel {
  V<D> v[N];
};
template <class D, int N>
struct PixelBox {
  Pixel<D, N> lo, hi;
};

// The 3-plane forms as the lane color types of core/lanes.h.
template <class D>
HWY_INLINE Color3<D> as_color3(const Pixel<D, 3>& p) {
  return {p.v[0], p.v[1], p.v[2]};
}
template <class D>
HWY_INLINE Aabb<D> as_aabb(const PixelBox<D, 3>& b) {
  return {as_color3(b.lo), as_color3(b.hi)};
}

// True if the lanes' flat indices are consecutive (idx[l] = idx[0] + l): the lanes then read
// one contiguous span, which a load fetches with the same values as a gather. Reprojection
// under smooth motion (camera pans, most of a frame) is consecutive almost everywhere; a
// gather costs several times a load. Always true for one lane.
template <class D>
HWY_INLINE bool consecutive(D, VI<D> idx) {
  const hn::RebindToSigned<D> di;
  return hn::AllTrue(di, hn::Eq(idx, iota_from(di, hn::GetLane(idx))));
}

// A lane block's flat indices with the consecutiveness test done once, for reading several
// planes at them (SVGF's reprojection taps read up to 12): each read_tap is then a load or a
// gather without testing again.
template <class D>
struct Tap {
  VI<D> idx;
  int first;
  bool consecutive;
};
template <class D>
HWY_INLINE Tap<hn::RebindToFloat<D>> make_tap(D d, VI<D> idx) {
  return {idx, hn::GetLane(idx), consecutive(d, idx)};
}
// Plane values at the tap's indices: a load when they are consecutive, else a gather.
template <class D, class T>
HWY_INLINE hn::Vec<D> read_tap(D d, const T* plane, const Tap<hn::RebindToFloat<D>>& t) {
  return t.consecutive ? hn::LoadU(d, plane + t.first) : hn::GatherIndex(d, plane, t.idx);
}

// Plane values at flat indices `idx` (valid indices): a load when they are consecutive.
template <class D, class T>
HWY_INLINE hn::Vec<D> gather_plane(D d, const T* plane, VI<D> idx) {
  return read_tap(d, plane, make_tap(d, idx));
}

template <class D, int N>
HWY_INLINE Pixel<D, N> gather(D d, const Planes<N>& img, VI<D> idx) {
  Pixel<D, N> r;
  if (consecutive(d, idx)) {
    const size_t i0 = size_t(hn::GetLane(idx));
    for (int c = 0; c < N; ++c) r.v[c] = hn::LoadU(d, img.p[c] + i0);
  } else {
    for (int c = 0; c < N; ++c) r.v[c] = hn::GatherIndex(d, img.p[c], idx);
  }
  return r;
}
template <class D, int N>
HWY_INLINE Pixel<D, N> pixel_lerp(const Pixel<D, N>& a, const Pixel<D, N>& b, V<D> t) {
  Pixel<D, N> r;
  for (int c = 0; c < N; ++c) r.v[c] = lerp<D>(a.v[c], b.v[c], t);
  return r;
}
template <class D, int N>
HWY_INLINE Pixel<D, N> pixel_min(const Pixel<D, N>& a, const Pixel<D, N>& b) {
  Pixel<D, N> r;
  for (int c = 0; c < N; ++c) r.v[c] = hn::Min(a.v[c], b.v[c]);
  return r;
}
template <class D, int N>
HWY_INLINE Pixel<D, N> pixel_max(const Pixel<D, N>& a, const Pixel<D, N>& b) {
  Pixel<D, N> r;
  for (int c = 0; c < N; ++c) r.v[c] = hn::Max(a.v[c], b.v[c]);
  return r;
}
// Box of four taps as min(min(a, b), min(c, e)) (this operand order; see core/lanes.h cmin).
template <class D, int N>
HWY_INLINE PixelBox<D, N> box_of_4(const Pixel<D, N>& a, const Pixel<D, N>& b, const Pixel<D, N>& c,
                                   const Pixel<D, N>& e) {
  return {pixel_min(pixel_min(a, b), pixel_min(c, e)), pixel_max(pixel_max(a, b), pixel_max(c, e))};
}

// ----------------------------------------------------------------------------------------
// Catmull-Rom weights (lane twins of core/sampler.h catmull_rom_weights / catmull_rom_taps)
// ----------------------------------------------------------------------------------------

template <class D>
struct CubicWeightsV {
  V<D> w0, w1, w2, w3;
};
template <class D>
HWY_INLINE CubicWeightsV<D> catmull_rom_weights(D d, V<D> f) {
  const auto c = hn::Set(d, 0.5f), two = hn::Set(d, 2.0f), three = hn::Set(d, 3.0f);
  auto f2 = hn::Mul(f, f), f3 = hn::Mul(f2, f);
  CubicWeightsV<D> w;
  w.w0 = hn::Sub(hn::Mul(c, hn::Sub(hn::Mul(two, f2), f3)), hn::Mul(c, f));
  w.w1 = hn::Add(hn::Sub(hn::Mul(hn::Sub(two, c), f3), hn::Mul(hn::Sub(three, c), f2)),
                 hn::Set(d, 1.0f));
  w.w2 =
      hn::Add(hn::Sub(hn::Mul(hn::Sub(three, hn::Mul(two, c)), f2), hn::Mul(hn::Sub(two, c), f3)),
              hn::Mul(c, f));
  w.w3 = hn::Mul(c, hn::Sub(f3, f2));
  return w;
}

// Merged-tap layout for one axis (see CatmullRomTaps in core/sampler.h).
template <class D>
struct CatmullRomAxis {
  V<D> tc0, tc12, tc3, w0, w12, w3;
};
template <class D>
HWY_INLINE CatmullRomAxis<D> catmull_rom_axis(D d, V<D> p) {
  const auto half = hn::Set(d, 0.5f), one = hn::Set(d, 1.0f);
  auto tc1 = hn::Add(hn::Floor(hn::Sub(p, half)), half);
  auto w = catmull_rom_weights(d, hn::Sub(p, tc1));
  CatmullRomAxis<D> a;
  a.w0 = w.w0;
  a.w12 = hn::Add(w.w1, w.w2);
  a.w3 = w.w3;
  a.tc0 = hn::Sub(tc1, one);
  a.tc3 = hn::Add(tc1, hn::Set(d, 2.0f));
  a.tc12 = hn::Add(tc1, hn::Div(w.w2, a.w12));
  return a;
}

// ----------------------------------------------------------------------------------------
// Samplers. `box`, if given, receives the min/max of the 2x2 texels around (x, y) (the
// bilinear footprint): clamping a bicubic result to it removes its ringing (anti-ringing).
// ----------------------------------------------------------------------------------------

// HLSL Load of the pixel containing (x, y): no resampling blur (seed 000, static scenes).
template <class D, int N>
HWY_INLINE Pixel<D, N> sample_point(D d, const Planes<N>& img, V<D> x, V<D> y,
                                    PixelBox<D, N>* box = nullptr) {
  Pixel<D, N> p = gather(d, img, nearest_pixel_index(d, img.width, img.height, x, y));
  if (box) *box = {p, p};
  return p;
}

// Bilinear fetch over a footprint (seed 000: Sample with a linear sampler).
template <class D, int N>
HWY_INLINE Pixel<D, N> sample_bilinear(D d, const Planes<N>& img, const Footprint<D>& f,
                                       PixelBox<D, N>* box = nullptr) {
  const Pixel<D, N> a = gather(d, img, f.i00), b = gather(d, img, f.i10);
  const Pixel<D, N> c = gather(d, img, f.i01), e = gather(d, img, f.i11);
  if (box) *box = box_of_4(a, b, c, e);
  Pixel<D, N> r;
  for (int k = 0; k < N; ++k) {
    auto top = hn::MulAdd(hn::Sub(b.v[k], a.v[k]), f.fx, a.v[k]);
    auto bot = hn::MulAdd(hn::Sub(e.v[k], c.v[k]), f.fx, c.v[k]);
    r.v[k] = hn::MulAdd(hn::Sub(bot, top), f.fy, top);
  }
  return r;
}
template <class D, int N>
HWY_INLINE Pixel<D, N> sample_bilinear(D d, const Planes<N>& img, V<D> x, V<D> y,
                                       PixelBox<D, N>* box = nullptr) {
  return sample_bilinear(d, img, bilinear_footprint(d, img.width, img.height, x, y), box);
}

// Sum of the footprint taps with the given weights (e.g. renormalize_weights over the taps
// that pass the consistency tests: SVGF / reverse reprojection cache).
template <class D, int N>
HWY_INLINE Pixel<D, N> sample_weighted(D d, const Planes<N>& img, const Footprint<D>& f,
                                       const TapWeights<D>& w) {
  const VI<D> taps[4] = {f.i00, f.i10, f.i01, f.i11};
  Pixel<D, N> r;
  for (int k = 0; k < N; ++k) r.v[k] = hn::Zero(d);
  for (int i = 0; i < 4; ++i) {
    const Pixel<D, N> t = gather(d, img, taps[i]);
    for (int k = 0; k < N; ++k) r.v[k] = hn::MulAdd(t.v[k], w.w[i], r.v[k]);
  }
  return r;
}

// Activision 5-tap Catmull-Rom (Filmic SMAA 2016; seed 003 SampleHistoryBicubic): the
// 9-tap layout without its corners, renormalised. On a GPU each tap is one bilinear fetch;
// here a fetch is a gather per texel, and the outer taps sit exactly on texel centers along
// one axis (their bilinear fraction there is 0), so the 5 taps read only 12 distinct texels:
// the 2x2 around (x, y) (center tap, also the anti-ringing box) and 2 texels per outer tap.
// Same weights and result as 5 bilinear fetches (20 gathers), with 12 gathers per plane.
template <class D, int N>
HWY_INLINE Pixel<D, N> sample_catmull_rom_5(D d, const Planes<N>& img, V<D> x, V<D> y,
                                            PixelBox<D, N>* box = nullptr) {
  const int w = img.width, h = img.height;
  const auto one = hn::Set(d, 1.0f), half = hn::Set(d, 0.5f);
  auto ax = catmull_rom_axis(d, x), ay = catmull_rom_axis(d, y);
  // Texel columns / rows -1, 0, 1, 2 around the cell; tc1 - 0.5 is the integer index of 0.
  const auto ix0 = hn::Sub(ax.tc0, half), iy0 = hn::Sub(ay.tc0, half);
  const V<D> cx[4] = {ix0, hn::Add(ix0, one), hn::Add(ix0, hn::Set(d, 2.0f)),
                      hn::Add(ix0, hn::Set(d, 3.0f))};
  const V<D> cy[4] = {iy0, hn::Add(iy0, one), hn::Add(iy0, hn::Set(d, 2.0f)),
                      hn::Add(iy0, hn::Set(d, 3.0f))};
  // Lanes of one row whose cells are consecutive along x and inside the image (smooth motion:
  // most of a frame): the 4x4 texels are contiguous spans, read with loads instead of 12
  // index computations and consecutiveness checks (the same values as the clamped gathers).
  const float x0 = hn::GetLane(ix0), y0 = hn::GetLane(iy0);
  const bool spans = x0 >= 0.0f && y0 >= 0.0f && x0 + float(hn::Lanes(d) + 2) <= float(w - 1) &&
                     y0 + 3.0f <= float(h - 1) && hn::AllTrue(d, hn::Eq(ix0, iota_from(d, x0))) &&
                     hn::AllTrue(d, hn::Eq(iy0, hn::Set(d, y0)));
  const size_t base = spans ? size_t(y0) * size_t(w) + size_t(x0) : 0;
  // Otherwise clamped column indices and row offsets, computed once for the 12 texels (the
  // same operations as clamped_pixel_index).
  const hn::RebindToSigned<D> di;
  VI<D> col[4], row[4];
  if (!spans)
    for (int i = 0; i < 4; ++i) {
      col[i] = hn::ConvertTo(di, hn::Min(hn::Max(cx[i], hn::Zero(d)), hn::Set(d, float(w - 1))));
      row[i] =
          hn::Mul(hn::ConvertTo(di, hn::Min(hn::Max(cy[i], hn::Zero(d)), hn::Set(d, float(h - 1)))),
                  hn::Set(di, w));
    }
  // Always inlined: as a call (GCC outlined it once the resolve kernel grew) each texel is
  // returned through the stack.
  auto texel = [&](int i, int j) __attribute__((always_inline)) {
    if (spans) {
      Pixel<D, N> p;
      const size_t at = base + size_t(j) * size_t(w) + size_t(i);
      for (int c = 0; c < N; ++c) p.v[c] = hn::LoadU(d, img.p[c] + at);
      return p;
    }
    return gather(d, img, hn::Add(row[j], col[i]));
  };
  // Fractions of the merged middle taps inside the cell (bilinear fx / fy of tc12).
  const auto fx = hn::Sub(hn::Sub(ax.tc12, half), cx[1]),
             fy = hn::Sub(hn::Sub(ay.tc12, half), cy[1]);
  const Pixel<D, N> t11 = texel(1, 1), t21 = texel(2, 1), t12 = texel(1, 2), t22 = texel(2, 2);
  if (box) *box = box_of_4(t11, t21, t12, t22);
  const Pixel<D, N> center = pixel_lerp(pixel_lerp(t11, t21, fx), pixel_lerp(t12, t22, fx), fy);
  const Pixel<D, N> up = pixel_lerp(texel(1, 0), texel(2, 0), fx);
  const Pixel<D, N> down = pixel_lerp(texel(1, 3), texel(2, 3), fx);
  const Pixel<D, N> left = pixel_lerp(texel(0, 1), texel(0, 2), fy);
  const Pixel<D, N> right = pixel_lerp(texel(3, 1), texel(3, 2), fy);
  auto cw0 = hn::Mul(ax.w12, ay.w0), cw1 = hn::Mul(ax.w0, ay.w12), cw2 = hn::Mul(ax.w12, ay.w12);
  auto cw3 = hn::Mul(ax.w3, ay.w12), cw4 = hn::Mul(ax.w12, ay.w3);
  auto inv = hn::Div(one, hn::Add(hn::Add(hn::Add(cw0, cw1), hn::Add(cw2, cw3)), cw4));
  Pixel<D, N> r;
  for (int k = 0; k < N; ++k) {
    auto s = hn::Mul(center.v[k], cw2);
    s = hn::MulAdd(up.v[k], cw0, s);
    s = hn::MulAdd(left.v[k], cw1, s);
    s = hn::MulAdd(right.v[k], cw3, s);
    s = hn::MulAdd(down.v[k], cw4, s);
    r.v[k] = hn::Mul(s, inv);
  }
  return r;
}

// MJP's 9-tap Catmull-Rom: 3x3 bilinear taps at tc0 / tc12 / tc3 of each axis (exact
// 16-tap Catmull-Rom away from the borders; seed 003 link).
template <class D, int N>
HWY_INLINE Pixel<D, N> sample_catmull_rom_9(D d, const Planes<N>& img, V<D> x, V<D> y,
                                            PixelBox<D, N>* box = nullptr) {
  const int w = img.width, h = img.height;
  auto ax = catmull_rom_axis(d, x), ay = catmull_rom_axis(d, y);
  const V<D> px[3] = {ax.tc0, ax.tc12, ax.tc3}, wx[3] = {ax.w0, ax.w12, ax.w3};
  const V<D> py[3] = {ay.tc0, ay.tc12, ay.tc3}, wy[3] = {ay.w0, ay.w12, ay.w3};
  Pixel<D, N> s;
  for (int k = 0; k < N; ++k) s.v[k] = hn::Zero(d);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) {
      PixelBox<D, N>* b = (i == 1 && j == 1) ? box : nullptr;
      const Pixel<D, N> t = sample_bilinear(d, img, bilinear_footprint(d, w, h, px[i], py[j]), b);
      const auto wij = hn::Mul(wx[i], wy[j]);
      for (int k = 0; k < N; ++k) s.v[k] = hn::MulAdd(t.v[k], wij, s.v[k]);
    }
  return s;
}

// Full 16-tap Catmull-Rom bicubic (Keys a = -0.5): the reference of the two above.
template <class D, int N>
HWY_INLINE Pixel<D, N> sample_catmull_rom_16(D d, const Planes<N>& img, V<D> x, V<D> y,
                                             PixelBox<D, N>* box = nullptr) {
  const auto half = hn::Set(d, 0.5f);
  auto tx = hn::Sub(x, half), ty = hn::Sub(y, half);
  auto x0 = hn::Floor(tx), y0 = hn::Floor(ty);
  auto wx4 = catmull_rom_weights(d, hn::Sub(tx, x0)), wy4 = catmull_rom_weights(d, hn::Sub(ty, y0));
  const V<D> wx[4] = {wx4.w0, wx4.w1, wx4.w2, wx4.w3}, wy[4] = {wy4.w0, wy4.w1, wy4.w2, wy4.w3};
  Pixel<D, N> s;
  for (int k = 0; k < N; ++k) s.v[k] = hn::Zero(d);
  Pixel<D, N> inner[4];
  int n_inner = 0;
  for (int j = 0; j < 4; ++j) {
    auto yy = hn::Add(y0, hn::Set(d, float(j - 1)));
    Pixel<D, N> row;
    for (int k = 0; k < N; ++k) row.v[k] = hn::Zero(d);
    for (int i = 0; i < 4; ++i) {
      auto xx = hn::Add(x0, hn::Set(d, float(i - 1)));
      const Pixel<D, N> t = gather(d, img, clamped_pixel_index(d, img.width, img.height, xx, yy));
      if ((i == 1 || i == 2) && (j == 1 || j == 2)) inner[n_inner++] = t;
      for (int k = 0; k < N; ++k) row.v[k] = hn::MulAdd(t.v[k], wx[i], row.v[k]);
    }
    for (int k = 0; k < N; ++k) s.v[k] = hn::MulAdd(row.v[k], wy[j], s.v[k]);
  }
  if (box) {
    // Accumulated in tap order (min(min(min(t11, t21), t12), t22)), as before the move.
    PixelBox<D, N> b{inner[0], inner[0]};
    for (int i = 1; i < 4; ++i) b = {pixel_min(b.lo, inner[i]), pixel_max(b.hi, inner[i])};
    *box = b;
  }
  return s;
}

// The history samplers by kind, for callers that pick one per pass.
enum class HistoryFilter { Point, Bilinear, CatmullRom5, CatmullRom9, CatmullRom16 };

template <class D, int N>
HWY_INLINE Pixel<D, N> sample_history(D d, HistoryFilter kind, const Planes<N>& img, V<D> x, V<D> y,
                                      PixelBox<D, N>* box = nullptr) {
  switch (kind) {
    case HistoryFilter::Point:
      return sample_point(d, img, x, y, box);
    case HistoryFilter::Bilinear:
      return sample_bilinear(d, img, x, y, box);
    case HistoryFilter::CatmullRom5:
      return sample_catmull_rom_5(d, img, x, y, box);
    case HistoryFilter::CatmullRom9:
      return sample_catmull_rom_9(d, img, x, y, box);
    case HistoryFilter::CatmullRom16:
      break;
  }
  return sample_catmull_rom_16(d, img, x, y, box);
}

}  // namespace afterimage::reproject
