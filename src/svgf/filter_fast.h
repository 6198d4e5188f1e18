// The fast schedule of SVGF's spatial stages (filter.h), internal to the module: blocks of
// Highway lanes (svgf_kernels.h), the taps unrolled with compile-time offsets and kernel
// weights, blocks whose taps are all inside the image without border tests, the rows with
// subnormals flushed. Each computes what reference.h specifies, bit for bit (svgf_filter_test);
// the callers (filter.cpp) have checked the shapes.
#pragma once

#include <cstddef>
#include <type_traits>
#include <utility>

#include "core/image.h"
#include "core/parallel.h"
#include "svgf/filter.h"
#include "svgf/settings.h"
#include "svgf/svgf_kernels.h"

namespace afterimage::svgf::fast {

// filter.h's stages (filter_fast_variance.cpp, filter_fast_atrous.cpp,
// filter_fast_atrous_final.cpp).
void depth_gradient(const ImageF& depth, ImageF& out, const Exec& exec);
void estimate_variance(const Guide& g, const ImageF& moments, const ImageF& length,
                       const SvgfSettings& s, ImageF& variance, const Exec& exec);
void atrous_iteration(const Guide& g, const ImageF& color, const ImageF& variance, int step,
                      const SvgfSettings& s, ImageF& out_color, ImageF& out_variance,
                      const Exec& exec);
void atrous_iteration_remodulated(const Guide& g, const ImageF& color, const ImageF& variance,
                                  int step, const SvgfSettings& s, const RemodulationInputs& r,
                                  ImageF& out, ImageF* filtered, const Exec& exec);

// The largest spatial_radius (settings.cpp) estimate_variance supports.
inline constexpr int kMaxSpatialRadius = 8;

// ---- Blocks of lanes shared by the stages ----------------------------------------------------

// The lanes of a block at x, shifted by `ox` columns: one contiguous load when every shifted
// column is inside the image, else a gather of the clamped columns with a mask of the inside
// ones (whose weights the caller zeroes). Both give the same values, so the 1-lane and the
// full-width paths agree.
template <class D>
struct Columns {
  bool interior = true;
  VI<D> idx;
  hn::Mask<D> inside;
};
// kInside: the caller knows every shifted column is inside (an interior block), so the test and
// the mask fold away.
template <bool kInside, class D>
HWY_INLINE Columns<D> shifted_columns(D d, int x, int ox, int w) {
  Columns<D> c;
  if constexpr (kInside) return c;
  const int n = int(hn::Lanes(d));
  c.interior = x + ox >= 0 && x + ox + n <= w;
  if (!c.interior) {
    const hn::RebindToSigned<D> di;
    const auto xi = iota_from(di, x + ox);
    c.inside = hn::RebindMask(d, hn::And(hn::Gt(xi, hn::Set(di, -1)), hn::Lt(xi, hn::Set(di, w))));
    c.idx = hn::Min(hn::Max(xi, hn::Zero(di)), hn::Set(di, w - 1));
  } else {
    c.inside = hn::FirstN(d, size_t(n));
  }
  return c;
}
template <class D>
HWY_INLINE V<D> load_at(D d, const float* row, int x, int ox, const Columns<D>& c) {
  return c.interior ? hn::LoadU(d, row + x + ox) : hn::GatherIndex(d, row, c.idx);
}

// Geometry of one pixel block: depth, normal, depth gradient, and the depth term's eps.
template <class D>
struct Center {
  V<D> z, n[3], gx, gy, eps;
};
template <class D>
HWY_INLINE Center<D> load_center(D d, const Guide& g, size_t o, float depth_epsilon) {
  Center<D> c;
  c.z = hn::LoadU(d, g.depth->plane(0) + o);
  for (int k = 0; k < 3; ++k) c.n[k] = hn::LoadU(d, g.normal->plane(k) + o);
  c.gx = hn::LoadU(d, g.gradient->plane(0) + o);
  c.gy = hn::LoadU(d, g.gradient->plane(1) + o);
  // Relative eps (settings.h), floored so that a zero depth cannot make 0 / 0.
  c.eps = hn::Max(hn::Mul(c.z, hn::Set(d, depth_epsilon)), hn::Set(d, 1e-30f));
  return c;
}

// The paper's normal exponent is a compile-time constant in the kernels below (7 squarings,
// unrolled); any other value goes through normal_weight's loop. kNormalExp: the setting
// normal_exp, the normal term in the exponent (svgf_kernels.h normal_exponent).
inline constexpr int kUnrolledSigmaN = 128;
inline constexpr int kNormalExp = -1;

// Calls fn(signals, normal) with compile-time constants: S in {1, 2}, normal kNormalExp, 128 or
// 0 (= the power with the setting's sigma_n at run time).
template <class Fn>
void dispatch(int signals, const SvgfSettings& s, Fn&& fn) {
  using One = std::integral_constant<int, 1>;
  using Two = std::integral_constant<int, 2>;
  using Exp = std::integral_constant<int, kNormalExp>;
  using Fixed = std::integral_constant<int, kUnrolledSigmaN>;
  using Any = std::integral_constant<int, 0>;
  const auto with = [&](auto S) {
    if (s.normal_exp)
      fn(S, Exp{});
    else if (s.sigma_n == kUnrolledSigmaN)
      fn(S, Fixed{});
    else
      fn(S, Any{});
  };
  signals == 1 ? with(One{}) : with(Two{});
}

// Calls fn(radius) with the à-trous kernel's radius in steps as a compile-time constant.
template <class Fn>
void dispatch_kernel(const SvgfSettings& s, Fn&& fn) {
  if (s.atrous_kernel == AtrousKernel::Linear3x3)
    fn(std::integral_constant<int, 1>{});
  else
    fn(std::integral_constant<int, 2>{});
}

// The depth term's denominator sigma_z |grad z(p) . (ox, oy)| + eps (svgf_kernels.h).
template <class D>
HWY_INLINE V<D> depth_den(D d, const Center<D>& c, int ox, int oy, const SvgfSettings& s) {
  const auto gdot = hn::MulAdd(c.gx, hn::Set(d, float(ox)), hn::Mul(c.gy, hn::Set(d, float(oy))));
  return depth_denominator(d, gdot, s.sigma_z, c.eps);
}

// Depth exponent and normal weight of the tap at offset (ox, oy) pixels (row pointer offset
// `ro`), columns `cols`. With kNormalExp, ez is the depth plus the normal exponent (offset by
// `exp_offset`) and wn is not set.
template <int kSigmaN, class D>
HWY_INLINE void geometry_terms(D d, const Guide& g, const Center<D>& c, size_t ro, int x, int ox,
                               int oy, const Columns<D>& cols, const SvgfSettings& s, V<D>& ez,
                               V<D>& wn, const V<D>* den = nullptr, float exp_offset = 0.0f) {
  const auto zq = load_at(d, g.depth->plane(0) + ro, x, ox, cols);
  const auto nx = load_at(d, g.normal->plane(0) + ro, x, ox, cols);
  const auto ny = load_at(d, g.normal->plane(1) + ro, x, ox, cols);
  const auto nz = load_at(d, g.normal->plane(2) + ro, x, ox, cols);
  const auto dot = hn::MulAdd(c.n[0], nx, hn::MulAdd(c.n[1], ny, hn::Mul(c.n[2], nz)));
  ez = depth_exponent_over(d, c.z, zq, den ? *den : depth_den(d, c, ox, oy, s));
  if constexpr (kSigmaN == kNormalExp)
    ez = hn::Add(ez, normal_exponent(d, dot, float(s.sigma_n), exp_offset));
  else
    wn = normal_weight(d, dot, kSigmaN ? kSigmaN : s.sigma_n);
}

// ---- À-trous (Sec. 4.3) ------------------------------------------------------------------------

struct AtrousContext {
  const Guide* g;
  const SvgfSettings* s;
  int w, h, signals, step;
  const float* color[3 * kMaxSignals];
  const float* var[kMaxSignals];
  float* out_color[3 * kMaxSignals];  // not kFinal
  float* out_var[kMaxSignals];
  // kFinal: remodulation (filter.h RemodulationInputs) as raw planes.
  Remodulation factor[kMaxSignals];
  float albedo_epsilon;
  const float* emission[3];  // null: none
  const float* albedo[3];
  const float* in_color[3];
  float* out[3];
};

// The inputs every à-trous iteration reads (the outputs are the caller's).
inline AtrousContext atrous_context(const Guide& g, const ImageF& color, const ImageF& variance,
                                    int step, const SvgfSettings& s) {
  AtrousContext k{};
  k.g = &g;
  k.s = &s;
  k.w = color.width();
  k.h = color.height();
  k.signals = variance.channels();
  k.step = step;
  for (int sg = 0; sg < k.signals; ++sg) {
    for (int ch = 0; ch < 3; ++ch) k.color[3 * sg + ch] = color.plane(3 * sg + ch);
    k.var[sg] = variance.plane(sg);
  }
  return k;
}

// Remodulates the block at x of row y from the filtered signals in `rp` (3S row pointers,
// indexed by x) and stores the color. The operations and order of the separate pass it
// replaced, and, like it, run without FlushSubnormals (after the row's à-trous blocks): the same
// bits.
template <int S, class D>
HWY_INLINE void remodulate_block(D d, const AtrousContext& k, float* const* rp, int x, int y) {
  const size_t o = size_t(y) * size_t(k.w) + size_t(x);
  V<D> r[3];
  for (int ch = 0; ch < 3; ++ch) {
    auto sum = k.emission[ch] ? hn::LoadU(d, k.emission[ch] + o) : hn::Zero(d);
    for (int sg = 0; sg < S; ++sg) {
      auto v = hn::LoadU(d, rp[3 * sg + ch] + x);
      if (k.factor[sg] != Remodulation::One) {
        const auto a = hn::LoadU(d, k.albedo[ch] + o);
        v = hn::Mul(v, k.factor[sg] == Remodulation::Albedo
                           ? a
                           : demodulation_factor(d, a, k.albedo_epsilon));
      }
      sum = hn::Add(sum, v);
    }
    r[ch] = sum;
  }
  Color3<D> c{r[0], r[1], r[2]};
  const auto finite = all_finite(d, c);
  if (!hn::AllTrue(d, finite)) {  // rare: the input color is read only then
    const Color3<D> in{hn::LoadU(d, k.in_color[0] + o), hn::LoadU(d, k.in_color[1] + o),
                       hn::LoadU(d, k.in_color[2] + o)};
    c = select<D>(finite, c, in);
  }
  hn::StoreU(c.c0, d, k.out[0] + o);
  hn::StoreU(c.c1, d, k.out[1] + o);
  hn::StoreU(c.c2, d, k.out[2] + o);
}

// kR: the kernel's radius in steps (2: the paper's 5x5 B3, 1: the 3x3 linear B-spline;
// settings.h atrous_kernel). kFinal: the last iteration (atrous_iteration_remodulated): the
// filtered color goes to the row pointers `rp` (3S, indexed by x) for remodulate_block, and no
// variance is computed.
template <int S, int kSigmaN, int kR, bool kInside, bool kFinal, class D>
HWY_INLINE void atrous_block(D d, const AtrousContext& k, int x, int y,
                             float* const* rp = nullptr) {
  const SvgfSettings& s = *k.s;
  const int w = k.w, h = k.h;
  const size_t o = size_t(y) * size_t(w) + size_t(x);
  const Center<D> c = load_center(d, *k.g, o, s.depth_epsilon);

  // Luminance weight normalisation from the 3x3 Gaussian of the variance (Eq.二.3), over the
  // taps inside the image.
  V<D> lp[kMaxSignals], inv_phi[kMaxSignals], sum_w[kMaxSignals], sum_v[kMaxSignals];
  V<D> sum_c[3 * kMaxSignals];
  {
    V<D> gv[kMaxSignals], gw = hn::Zero(d);
    for (int sg = 0; sg < S; ++sg) gv[sg] = hn::Zero(d);
    for (int dy = -1; dy <= 1; ++dy) {
      const int yy = y + dy;
      if (!kInside && (yy < 0 || yy >= h)) continue;
      const size_t ro = size_t(yy) * size_t(w);
      for (int dx = -1; dx <= 1; ++dx) {
        const Columns<D> cols = shifted_columns<kInside>(d, x, dx, w);
        auto wt = hn::Set(d, gauss3_weight(dx, dy));
        if (!cols.interior) wt = hn::IfThenElseZero(cols.inside, wt);
        gw = hn::Add(gw, wt);
        for (int sg = 0; sg < S; ++sg)
          gv[sg] = hn::MulAdd(wt, load_at(d, k.var[sg] + ro, x, dx, cols), gv[sg]);
      }
    }
    const auto h0 = hn::Set(d, atrous_weight<kR>(0, 0));
    for (int sg = 0; sg < S; ++sg) {
      // Inside, gw is the sum of the nine dyadic weights, exactly 1, and x / 1 is x: the
      // division is skipped with the same bits.
      inv_phi[sg] = luminance_inv_phi(d, kInside ? gv[sg] : hn::Div(gv[sg], gw), s.sigma_l);
      Color3<D> cp{hn::LoadU(d, k.color[3 * sg] + o), hn::LoadU(d, k.color[3 * sg + 1] + o),
                   hn::LoadU(d, k.color[3 * sg + 2] + o)};
      lp[sg] = luminance(d, cp);
      // The center: w(p, p) = 1.
      sum_w[sg] = h0;
      sum_c[3 * sg] = hn::Mul(h0, cp.c0);
      sum_c[3 * sg + 1] = hn::Mul(h0, cp.c1);
      sum_c[3 * sg + 2] = hn::Mul(h0, cp.c2);
      if constexpr (!kFinal) sum_v[sg] = hn::Mul(hn::Mul(h0, h0), hn::LoadU(d, k.var[sg] + o));
    }
  }

  // The 24 (8) taps around the center, unrolled: offsets in units of the step and the kernel
  // weights are compile-time constants.
  constexpr int kSide = 2 * kR + 1, kTaps = kSide * kSide, kHalf = kTaps / 2;
  V<D> den[kHalf];
  const auto tap = [&](auto index) __attribute__((always_inline)) {
    constexpr int t = decltype(index)::value;
    constexpr int i = t % kSide - kR, j = t / kSide - kR;
    if constexpr (i != 0 || j != 0) {
      const int oy = j * k.step, yy = y + oy;
      const int ox = i * k.step;
      // Taps before the center compute the depth denominator, their mirrored taps after it
      // reuse it.
      if constexpr (t < kHalf) den[t] = depth_den(d, c, ox, oy, s);
      if (!kInside && (yy < 0 || yy >= h)) return;
      const size_t ro = size_t(yy) * size_t(w);
      const Columns<D> cols = shifted_columns<kInside>(d, x, ox, w);
      V<D> ez, wn;
      // normal_exp: h(q) enters the exponent as -ln h(q), so a tap's weight is one exp.
      geometry_terms<kSigmaN>(d, *k.g, c, ro, x, ox, oy, cols, s, ez, wn,
                              &den[t < kHalf ? t : kTaps - 1 - t], atrous_neg_log<kR>(i, j));
      if constexpr (kSigmaN != kNormalExp) {
        auto hw = hn::Set(d, atrous_weight<kR>(i, j));
        if (!cols.interior) hw = hn::IfThenElseZero(cols.inside, hw);
        wn = hn::Mul(wn, hw);
      }
      for (int sg = 0; sg < S; ++sg) {
        Color3<D> cq{load_at(d, k.color[3 * sg] + ro, x, ox, cols),
                     load_at(d, k.color[3 * sg + 1] + ro, x, ox, cols),
                     load_at(d, k.color[3 * sg + 2] + ro, x, ox, cols)};
        const auto el = luminance_exponent(d, lp[sg], luminance(d, cq), inv_phi[sg]);
        V<D> wt;  // h(q) w(p, q)
        if constexpr (kSigmaN == kNormalExp) {
          wt = edge_stopping_weight_exp(d, ez, el);
          if (!cols.interior) wt = hn::IfThenElseZero(cols.inside, wt);
        } else {
          wt = edge_stopping_weight(d, ez, el, wn);
        }
        sum_w[sg] = hn::Add(sum_w[sg], wt);
        sum_c[3 * sg] = hn::MulAdd(wt, cq.c0, sum_c[3 * sg]);
        sum_c[3 * sg + 1] = hn::MulAdd(wt, cq.c1, sum_c[3 * sg + 1]);
        sum_c[3 * sg + 2] = hn::MulAdd(wt, cq.c2, sum_c[3 * sg + 2]);
        if constexpr (!kFinal) {
          const auto vq = load_at(d, k.var[sg] + ro, x, ox, cols);
          sum_v[sg] = hn::MulAdd(hn::Mul(wt, wt), vq, sum_v[sg]);
        }
      }
    }
  };
  [&]<int... T>(std::integer_sequence<int, T...>) __attribute__((always_inline)) {
    (tap(std::integral_constant<int, T>{}), ...);
  }
  (std::make_integer_sequence<int, kTaps>{});
  if constexpr (kFinal) {
    for (int sg = 0; sg < S; ++sg) {
      const auto inv = hn::Div(hn::Set(d, 1.0f), sum_w[sg]);
      for (int ch = 0; ch < 3; ++ch)
        hn::StoreU(hn::Mul(sum_c[3 * sg + ch], inv), d, rp[3 * sg + ch] + x);
    }
  } else {
    for (int sg = 0; sg < S; ++sg) {
      const auto inv = hn::Div(hn::Set(d, 1.0f), sum_w[sg]);
      for (int ch = 0; ch < 3; ++ch)
        hn::StoreU(hn::Mul(sum_c[3 * sg + ch], inv), d, k.out_color[3 * sg + ch] + o);
      hn::StoreU(hn::Mul(sum_v[sg], hn::Mul(inv, inv)), d, k.out_var[sg] + o);
    }
  }
}

// Calls block(d, x, y, inside) over the image row by row (rows in parallel), `inside` a
// compile-time true for the full-width blocks whose taps are all inside the image (`margin`
// pixels from every border): those skip the border tests and masks (profile: ~5% of the
// à-trous CPU time). Each output pixel is a pure function of the inputs, so which path computes
// it changes no bit (svgf_filter_test). Tiling the sweep into 256x64 tiles for cache reuse was
// measured slower (the kernel is compute-bound, not memory-bound: docs/perf/2026-log.md).
//
// The rows run with subnormal floats flushed to 0 (core/simd.h
// FlushSubnormals). The power form of the normal weight multiplies an exp clamped near 2^-125
// by max(0, n.n')^sigma_n and h(q), so every tap stopped by depth or luminance made a
// subnormal weight and then subnormal products in the sums, each a microcode assist; with
// normal_exp the weight stays >= 2^-126 but its square (the variance sum) underflows. Flushed:
// svgf-paper à-trous CPU -40% at 1080p on the filter bench's frame, the afterimage preset's
// -28% on the stage bench's noisy frame (perf task-clock / alternating runs; demo figures in
// docs/perf/2026-log.md). A weight below 2^-126 against the center's 9/64 changes nothing visible.
template <class Block>
void for_each_block_of_row(const Exec& ex, int w, int h, int margin, int y, Block&& block) {
  const FlushSubnormals flush;
  const bool row_inside = y >= margin && y + margin < h;
  int x = 0;
  if (ex.simd) {
    const FullTag d;
    const int n = int(hn::Lanes(d));
    for (; x + n <= w; x += n) {
      if (row_inside && x >= margin && x + n + margin <= w)
        block(d, x, y, std::true_type{});
      else
        block(d, x, y, std::false_type{});
    }
  }
  const OneTag d1;
  for (; x < w; ++x) block(d1, x, y, std::false_type{});
}
template <class Block>
void for_each_block(const Exec& ex, int w, int h, int margin, Block&& block) {
  parallel_rows(ex, h, [&](int y) { for_each_block_of_row(ex, w, h, margin, y, block); });
}

}  // namespace afterimage::svgf::fast
