#include "metrics/psnr.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "metrics/display.h"

namespace afterimage::metrics {

double psnr_from_mse(double mse, double peak) {
  if (mse <= 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(peak * peak / mse);
}

double mean_squared_error(const ImageF& a, const ImageF& b, const Exec& ex) {
  check_same_shape(a, b, "mean_squared_error");
  const int w = a.width(), nc = a.channels();
  const double sum = parallel_sum_rows(ex, a.height(), [&](int y) {
    double s = 0.0;
    for (int c = 0; c < nc; ++c) {
      const float *pa = a.row(c, y), *pb = b.row(c, y);
      for (int x = 0; x < w; ++x) {
        const double d = double(pa[x]) - double(pb[x]);
        s += d * d;
      }
    }
    return s;
  });
  return sum / (double(a.plane_size()) * nc);
}

double psnr(const ImageF& reference, const ImageF& test, double peak, const Exec& ex) {
  return psnr_from_mse(mean_squared_error(reference, test, ex), peak);
}

LinearPsnr psnr_linear_hdr(const ImageF& reference, const ImageF& test, const Exec& ex) {
  check_same_shape(reference, test, "psnr_linear_hdr");
  float peak = 0.0f;
  for (float v : reference.data())
    if (std::isfinite(v)) peak = std::max(peak, v);
  LinearPsnr r;
  r.peak = peak > 0.0f ? double(peak) : 1.0;
  r.psnr = psnr(reference, test, r.peak, ex);
  return r;
}

}  // namespace afterimage::metrics
