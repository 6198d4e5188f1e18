#include "svgf/gradient.h"

#include <utility>

#include "core/error.h"
#include "core/lanes.h"
#include "core/simd.h"
#include "svgf/reference.h"
#include "svgf/svgf_kernels.h"

namespace afterimage::svgf {

namespace {

// Planes of the stratum image while filtering.
using enum reference::GradientPlane;
constexpr int kPlanes = kGradientPlanes;

// Stratum-plane values of lanes px + ox .. in row qy, and which lanes are inside [0, sw): a
// load inside the row, a gather of clamped columns at its ends.
template <class D>
HWY_INLINE V<D> stratum_load(D d, const ImageF& img, int plane, int qx, int qy, int sw) {
  const float* row = img.plane(plane) + size_t(qy) * size_t(sw);
  const int n = int(hn::Lanes(d));
  if (qx >= 0 && qx + n <= sw) return hn::LoadU(d, row + qx);
  const hn::RebindToSigned<D> di;
  const auto idx = hn::Min(hn::Max(iota_from(di, qx), hn::Zero(di)), hn::Set(di, sw - 1));
  return hn::GatherIndex(d, row, idx);
}

// One à-trous iteration over the strata for the lanes px.. of stratum row py: reference.h
// gradient_atrous_at in lanes, bit for bit (Sec. 4 of Schied et al. 2018: the sparse gradient
// filtered like SVGF's color, Eq. 2.2 edge stopping, over the samples' confidence). The weights
// are the filter's (svgf_kernels.h: depth over the plane's change across the tap's distance in
// full-resolution pixels, the normal power by squaring, exp_neg), with the luminance term
// relative to the guides' mean luminance (the guide is a 1-spp sample whose noise scales with
// its value).
template <class D>
HWY_INLINE void gradient_atrous_block(D d, const ImageF& src, ImageF& dst, const SvgfSettings& s,
                                      int px, int py, int step) {
  constexpr int kS = kGradientStratumSize;
  const int sw = src.width(), sh = src.height();
  const hn::RebindToSigned<D> di;
  auto at = [&](int plane, int ox, int qy) { return stratum_load(d, src, plane, px + ox, qy, sw); };
  const auto zp = at(kZ, 0, py), lp = at(kLum, 0, py);
  const V<D> np[3] = {at(kNx, 0, py), at(kNy, 0, py), at(kNz, 0, py)};
  const auto gxp = at(kGx, 0, py), gyp = at(kGy, 0, py);
  const auto eps = hn::Max(hn::Mul(zp, hn::Set(d, s.depth_epsilon)), hn::Set(d, 1e-30f));
  const auto zero = hn::Zero(d);
  auto sum_h = zero, sum_c = zero, sum_d = zero, sum_m = zero, sum_p = zero;
  for (int oy = -2; oy <= 2; ++oy) {
    const int qy = py + oy * step;
    if (qy < 0 || qy >= sh) continue;
    for (int ox = -2; ox <= 2; ++ox) {
      const int dxs = ox * step;
      // Lanes whose tap column lies outside the strata contribute nothing.
      const auto qx = iota_from(di, px + dxs);
      const auto inside =
          hn::RebindMask(d, hn::And(hn::Gt(qx, hn::Set(di, -1)), hn::Lt(qx, hn::Set(di, sw))));
      auto wgt = hn::Set(d, b3_weight(ox, oy));
      if (ox != 0 || oy != 0) {
        const auto offset = hn::MulAdd(gxp, hn::Set(d, float(dxs * kS)),
                                       hn::Mul(gyp, hn::Set(d, float(oy * step * kS))));
        const auto ez = depth_exponent(d, zp, at(kZ, dxs, qy), offset, s.sigma_z, eps);
        const auto dn =
            hn::MulAdd(np[0], at(kNx, dxs, qy),
                       hn::MulAdd(np[1], at(kNy, dxs, qy), hn::Mul(np[2], at(kNz, dxs, qy))));
        const auto lq = at(kLum, dxs, qy);
        const auto el =
            hn::Div(hn::Abs(hn::Sub(lp, lq)),
                    hn::MulAdd(hn::Set(d, s.sigma_l * 0.5f), hn::Add(lp, lq), hn::Set(d, 1e-4f)));
        wgt = hn::Mul(wgt, edge_stopping_weight(d, ez, el, normal_weight(d, dn, s.sigma_n)));
      }
      wgt = hn::IfThenElseZero(inside, wgt);
      const auto wc = hn::Mul(wgt, at(kConf, dxs, qy));
      sum_h = hn::Add(sum_h, wgt);
      sum_c = hn::Add(sum_c, wc);
      sum_d = hn::MulAdd(wc, at(kDelta, dxs, qy), sum_d);
      sum_m = hn::MulAdd(wc, at(kMax, dxs, qy), sum_m);
      sum_p = hn::MulAdd(wc, at(kPrev, dxs, qy), sum_p);
    }
  }
  const auto has_c = hn::Gt(sum_c, zero), has_h = hn::Gt(sum_h, zero);
  const auto safe_c = hn::IfThenElse(has_c, sum_c, hn::Set(d, 1.0f));
  const auto safe_h = hn::IfThenElse(has_h, sum_h, hn::Set(d, 1.0f));
  const size_t o = size_t(py) * size_t(sw) + size_t(px);
  hn::StoreU(hn::IfThenElseZero(has_c, hn::Div(sum_d, safe_c)), d, dst.plane(kDelta) + o);
  hn::StoreU(hn::IfThenElseZero(has_c, hn::Div(sum_m, safe_c)), d, dst.plane(kMax) + o);
  hn::StoreU(hn::IfThenElseZero(has_c, hn::Div(sum_p, safe_c)), d, dst.plane(kPrev) + o);
  hn::StoreU(hn::IfThenElseZero(has_h, hn::Div(sum_c, safe_h)), d, dst.plane(kConf) + o);
}

}  // namespace

void reconstruct_gradient(const ImageF& gradient, const Guide& g, const ImageF& luminance,
                          const SvgfSettings& s, ImageF& strata, ImageF& lambda, ImageF* relight,
                          const Exec& ex) {
  const int w = gradient.width(), h = gradient.height();
  AI_CHECK(gradient.channels() == 3 && g.depth && g.normal && g.gradient);
  AI_CHECK(g.depth->width() == w && g.depth->height() == h && luminance.width() == w &&
           luminance.height() == h);
  constexpr int kS = kGradientStratumSize;
  const int sw = (w + kS - 1) / kS, sh = (h + kS - 1) / kS;

  // Stratum samples and guides.
  ImageF a(sw, sh, kPlanes), b(sw, sh, kPlanes);
  parallel_rows(ex, sh, [&](int sy) {
    for (int sx = 0; sx < sw; ++sx) {
      int gx = std::min(w - 1, sx * kS + kS / 2), gy = std::min(h - 1, sy * kS + kS / 2);
      float delta = 0.0f, max = 0.0f, conf = 0.0f;
      for (int y = sy * kS; y < std::min(h, sy * kS + kS) && conf == 0.0f; ++y)
        for (int x = sx * kS; x < std::min(w, sx * kS + kS); ++x) {
          const float d = gradient.at(x, y, 0), m = gradient.at(x, y, 1), v = gradient.at(x, y, 2);
          if (gradient_sample_usable(d, m, v)) {
            delta = d;
            max = m;
            conf = 1.0f;
            gx = x;
            gy = y;
            break;
          }
        }
      a.at(sx, sy, kDelta) = delta;
      a.at(sx, sy, kMax) = max;
      a.at(sx, sy, kConf) = conf;
      a.at(sx, sy, kPrev) = gradient_sample_previous(delta, max);
      a.at(sx, sy, kZ) = g.depth->at(gx, gy, 0);
      for (int c = 0; c < 3; ++c) a.at(sx, sy, kNx + c) = g.normal->at(gx, gy, c);
      a.at(sx, sy, kGx) = g.gradient->at(gx, gy, 0);
      a.at(sx, sy, kGy) = g.gradient->at(gx, gy, 1);
      const float l = luminance.at(gx, gy, 0);
      a.at(sx, sy, kLum) = std::isfinite(l) ? std::max(0.0f, l) : 0.0f;
    }
  });
  // Guides are copied once; only delta, max and confidence change per iteration.
  for (int p = kZ; p < kPlanes; ++p)
    for (int y = 0; y < sh; ++y)
      for (int x = 0; x < sw; ++x) b.at(x, y, p) = a.at(x, y, p);

  ImageF* in = &a;
  ImageF* out = &b;
  for (int it = 0; it < s.gradient_iterations; ++it) {
    const int step = 1 << it;
    const ImageF& src = *in;
    ImageF& dst = *out;
    parallel_rows(ex, sh, [&](int py) {
      // As SVGF's à-trous (filter_fast.h for_each_block): stopped taps make subnormal weights.
      const FlushSubnormals flush;
      if (!ex.simd) {  // --simd off: the plain version
        for (int px = 0; px < sw; ++px) reference::gradient_atrous_at(src, dst, s, px, py, step);
        return;
      }
      for_each_lane_block(
          ex, sw, [&](auto d, int px) { gradient_atrous_block(d, src, dst, s, px, py, step); });
    });
    std::swap(in, out);
  }

  ensure_shape(strata, sw, sh, 5);
  for (int y = 0; y < sh; ++y)
    for (int x = 0; x < sw; ++x) {
      const float d = in->at(x, y, kDelta), m = in->at(x, y, kMax);
      strata.at(x, y, 0) = d;
      strata.at(x, y, 1) = m;
      strata.at(x, y, 2) = in->at(x, y, kConf);
      strata.at(x, y, 3) = gradient_lambda(d, m, s.gradient_scale);
      strata.at(x, y, 4) = gradient_relight(d, in->at(x, y, kPrev));
    }
  ensure_shape(lambda, w, h, 1);
  parallel_rows(ex, h, [&](int y) {
    for (int x = 0; x < w; ++x) lambda.at(x, y, 0) = strata.at(x / kS, y / kS, 3);
  });
  if (relight) {
    ensure_shape(*relight, w, h, 1);
    parallel_rows(ex, h, [&](int y) {
      for (int x = 0; x < w; ++x) relight->at(x, y, 0) = strata.at(x / kS, y / kS, 4);
    });
  }
}

}  // namespace afterimage::svgf
