#include "svgf/filter.h"

#include <cmath>
#include <memory>
#include <type_traits>
#include <utility>

#include "core/error.h"
#include "svgf/svgf_kernels.h"

namespace afterimage::svgf {

namespace {

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
constexpr int kUnrolledSigmaN = 128;
constexpr int kNormalExp = -1;

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

void check_guide(const Guide& g, int w, int h) {
  AI_CHECK(g.depth && g.normal && g.gradient);
  AI_CHECK(g.depth->width() == w && g.depth->height() == h && g.depth->channels() == 1);
  AI_CHECK(g.normal->width() == w && g.normal->height() == h && g.normal->channels() == 3);
  AI_CHECK(g.gradient->width() == w && g.gradient->height() == h && g.gradient->channels() == 2);
}

// ---- Variance (Sec. 4.2) ----------------------------------------------------------------------

// The largest spatial_radius (settings.cpp) and its taps before the center.
constexpr int kMaxSpatialRadius = 8;
constexpr int kMaxVarianceHalfTaps =
    ((2 * kMaxSpatialRadius + 1) * (2 * kMaxSpatialRadius + 1) - 1) / 2;

struct VarianceContext {
  const Guide* g;
  const SvgfSettings* s;
  int w, h, signals;
  const float* mean[kMaxSignals];
  const float* var[kMaxSignals];
  const float* length;
  float* out[kMaxSignals];
};

// S signals, a compile-time constant so the per-signal sums stay in registers.
template <int S, int kSigmaN, bool kInside, class D>
HWY_INLINE void variance_block(D d, const VarianceContext& k, int x, int y) {
  const SvgfSettings& s = *k.s;
  const size_t o = size_t(y) * size_t(k.w) + size_t(x);
  const auto n = hn::LoadU(d, k.length + o);
  const auto spatial = hn::Lt(n, hn::Set(d, float(s.temporal_variance_frames)));
  V<D> result[kMaxSignals];
  for (int sg = 0; sg < S; ++sg) result[sg] = hn::LoadU(d, k.var[sg] + o);  // temporal
  if (!hn::AllFalse(d, spatial)) {
    // Spatial estimate: moments of the window, weighted; accumulated around this pixel's mean
    // (a per-pixel shift), so mu2 - mu1^2 of the window does not cancel catastrophically.
    const Center<D> c = load_center(d, *k.g, o, s.depth_epsilon);
    V<D> mp[kMaxSignals], sw = hn::Set(d, 1.0f), s1[kMaxSignals], s2[kMaxSignals];
    for (int sg = 0; sg < S; ++sg) {
      mp[sg] = hn::LoadU(d, k.mean[sg] + o);
      s1[sg] = hn::Zero(d);
      s2[sg] = result[sg];  // the center's own variance, weight 1
    }
    const int r = s.spatial_radius, side = 2 * r + 1, half = (side * side - 1) / 2;
    // The depth denominators of the taps before the center (row-major order), reused by their
    // mirrored taps after it (the same bits: svgf_kernels.h depth_denominator).
    V<D> den[kMaxVarianceHalfTaps];
    for (int dy = -r; dy <= r; ++dy) {
      const int yy = y + dy;
      if (!kInside && (yy < 0 || yy >= k.h)) continue;
      const size_t ro = size_t(yy) * size_t(k.w);
      for (int dx = -r; dx <= r; ++dx) {
        if (dx == 0 && dy == 0) continue;
        const int t = (dy + r) * side + (dx + r);
        V<D> dn;
        if (t < half) {
          dn = den[t] = depth_den(d, c, dx, dy, s);
        } else if (kInside || y - dy >= 0) {  // the mirrored tap's row was visited
          dn = den[side * side - 1 - t];
        } else {
          dn = depth_den(d, c, dx, dy, s);
        }
        const Columns<D> cols = shifted_columns<kInside>(d, x, dx, k.w);
        V<D> ez, wn;
        geometry_terms<kSigmaN>(d, *k.g, c, ro, x, dx, dy, cols, s, ez, wn, &dn);
        V<D> wt;
        if constexpr (kSigmaN == kNormalExp)
          wt = edge_stopping_weight_exp(d, ez, hn::Zero(d));
        else
          wt = edge_stopping_weight(d, ez, hn::Zero(d), wn);
        if (!cols.interior) wt = hn::IfThenElseZero(cols.inside, wt);
        sw = hn::Add(sw, wt);
        for (int sg = 0; sg < S; ++sg) {
          const auto dm = hn::Sub(load_at(d, k.mean[sg] + ro, x, dx, cols), mp[sg]);
          const auto vq = load_at(d, k.var[sg] + ro, x, dx, cols);
          s1[sg] = hn::MulAdd(wt, dm, s1[sg]);
          s2[sg] = hn::MulAdd(wt, hn::MulAdd(dm, dm, vq), s2[sg]);
        }
      }
    }
    const auto inv = hn::Div(hn::Set(d, 1.0f), sw);
    for (int sg = 0; sg < S; ++sg) {
      const auto m1 = hn::Mul(s1[sg], inv);
      const auto v = hn::Max(hn::Zero(d), hn::NegMulAdd(m1, m1, hn::Mul(s2[sg], inv)));
      result[sg] = hn::IfThenElse(spatial, v, result[sg]);
    }
  }
  for (int sg = 0; sg < S; ++sg) hn::StoreU(result[sg], d, k.out[sg] + o);
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

// One-sided differences a = v(+1) - v(0), b = v(0) - v(-1): their mean where they agree within
// a factor of 2 (a smooth surface), else the smaller in magnitude (a silhouette on one side).
// A non-finite difference (the image border passes infinity) leaves the other, or 0.
template <class D>
HWY_INLINE V<D> gradient_of(D d, V<D> a, V<D> b) {
  const auto two = hn::Set(d, 2.0f);
  const auto fa = hn::Abs(a), fb = hn::Abs(b);
  const auto agree = hn::And(hn::Le(fa, hn::Mul(two, fb)), hn::Le(fb, hn::Mul(two, fa)));
  auto r = hn::IfThenElse(agree, hn::Mul(hn::Set(d, 0.5f), hn::Add(a, b)),
                          hn::IfThenElse(hn::Lt(fa, fb), a, b));
  r = hn::IfThenElse(hn::IsFinite(b), r, a);
  return hn::IfThenElse(hn::IsFinite(a), r, hn::IfThenElseZero(hn::IsFinite(b), b));
}

}  // namespace

void depth_gradient(const ImageF& depth, ImageF& out, const Exec& exec) {
  AI_CHECK(depth.channels() == 1);
  const int w = depth.width(), h = depth.height();
  ensure_shape(out, w, h, 2);
  if (w == 0) return;
  parallel_rows(exec, h, [&](int y) {
    const float* r = depth.row(0, y);
    const float* up = y > 0 ? depth.row(0, y - 1) : nullptr;
    const float* dn = y + 1 < h ? depth.row(0, y + 1) : nullptr;
    float* gx = out.row(0, y);
    float* gy = out.row(1, y);
    // Lanes (was a scalar loop with branches, ~1.5% of the filter's CPU time at 1080p); the
    // first and last pixel of a row, whose missing neighbour is infinity, take the 1-lane path.
    const auto block = [&](auto d, int x) {
      const int n = int(hn::Lanes(d));
      const auto inf = hn::Set(d, INFINITY);
      const auto v = hn::LoadU(d, r + x);
      const auto right = x + n < w ? hn::LoadU(d, r + x + 1) : inf;
      const auto left = x > 0 ? hn::LoadU(d, r + x - 1) : inf;
      hn::StoreU(gradient_of(d, hn::Sub(right, v), hn::Sub(v, left)), d, gx + x);
      const auto below = dn ? hn::Sub(hn::LoadU(d, dn + x), v) : inf;
      const auto above = up ? hn::Sub(v, hn::LoadU(d, up + x)) : inf;
      hn::StoreU(gradient_of(d, below, above), d, gy + x);
    };
    block(OneTag{}, 0);
    int x = 1;
    if (exec.simd) {
      const FullTag d;
      for (const int n = int(hn::Lanes(d)); x + n < w; x += n) block(d, x);
    }
    for (; x < w; ++x) block(OneTag{}, x);
  });
}

void estimate_variance(const Guide& g, const ImageF& moments, const ImageF& length,
                       const SvgfSettings& s, ImageF& variance, const Exec& exec) {
  const int w = moments.width(), h = moments.height(), S = moments.channels() / 2;
  AI_CHECK(S >= 1 && S <= kMaxSignals && moments.channels() == 2 * S);
  AI_CHECK(length.width() == w && length.height() == h && length.channels() == 1);
  check_guide(g, w, h);
  AI_CHECK(s.spatial_radius >= 0 && s.spatial_radius <= kMaxSpatialRadius);
  ensure_shape(variance, w, h, S);
  VarianceContext k{&g, &s, w, h, S, {}, {}, length.plane(0), {}};
  for (int sg = 0; sg < S; ++sg) {
    k.mean[sg] = moments.plane(2 * sg);
    k.var[sg] = moments.plane(2 * sg + 1);
    k.out[sg] = variance.plane(sg);
  }
  dispatch(S, s, [&](auto signals, auto sigma_n) {
    for_each_block(exec, w, h, s.spatial_radius, [&](auto d, int x, int y, auto inside) {
      variance_block<decltype(signals)::value, decltype(sigma_n)::value, inside.value>(d, k, x, y);
    });
  });
}

namespace {
// The inputs every à-trous iteration reads (the outputs are the caller's).
AtrousContext atrous_context(const Guide& g, const ImageF& color, const ImageF& variance, int step,
                             const SvgfSettings& s) {
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
}  // namespace

void atrous_iteration(const Guide& g, const ImageF& color, const ImageF& variance, int step,
                      const SvgfSettings& s, ImageF& out_color, ImageF& out_variance,
                      const Exec& exec) {
  const int w = color.width(), h = color.height(), S = variance.channels();
  AI_CHECK(S >= 1 && S <= kMaxSignals && color.channels() == 3 * S);
  AI_CHECK(variance.width() == w && variance.height() == h);
  AI_CHECK(&out_color != &color && &out_variance != &variance && step >= 1);
  check_guide(g, w, h);
  ensure_shape(out_color, w, h, 3 * S);
  ensure_shape(out_variance, w, h, S);
  AtrousContext k = atrous_context(g, color, variance, step, s);
  for (int sg = 0; sg < S; ++sg) {
    for (int ch = 0; ch < 3; ++ch) k.out_color[3 * sg + ch] = out_color.plane(3 * sg + ch);
    k.out_var[sg] = out_variance.plane(sg);
  }
  dispatch(S, s, [&](auto signals, auto sigma_n) {
    dispatch_kernel(s, [&](auto radius) {
      constexpr int kR = decltype(radius)::value;
      // The taps reach kR steps; the 3x3 Gaussian 1 pixel.
      for_each_block(exec, w, h, kR * step, [&](auto d, int x, int y, auto inside) {
        atrous_block<decltype(signals)::value, decltype(sigma_n)::value, kR, inside.value, false>(
            d, k, x, y);
      });
    });
  });
}

void atrous_iteration_remodulated(const Guide& g, const ImageF& color, const ImageF& variance,
                                  int step, const SvgfSettings& s, const RemodulationInputs& r,
                                  ImageF& out, ImageF* filtered, const Exec& exec) {
  const int w = color.width(), h = color.height(), S = variance.channels();
  AI_CHECK(S >= 1 && S <= kMaxSignals && color.channels() == 3 * S);
  AI_CHECK(variance.width() == w && variance.height() == h);
  AI_CHECK(&out != &color && filtered != &color && filtered != &out && step >= 1);
  AI_CHECK(r.color && r.color->width() == w && r.color->height() == h && r.color->channels() == 3);
  for (const ImageF* p : {r.emission, r.albedo})
    AI_CHECK(!p || (p->width() == w && p->height() == h && p->channels() == 3));
  for (int sg = 0; sg < S; ++sg) AI_CHECK(r.factor[sg] == Remodulation::One || r.albedo);
  check_guide(g, w, h);
  ensure_shape(out, w, h, 3);
  if (filtered) ensure_shape(*filtered, w, h, 3 * S);
  AtrousContext k = atrous_context(g, color, variance, step, s);
  for (int sg = 0; sg < S; ++sg) k.factor[sg] = r.factor[sg];
  k.albedo_epsilon = r.albedo_epsilon;
  for (int ch = 0; ch < 3; ++ch) {
    k.emission[ch] = r.emission ? r.emission->plane(ch) : nullptr;
    k.albedo[ch] = r.albedo ? r.albedo->plane(ch) : nullptr;
    k.in_color[ch] = r.color->plane(ch);
    k.out[ch] = out.plane(ch);
  }
  // Per row: the à-trous blocks (subnormals flushed) write the filtered color to `filtered` or
  // to a row buffer (in L1 / L2: the full-image planes of the last iteration are neither written
  // nor read back), then the row is remodulated with the caller's floating-point mode.
  dispatch(S, s, [&](auto signals, auto sigma_n) {
    dispatch_kernel(s, [&](auto radius) {
      constexpr int kS = decltype(signals)::value, kR = decltype(radius)::value;
      parallel_rows(exec, h, [&](int y) {
        std::unique_ptr<float[]> buffer;
        float* rp[3 * kMaxSignals] = {};
        if (!filtered) buffer.reset(new float[size_t(3 * kS) * size_t(w)]);
        for (int ch = 0; ch < 3 * kS; ++ch)
          rp[ch] = filtered ? filtered->row(ch, y) : buffer.get() + size_t(ch) * size_t(w);
        for_each_block_of_row(exec, w, h, kR * step, y, [&](auto d, int x, int yy, auto inside) {
          atrous_block<kS, decltype(sigma_n)::value, kR, inside.value, true>(d, k, x, yy, rp);
        });
        for_each_lane_block(exec, w, [&](auto d, int x) { remodulate_block<kS>(d, k, rp, x, y); });
      });
    });
  });
}

}  // namespace afterimage::svgf
