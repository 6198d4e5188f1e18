// Google Benchmark for the metrics kernels at 1080p, 1 thread and all threads
// (names module.kernel.WxH/threads, 0 = all; filter with --benchmark_filter=metrics).
#include <benchmark/benchmark.h>

#include <random>

#include "metrics/flip.h"
#include "metrics/ssim.h"

using namespace afterimage;

namespace {
ImageF noise_rgb(int w, int h, unsigned seed) {
  ImageF img(w, h, 3);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0, 1);
  for (auto& v : img.data()) v = u(rng);
  return img;
}

void BM_LdrFlip(benchmark::State& st) {
  const ImageF a = noise_rgb(1920, 1080, 1), b = noise_rgb(1920, 1080, 2);
  Exec ex;
  ex.threads = int(st.range(0));  // 1 or 0 = all
  for (auto _ : st)
    benchmark::DoNotOptimize(metrics::ldr_flip(a, b, metrics::flip_default_ppd(), ex).mean);
}

void BM_Ssim(benchmark::State& st) {
  const ImageF a = noise_rgb(1920, 1080, 3), b = noise_rgb(1920, 1080, 4);
  Exec ex;
  ex.threads = int(st.range(0));  // 1 or 0 = all
  for (auto _ : st) benchmark::DoNotOptimize(metrics::ssim(view(a, 0), view(b, 0), {}, ex));
}
}  // namespace

BENCHMARK(BM_LdrFlip)
    ->Name("metrics.ldr_flip.1920x1080")
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Ssim)
    ->Name("metrics.ssim_plane.1920x1080")
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kMillisecond);
