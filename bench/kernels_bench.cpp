// Google Benchmark for per-pixel kernels. Names follow module.kernel.WxH; filter with
// --benchmark_filter. Scalar (1-lane) and SIMD instantiations are benchmarked side by side.
#include <benchmark/benchmark.h>

#include <random>

#include "core/simd.h"
#include "reproject/gather.h"

using namespace afterimage;

namespace {
ImageF noise(int w, int h) {
  ImageF img(w, h, 1);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0, 1);
  for (auto& v : img.data()) v = u(rng);
  return img;
}

// Resample a whole image at a sub-pixel offset: the history-fetch pattern of TAA.
template <int Kind>
void BM_ResampleRow(benchmark::State& st, bool simd) {
  const int w = 1920, h = 1080;
  ImageF src = noise(w, h), dst(w, h, 1);
  const reproject::Planes<1> v = reproject::planes_of<1>(src);
  Exec ex;
  ex.simd = simd;
  ex.threads = 1;
  for (auto _ : st) {
    for (int y = 0; y < h; ++y) {
      float* out = dst.row(0, y);
      for_each_lane_block(ex, w, [&](auto d, int x) {
        auto px = hn::Add(pixel_center_x(d, x), hn::Set(d, 0.3f));
        auto py = hn::Set(d, y + 0.5f - 0.2f);
        reproject::Pixel<decltype(d), 1> r;
        if constexpr (Kind == 0)
          r = reproject::sample_bilinear(d, v, px, py);
        else
          r = reproject::sample_catmull_rom_5(d, v, px, py);
        hn::StoreU(r.v[0], d, out + x);
      });
    }
    benchmark::DoNotOptimize(dst.data().data());
  }
  st.SetBytesProcessed(int64_t(st.iterations()) * w * h * 8);
}
// Registered at start-up by name (BENCHMARK_CAPTURE would put spaces into dotted names).
const bool kRegistered = [] {
  for (bool simd : {true, false}) {
    const char* mode = simd ? "simd" : "scalar";
    benchmark::RegisterBenchmark((std::string("reproject.bilinear.1920x1080.") + mode).c_str(),
                                 [simd](benchmark::State& st) { BM_ResampleRow<0>(st, simd); })
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((std::string("reproject.catmull_rom_5.1920x1080.") + mode).c_str(),
                                 [simd](benchmark::State& st) { BM_ResampleRow<1>(st, simd); })
        ->Unit(benchmark::kMillisecond);
  }
  return true;
}();

}  // namespace
