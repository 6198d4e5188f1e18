#include "metrics/ssim.h"

#include <fmt/format.h>

#include <cmath>
#include <vector>

#include "core/error.h"

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

// Gaussian-filtered local statistics of a pair: E[a], E[b], E[a^2], E[b^2], E[ab].
struct Moments {
  int w = 0, h = 0;
  std::vector<double> plane[5];
};

// Horizontal pass of the five moments for every row.
Moments horizontal_moments(PlaneView a, PlaneView b, const std::vector<double>& taps,
                           const Exec& ex) {
  const int w = a.width, h = a.height, r = int(taps.size() / 2);
  Moments m;
  m.w = w;
  m.h = h;
  for (auto& p : m.plane) p.assign(size_t(w) * h, 0.0);
  parallel_rows(ex, h, [&](int y) {
    std::vector<double> pa(size_t(w + 2 * r)), pb(size_t(w + 2 * r));
    for (int i = -r; i < w + r; ++i) {
      const int xi = reflect_index(i, w);
      pa[size_t(i + r)] = a.at(xi, y);
      pb[size_t(i + r)] = b.at(xi, y);
    }
    const size_t row = size_t(y) * w;
    for (int x = 0; x < w; ++x) {
      double s[5] = {0, 0, 0, 0, 0};
      for (size_t k = 0; k < taps.size(); ++k) {
        const double va = pa[size_t(x) + k], vb = pb[size_t(x) + k], t = taps[k];
        s[0] += t * va;
        s[1] += t * vb;
        s[2] += t * (va * va);
        s[3] += t * (vb * vb);
        s[4] += t * (va * vb);
      }
      for (int c = 0; c < 5; ++c) m.plane[c][row + size_t(x)] = s[c];
    }
  });
  return m;
}

// Vertical pass for row y, then SSIM per pixel [Wang et al. eq. 13] with population
// covariances: S = (2 mu_a mu_b + C1)(2 cov + C2) / ((mu_a^2 + mu_b^2 + C1)(var_a + var_b + C2)).
void ssim_row(const Moments& m, const std::vector<double>& taps, int y, double c1, double c2,
              double* out) {
  const int w = m.w, r = int(taps.size() / 2);
  std::vector<double> s(size_t(5) * w, 0.0);
  for (int k = -r; k <= r; ++k) {
    const size_t row = size_t(reflect_index(y + k, m.h)) * w;
    const double t = taps[size_t(k + r)];
    for (int c = 0; c < 5; ++c) {
      const double* src = m.plane[c].data() + row;
      double* dst = s.data() + size_t(c) * w;
      for (int x = 0; x < w; ++x) dst[x] += t * src[x];
    }
  }
  for (int x = 0; x < w; ++x) {
    const double ma = s[size_t(x)], mb = s[size_t(w + x)];
    const double va = s[size_t(2 * w + x)] - ma * ma, vb = s[size_t(3 * w + x)] - mb * mb;
    const double cov = s[size_t(4 * w + x)] - ma * mb;
    out[x] =
        ((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
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

}  // namespace

double ssim(PlaneView a, PlaneView b, const SsimSettings& s, const Exec& ex) {
  const SsimPass p = prepare_ssim(a, b, s, ex);
  const int w = a.width, h = a.height, r = p.r;
  // Only rows and columns at least r from the border count (see ssim.h).
  const double sum = parallel_sum_rows(ex, h - 2 * r, [&](int i) {
    std::vector<double> row(static_cast<size_t>(w));
    ssim_row(p.m, p.taps, i + r, p.c1, p.c2, row.data());
    double t = 0.0;
    for (int x = r; x < w - r; ++x) t += row[size_t(x)];
    return t;
  });
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
  ImageF out(a.width, a.height, 1);
  parallel_rows(ex, a.height, [&](int y) {
    std::vector<double> row(static_cast<size_t>(a.width));
    ssim_row(p.m, p.taps, y, p.c1, p.c2, row.data());
    float* o = out.row(0, y);
    for (int x = 0; x < a.width; ++x) o[x] = float(row[size_t(x)]);
  });
  return out;
}

}  // namespace afterimage::metrics
