#include "taau/resample.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "core/error.h"

namespace afterimage::taau {

double catmull_rom_kernel(double x) {
  // Keys (1981) cubic with a = -0.5, the filter of core/sampler.h catmull_rom_weights.
  x = std::abs(x);
  if (x < 1) return 1.5 * x * x * x - 2.5 * x * x + 1;
  if (x < 2) return -0.5 * x * x * x + 2.5 * x * x - 4 * x + 2;
  return 0;
}

double lanczos3_kernel(double x) {
  x = std::abs(x);
  if (x < 1e-9) return 1;
  if (x >= 3) return 0;
  const double px = std::numbers::pi * x;
  return 3 * std::sin(px) * std::sin(px / 3) / (px * px);
}

namespace {

// Taps of one axis: for each output index, the first input index and normalised weights.
struct AxisTaps {
  int radius = 2;
  std::vector<int> first;
  std::vector<float> weights;  // (2 radius) per output index
};

AxisTaps axis_taps(int in, int out, ResampleFilter f) {
  AxisTaps t;
  t.radius = f == ResampleFilter::CatmullRom ? 2 : 3;
  const int n = 2 * t.radius;
  const double ratio = double(in) / double(out);
  t.first.resize(size_t(out));
  t.weights.resize(size_t(out) * size_t(n));
  for (int o = 0; o < out; ++o) {
    const double q = (o + 0.5) * ratio - 0.5;  // input position in pixel-index units
    const int i0 = int(std::floor(q)) - t.radius + 1;
    t.first[size_t(o)] = i0;
    double sum = 0;
    for (int k = 0; k < n; ++k) {
      const double x = q - (i0 + k);
      const double w = f == ResampleFilter::CatmullRom ? catmull_rom_kernel(x) : lanczos3_kernel(x);
      t.weights[size_t(o) * size_t(n) + size_t(k)] = float(w);
      sum += w;
    }
    for (int k = 0; k < n; ++k) t.weights[size_t(o) * size_t(n) + size_t(k)] /= float(sum);
  }
  return t;
}

}  // namespace

ImageF resample_image(const ImageF& in, int width, int height, ResampleFilter filter,
                      const Exec& ex) {
  AI_CHECK(width >= 1 && height >= 1 && !in.empty());
  const int w = in.width(), h = in.height(), ch = in.channels();
  const AxisTaps tx = axis_taps(w, width, filter), ty = axis_taps(h, height, filter);
  const int nx = 2 * tx.radius, ny = 2 * ty.radius;
  // Horizontal pass to width x h, then vertical to width x height.
  ImageF mid(width, h, ch), out(width, height, ch);
  parallel_rows(ex, h, [&](int y) {
    for (int c = 0; c < ch; ++c)
      for (int x = 0; x < width; ++x) {
        float s = 0;
        for (int k = 0; k < nx; ++k) {
          const int i = std::min(std::max(tx.first[size_t(x)] + k, 0), w - 1);
          s += tx.weights[size_t(x) * size_t(nx) + size_t(k)] * in.at(i, y, c);
        }
        mid.at(x, y, c) = s;
      }
  });
  parallel_rows(ex, height, [&](int y) {
    for (int c = 0; c < ch; ++c)
      for (int x = 0; x < width; ++x) {
        float s = 0;
        for (int k = 0; k < ny; ++k) {
          const int j = std::min(std::max(ty.first[size_t(y)] + k, 0), h - 1);
          s += ty.weights[size_t(y) * size_t(ny) + size_t(k)] * mid.at(x, j, c);
        }
        // Negative lobes can undershoot below 0 at edges; radiance is never negative.
        out.at(x, y, c) = std::max(s, 0.0f);
      }
  });
  return out;
}

}  // namespace afterimage::taau
