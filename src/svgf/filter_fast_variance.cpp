#include <cmath>

#include "svgf/filter_fast.h"

namespace afterimage::svgf::fast {

namespace {

// ---- Variance (Sec. 4.2) ----------------------------------------------------------------------

// The taps before the center of the largest window.
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
  const int w = depth.width(), h = depth.height();
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

}  // namespace afterimage::svgf::fast
