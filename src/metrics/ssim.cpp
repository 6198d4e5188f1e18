#include "metrics/ssim.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/error.h"
#include "core/image.h"
#include "core/simd.h"

namespace afterimage::metrics {

void SsimSettings::validate() const {
  if (!(sigma > 0.0) || !(truncate > 0.0) || !(data_range > 0.0) || !(k1 >= 0.0) || !(k2 >= 0.0))
    throw SettingsError(fmt::format(
        "ssim: sigma, truncate and data_range must be > 0 and K1, K2 >= 0 (got sigma={} "
        "truncate={} data_range={} K1={} K2={})",
        sigma, truncate, data_range, k1, k2));
}

int SsimSettings::radius() const {
  return int(truncate * sigma + 0.5);
}

namespace {

// Normalised Gaussian taps exp(-x^2 / (2 sigma^2)), x in [-r, r] (scipy.ndimage's kernel).
std::vector<double> gaussian_taps(double sigma, int r) {
  std::vector<double> t(size_t(2 * r + 1));
  double sum = 0.0;
  for (int i = -r; i <= r; ++i) sum += t[size_t(i + r)] = std::exp(-0.5 * i * i / (sigma * sigma));
  for (double& v : t) v /= sum;
  return t;
}

// Mirror index with the edge sample repeated (d c b a | a b c d | d c b a), scipy "reflect".
int reflect_index(int i, int n) {
  if (n == 1) return 0;
  while (i < 0 || i >= n) i = i < 0 ? -i - 1 : 2 * n - i - 1;
  return i;
}

// Calls body(d, x, blocks) over [0, width) in blocks of double lanes: two vectors a call
// (blocks: std::integral_constant<int, 2>) while they fit, then one, then single lanes (only
// those with --simd off). Each of SSIM's sums is a chain of 2r + 1 dependent adds; two blocks
// a call give the core twice the independent chains (-25 to -35% on top of the lanes).
template <class Body>
void for_each_double_blocks(const Exec& ex, int width, Body&& body) {
  int x = 0;
  if (ex.simd) {
    const hn::ScalableTag<double> d;
    const int n = int(hn::Lanes(d));
    for (; x + 2 * n <= width; x += 2 * n) body(d, x, std::integral_constant<int, 2>{});
    for (; x + n <= width; x += n) body(d, x, std::integral_constant<int, 1>{});
  }
  const hn::CappedTag<double, 1> d1;
  for (; x < width; ++x) body(d1, x, std::integral_constant<int, 1>{});
}

// sum[b][c] = sum over k of taps[k] * (the lanes at at(k, c) + b vectors), in k order: each
// lane the scalar sum's multiplies and adds (no FMA contraction here), so the same bits at
// every width.
template <int kBlocks, class D, class At>
HWY_INLINE void tap_sums(D d, const std::vector<double>& taps, At&& at,
                         hn::Vec<D> (&sum)[kBlocks][5]) {
  const size_t n = hn::Lanes(d);
  for (auto& b : sum)
    for (auto& v : b) v = hn::Zero(d);
  for (size_t k = 0; k < taps.size(); ++k) {
    const hn::Vec<D> t = hn::Set(d, taps[k]);
    for (int b = 0; b < kBlocks; ++b)
      for (int c = 0; c < 5; ++c)
        sum[b][c] = hn::Add(sum[b][c], hn::Mul(t, hn::LoadU(d, at(k, c) + b * n)));
  }
}

// Gaussian-filtered local statistics of a pair: E[a], E[b], E[a^2], E[b^2], E[ab].
struct Moments {
  int w = 0, h = 0;
  std::vector<double, DefaultInitAllocator<double>> plane[5];  // every value written once
};

// Horizontal pass of the five moments for every row. Pixels run on double lanes, each lane
// the scalar sum's operations in its order (this file is compiled without FMA contraction):
// the same bits at every width and with --simd off. The products a^2, b^2, ab of each
// padded sample are formed once a row instead of once a tap (the same values).
Moments horizontal_moments(PlaneView a, PlaneView b, const std::vector<double>& taps,
                           const Exec& ex) {
  const int w = a.width, h = a.height, r = int(taps.size() / 2);
  Moments m;
  m.w = w;
  m.h = h;
  for (auto& p : m.plane) p.resize(size_t(w) * h);
  parallel_rows(ex, h, [&](int y) {
    const size_t n = size_t(w + 2 * r);
    std::vector<double> pad(5 * n);  // a, b, a^2, b^2, ab
    double* src[5] = {pad.data(), pad.data() + n, pad.data() + 2 * n, pad.data() + 3 * n,
                      pad.data() + 4 * n};
    for (int i = -r; i < w + r; ++i) {
      const int xi = reflect_index(i, w);
      const double va = a.at(xi, y), vb = b.at(xi, y);
      const size_t j = size_t(i + r);
      src[0][j] = va;
      src[1][j] = vb;
      src[2][j] = va * va;
      src[3][j] = vb * vb;
      src[4][j] = va * vb;
    }
    const size_t row = size_t(y) * w;
    for_each_double_blocks(ex, w, [&](auto d, int x, auto blocks) {
      using VD = hn::Vec<decltype(d)>;
      constexpr int kBlocks = decltype(blocks)::value;
      const size_t n = hn::Lanes(d);
      VD sum[kBlocks][5];
      tap_sums<kBlocks>(
          d, taps, [&](size_t k, int c) { return src[c] + size_t(x) + k; }, sum);
      for (int b = 0; b < kBlocks; ++b)
        for (int c = 0; c < 5; ++c)
          hn::StoreU(sum[b][c], d, m.plane[c].data() + row + size_t(x) + b * n);
    });
  });
  return m;
}

// Vertical pass for rows [y0, y1), then SSIM per pixel [Wang et al. eq. 13] with population
// covariances: S = (2 mu_a mu_b + C1)(2 cov + C2) / ((mu_a^2 + mu_b^2 + C1)(var_a + var_b + C2)).
// out: (y1 - y0) rows of w. On double lanes, each lane the scalar operations in their order.
// The band runs in column strips, every row of the band within a strip before the next: a
// pixel reads 5 (2r + 1) moments from as many rows, and a strip's rows (5 x 11 x 32 doubles,
// 14 KB) stay in L1 from one output row to the next, where whole rows (5 x 11 rows of a
// 960-pixel image, 420 KB) came from L2 or farther (the vertical pass was ~70% of SSIM).
void ssim_rows(const Moments& m, const std::vector<double>& taps, int y0, int y1, double c1,
               double c2, double* out, const Exec& ex) {
  constexpr int kStrip = 32;
  const int w = m.w, r = int(taps.size() / 2);
  // The moments' rows of each output row, tap-major (plane c of tap k at [5 k + c]).
  const size_t n = size_t(5) * taps.size();
  std::vector<const double*> rows(size_t(y1 - y0) * n);
  for (int y = y0; y < y1; ++y)
    for (int k = -r; k <= r; ++k)
      for (int c = 0; c < 5; ++c)
        rows[size_t(y - y0) * n + size_t(k + r) * 5 + size_t(c)] =
            m.plane[c].data() + size_t(reflect_index(y + k, m.h)) * size_t(w);
  for (int x0 = 0; x0 < w; x0 += kStrip)
    for (int y = y0; y < y1; ++y) {
      const double* const* row = rows.data() + size_t(y - y0) * n;
      double* o = out + size_t(y - y0) * size_t(w) + size_t(x0);
      for_each_double_blocks(ex, std::min(kStrip, w - x0), [&](auto d, int x, auto blocks) {
        using VD = hn::Vec<decltype(d)>;
        constexpr int kBlocks = decltype(blocks)::value;
        const size_t n = hn::Lanes(d);
        VD s[kBlocks][5];
        tap_sums<kBlocks>(
            d, taps, [&](size_t k, int c) { return row[k * 5 + size_t(c)] + x0 + x; }, s);
        const VD two = hn::Set(d, 2.0), k1 = hn::Set(d, c1), k2 = hn::Set(d, c2);
        for (int b = 0; b < kBlocks; ++b) {
          const VD ma = s[b][0], mb = s[b][1];
          const VD va = hn::Sub(s[b][2], hn::Mul(ma, ma)), vb = hn::Sub(s[b][3], hn::Mul(mb, mb));
          const VD cov = hn::Sub(s[b][4], hn::Mul(ma, mb));
          const VD num =
              hn::Mul(hn::Add(hn::Mul(hn::Mul(two, ma), mb), k1), hn::Add(hn::Mul(two, cov), k2));
          const VD den = hn::Mul(hn::Add(hn::Add(hn::Mul(ma, ma), hn::Mul(mb, mb)), k1),
                                 hn::Add(hn::Add(va, vb), k2));
          hn::StoreU(hn::Div(num, den), d, o + x + b * n);
        }
      });
    }
}

void check_planes(PlaneView a, PlaneView b, int r) {
  if (a.width != b.width || a.height != b.height)
    throw InputError(fmt::format("ssim: image sizes differ ({}x{} vs {}x{})", a.width, a.height,
                                 b.width, b.height));
  if (a.width < 2 * r + 1 || a.height < 2 * r + 1)
    throw InputError(fmt::format("ssim: image {}x{} is smaller than the {}x{} window", a.width,
                                 a.height, 2 * r + 1, 2 * r + 1));
}

// What both the mean and the map need: validated window, taps, horizontal moments and the
// stabilising constants C1 = (K1 L)^2, C2 = (K2 L)^2 (Wang et al. 2004, Eq. 13).
struct SsimPass {
  int r;
  std::vector<double> taps;
  Moments m;
  double c1, c2;
};
SsimPass prepare_ssim(PlaneView a, PlaneView b, const SsimSettings& s, const Exec& ex) {
  s.validate();
  const int r = s.radius();
  check_planes(a, b, r);
  SsimPass p{r, gaussian_taps(s.sigma, r), {}, 0, 0};
  p.m = horizontal_moments(a, b, p.taps, ex);
  p.c1 = (s.k1 * s.data_range) * (s.k1 * s.data_range);
  p.c2 = (s.k2 * s.data_range) * (s.k2 * s.data_range);
  return p;
}

// Rows [first, last) in bands of kBand rows, one task a band: band(y0, y1, out) with out
// holding the band's SSIM rows (ssim_rows).
constexpr int kBand = 16;
template <class Band>
void for_each_ssim_band(const SsimPass& p, int first, int last, const Exec& ex, Band&& band) {
  const int bands = (last - first + kBand - 1) / kBand;
  parallel_rows(ex, bands, [&](int b) {
    const int y0 = first + b * kBand, y1 = std::min(last, y0 + kBand);
    std::vector<double> out(size_t(y1 - y0) * size_t(p.m.w));
    ssim_rows(p.m, p.taps, y0, y1, p.c1, p.c2, out.data(), ex);
    band(y0, y1, out.data());
  });
}

}  // namespace

double ssim(PlaneView a, PlaneView b, const SsimSettings& s, const Exec& ex) {
  const SsimPass p = prepare_ssim(a, b, s, ex);
  const int w = a.width, h = a.height, r = p.r;
  // Only rows and columns at least r from the border count (see ssim.h): each row's sum, then
  // the rows' in order (parallel_sum_rows' order).
  std::vector<double> partial(size_t(h - 2 * r));
  for_each_ssim_band(p, r, h - r, ex, [&](int y0, int y1, const double* out) {
    for (int y = y0; y < y1; ++y) {
      const double* row = out + size_t(y - y0) * size_t(w);
      double t = 0.0;
      for (int x = r; x < w - r; ++x) t += row[x];
      partial[size_t(y - r)] = t;
    }
  });
  double sum = 0.0;
  for (double v : partial) sum += v;
  return sum / (double(w - 2 * r) * double(h - 2 * r));
}

double ssim_channels(const ImageF& a, const ImageF& b, const SsimSettings& s, const Exec& ex) {
  if (a.channels() != b.channels() || a.channels() == 0)
    throw InputError(fmt::format("ssim: channel counts differ or are zero ({} vs {})", a.channels(),
                                 b.channels()));
  double sum = 0.0;
  for (int c = 0; c < a.channels(); ++c) sum += ssim(view(a, c), view(b, c), s, ex);
  return sum / a.channels();
}

ImageF ssim_map(PlaneView a, PlaneView b, const SsimSettings& s, const Exec& ex) {
  const SsimPass p = prepare_ssim(a, b, s, ex);
  ImageF out = ImageF::uninitialized(a.width, a.height, 1);
  for_each_ssim_band(p, 0, a.height, ex, [&](int y0, int y1, const double* rows) {
    for (int y = y0; y < y1; ++y) {
      const double* row = rows + size_t(y - y0) * size_t(a.width);
      float* o = out.row(0, y);
      for (int x = 0; x < a.width; ++x) o[x] = float(row[x]);
    }
  });
  return out;
}

}  // namespace afterimage::metrics
