#include "svgf/history_clamp.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "core/neighborhood.h"
#include "svgf/reference.h"
#include "svgf/svgf_kernels.h"

namespace afterimage::svgf {

namespace {

// Index x + dx mirrored at the image border without repeating the edge pixel (-1 -> 1,
// n -> n - 2), so a pixel's neighbours never include itself; clamped for 1-pixel images.
int mirror(int i, int n) {
  if (i < 0) i = -i;
  if (i > n - 1) i = 2 * (n - 1) - i;
  return std::clamp(i, 0, n - 1);
}

// Lanes x + dx .. of `row`, mirrored at the border (a gather of mirrored indices there).
template <class D>
HWY_INLINE V<D> load_row_mirrored(D d, const float* row, int x, int dx, int width) {
  const int n = int(hn::Lanes(d));
  const int xs = x + dx;
  if (xs >= 0 && xs + n <= width) return hn::LoadU(d, row + xs);
  const hn::RebindToSigned<D> di;
  auto idx = hn::Abs(iota_from(di, xs));
  idx = hn::Min(idx, hn::Sub(hn::Set(di, 2 * (width - 1)), idx));
  idx = hn::Min(hn::Max(idx, hn::Zero(di)), hn::Set(di, width - 1));
  return hn::GatherIndex(d, row, idx);
}

}  // namespace

void demodulate_and_clamp_fireflies(const SignalInputs& in, int rank, ImageF& out, ImageF& lum,
                                    const Exec& ex) {
  if (!ex.simd) return reference::demodulate_and_clamp_fireflies(in, rank, out, lum, ex);
  const int w = in.w, h = in.h, S = in.signals;
  ensure_shape(out, w, h, 3 * S);
  ensure_shape(lum, w, h, S);
  // Pass 1: demodulate (the operations of SvgfDenoiser's step 2) and take the luminance.
  parallel_rows(ex, h, [&](int y) {
    for_each_lane_block(ex, w, [&](auto d, int x) {
      const size_t o = size_t(y) * size_t(w) + size_t(x);
      const auto zero = hn::Zero(d);
      for (int sg = 0; sg < S; ++sg) {
        V<decltype(d)> c[3];
        for (int ch = 0; ch < 3; ++ch) {
          c[ch] = hn::LoadU(d, in.signal[3 * sg + ch] + o);
          if (in.subtract_emission && in.emission[ch])
            c[ch] = hn::Max(hn::Sub(c[ch], hn::LoadU(d, in.emission[ch] + o)), zero);
          if (in.demodulate)
            c[ch] = hn::Div(
                c[ch], demodulation_factor(d, hn::LoadU(d, in.albedo[ch] + o), in.albedo_epsilon));
          hn::StoreU(c[ch], d, out.plane(3 * sg + ch) + o);
        }
        hn::StoreU(luminance(d, Color3<decltype(d)>{c[0], c[1], c[2]}), d, lum.plane(sg) + o);
      }
    });
  });
  if (rank <= 0) return;
  // Pass 2: scale each pixel whose luminance exceeds the k-th largest of its neighbours'. It
  // reads only `lum`, so `out` is changed in place.
  const int k = std::clamp(rank, 1, 8);
  parallel_rows(ex, h, [&](int y) {
    const size_t rows[3] = {size_t(mirror(y - 1, h)) * size_t(w), size_t(y) * size_t(w),
                            size_t(mirror(y + 1, h)) * size_t(w)};
    for_each_lane_block(ex, w, [&](auto d, int x) {
      const size_t o = size_t(y) * size_t(w) + size_t(x);
      for (int sg = 0; sg < S; ++sg) {
        const float* l = lum.plane(sg);
        V<decltype(d)> nb[8];
        int n = 0;
        for (int i = 1; i < 9; ++i)  // the 8 neighbours, kNeighborDx/Dy order
          nb[n++] = load_row_mirrored(d, l + rows[kNeighborDy[i] + 1], x, kNeighborDx[i], w);
        sort8<decltype(d)>(nb);
        const auto scale = firefly_scale(d, hn::LoadU(d, l + o), nb[8 - k]);
        for (int ch = 0; ch < 3; ++ch) {
          float* p = out.plane(3 * sg + ch) + o;
          hn::StoreU(hn::Mul(hn::LoadU(d, p), scale), d, p);
        }
      }
    });
  });
}

void clamp_history_to_fast_box(const ImageF& fast, const ImageF& long_prev, const ImageF& alpha,
                               float sigma, int radius, ImageF& acc, const Exec& ex) {
  if (!ex.simd)
    return reference::clamp_history_to_fast_box(fast, long_prev, alpha, sigma, radius, acc, ex);
  const int w = acc.width(), h = acc.height(), planes = acc.channels();
  const int r = std::max(radius, 0);
  const float inv_count = 1.0f / float((2 * r + 1) * (2 * r + 1));
  parallel_rows(ex, h, [&](int y) {
    for_each_lane_block(ex, w, [&](auto d, int x) {
      const size_t o = size_t(y) * size_t(w) + size_t(x);
      const auto zero = hn::Zero(d), inv_n = hn::Set(d, inv_count);
      const auto a = hn::LoadU(d, alpha.plane(0) + o);
      const auto no_history = hn::Ge(a, hn::Set(d, 1.0f));
      for (int p = 0; p < planes; ++p) {
        const float* f = fast.plane(p);
        // Two passes over the window (mean, then squared deviations): no cancellation of
        // mu2 - mu1^2 at high luminance.
        auto sum = zero;
        for (int dy = -r; dy <= r; ++dy) {
          const float* row = f + size_t(std::clamp(y + dy, 0, h - 1)) * size_t(w);
          for (int dx = -r; dx <= r; ++dx)
            sum = hn::Add(sum, load_row_strided(d, row, x, dx, 1, w));
        }
        const auto mean = hn::Mul(sum, inv_n);
        auto dev = zero;
        for (int dy = -r; dy <= r; ++dy) {
          const float* row = f + size_t(std::clamp(y + dy, 0, h - 1)) * size_t(w);
          for (int dx = -r; dx <= r; ++dx) {
            const auto e = hn::Sub(load_row_strided(d, row, x, dx, 1, w), mean);
            dev = hn::MulAdd(e, e, dev);
          }
        }
        const auto sd = hn::Sqrt(hn::Mul(dev, inv_n));
        const auto prev =
            clamp_to_deviation_box(d, hn::LoadU(d, long_prev.plane(p) + o), mean, sd, sigma);
        float* c = acc.plane(p) + o;
        const auto cur = hn::LoadU(d, c);
        hn::StoreU(hn::IfThenElse(no_history, cur, accumulate(d, prev, cur, a)), d, c);
      }
    });
  });
}

double frame_time_step(double time, double prev_time, float fallback_fps) {
  const double dt = time - prev_time;
  if (std::isfinite(dt) && dt > 0.0) return dt;
  return 1.0 / double(fallback_fps);
}

float alpha_for_time_constant(double dt, double tau) {
  return float(std::clamp(-std::expm1(-dt / tau), 0.001, 1.0));
}

int history_cap_for_seconds(double dt, double seconds) {
  return int(std::clamp(std::round(seconds / dt), 1.0, 1024.0));
}

SvgfSettings settings_at_time_step(const SvgfSettings& s, double dt) {
  SvgfSettings r = s;
  if (s.alpha_seconds > 0.0f) r.alpha_min = alpha_for_time_constant(dt, s.alpha_seconds);
  if (s.moments_alpha_seconds > 0.0f)
    r.moments_alpha_min = alpha_for_time_constant(dt, s.moments_alpha_seconds);
  if (s.history_cap_seconds > 0.0f)
    r.history_cap = history_cap_for_seconds(dt, s.history_cap_seconds);
  return r;
}

}  // namespace afterimage::svgf
