// Lane-templated twins of core/sampler.h: same formulas, evaluated for every lane of `d`
// with gathers. Each must agree with its scalar twin (tests/core_sampler_test.cpp).
#pragma once

#include "core/image.h"
#include "core/sampler.h"
#include "core/simd.h"

namespace afterimage {

// Flat index of the clamped pixel (ix, iy) for lane vectors of integer-valued floats.
template <class D>
inline hn::Vec<hn::RebindToSigned<D>> clamped_index(D d, const PlaneView& img, hn::Vec<D> ix,
                                                    hn::Vec<D> iy) {
  const hn::RebindToSigned<D> di;
  ix = hn::Min(hn::Max(ix, hn::Zero(d)), hn::Set(d, float(img.width - 1)));
  iy = hn::Min(hn::Max(iy, hn::Zero(d)), hn::Set(d, float(img.height - 1)));
  auto xi = hn::ConvertTo(di, ix), yi = hn::ConvertTo(di, iy);
  return hn::Add(hn::Mul(yi, hn::Set(di, img.width)), xi);
}

template <class D>
inline hn::Vec<D> load_clamped(D d, const PlaneView& img, hn::Vec<D> ix, hn::Vec<D> iy) {
  return hn::GatherIndex(d, img.data, clamped_index(d, img, ix, iy));
}

template <class D>
inline hn::Vec<D> sample_point(D d, const PlaneView& img, hn::Vec<D> x, hn::Vec<D> y) {
  return load_clamped(d, img, hn::Floor(x), hn::Floor(y));
}

template <class D>
inline hn::Vec<D> sample_bilinear(D d, const PlaneView& img, hn::Vec<D> x, hn::Vec<D> y) {
  const auto half = hn::Set(d, 0.5f), one = hn::Set(d, 1.0f);
  auto tx = hn::Sub(x, half), ty = hn::Sub(y, half);
  auto x0 = hn::Floor(tx), y0 = hn::Floor(ty);
  auto fx = hn::Sub(tx, x0), fy = hn::Sub(ty, y0);
  auto x1 = hn::Add(x0, one), y1 = hn::Add(y0, one);
  auto a = load_clamped(d, img, x0, y0), b = load_clamped(d, img, x1, y0);
  auto c = load_clamped(d, img, x0, y1), e = load_clamped(d, img, x1, y1);
  auto top = hn::MulAdd(hn::Sub(b, a), fx, a);
  auto bot = hn::MulAdd(hn::Sub(e, c), fx, c);
  return hn::MulAdd(hn::Sub(bot, top), fy, top);
}

template <class D>
struct CubicWeightsV {
  hn::Vec<D> w0, w1, w2, w3;
};
template <class D>
inline CubicWeightsV<D> catmull_rom_weights(D d, hn::Vec<D> f) {
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
  hn::Vec<D> tc0, tc12, tc3, w0, w12, w3;
};
template <class D>
inline CatmullRomAxis<D> catmull_rom_axis(D d, hn::Vec<D> p) {
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

template <class D>
inline hn::Vec<D> sample_catmull_rom_5(D d, const PlaneView& img, hn::Vec<D> x, hn::Vec<D> y) {
  auto ax = catmull_rom_axis(d, x), ay = catmull_rom_axis(d, y);
  auto cw0 = hn::Mul(ax.w12, ay.w0), cw1 = hn::Mul(ax.w0, ay.w12), cw2 = hn::Mul(ax.w12, ay.w12);
  auto cw3 = hn::Mul(ax.w3, ay.w12), cw4 = hn::Mul(ax.w12, ay.w3);
  auto s = hn::Mul(cw0, sample_bilinear(d, img, ax.tc12, ay.tc0));
  s = hn::MulAdd(cw1, sample_bilinear(d, img, ax.tc0, ay.tc12), s);
  s = hn::MulAdd(cw2, sample_bilinear(d, img, ax.tc12, ay.tc12), s);
  s = hn::MulAdd(cw3, sample_bilinear(d, img, ax.tc3, ay.tc12), s);
  s = hn::MulAdd(cw4, sample_bilinear(d, img, ax.tc12, ay.tc3), s);
  return hn::Div(s, hn::Add(hn::Add(hn::Add(cw0, cw1), hn::Add(cw2, cw3)), cw4));
}

template <class D>
inline hn::Vec<D> sample_catmull_rom_9(D d, const PlaneView& img, hn::Vec<D> x, hn::Vec<D> y) {
  auto ax = catmull_rom_axis(d, x), ay = catmull_rom_axis(d, y);
  const hn::Vec<D> px[3] = {ax.tc0, ax.tc12, ax.tc3}, wx[3] = {ax.w0, ax.w12, ax.w3};
  const hn::Vec<D> py[3] = {ay.tc0, ay.tc12, ay.tc3}, wy[3] = {ay.w0, ay.w12, ay.w3};
  auto s = hn::Zero(d);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i)
      s = hn::MulAdd(hn::Mul(wx[i], wy[j]), sample_bilinear(d, img, px[i], py[j]), s);
  return s;
}

}  // namespace afterimage
