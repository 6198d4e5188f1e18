// Google Benchmark of SVGF's stages (names svgf.<stage>.<WxH>.t<threads>; filter with
// --benchmark_filter=svgf): one frame in steady state (history in place), timed per stage from
// the denoiser's own stage clocks (manual time). The pass-level row against the bandwidth floor
// is `afterimage bench` (svgf.filter.<preset>).
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

#include "svgf/denoiser.h"

using namespace afterimage;

namespace {

// A panning textured plane pair with noisy illumination, albedo, normals, ids.
Frame bench_frame(int w, int h, int t) {
  Frame f = Frame::allocate(w, h);
  f.index = t;
  uint32_t state = 12345u + uint32_t(t);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      state = state * 1664525u + 1013904223u;
      const float noise = float(state >> 8) * (2.0f / 16777216.0f);  // mean 1
      const bool near = (x + 2 * t) % 512 < 200;
      for (int c = 0; c < 3; ++c) {
        const float a = 0.3f + 0.4f * float(((x + 2 * t) / 16 + y / 16 + c) % 2);
        f.albedo.at(x, y, c) = a;
        f.color.at(x, y, c) = a * (near ? 2.0f : 0.7f) * noise;
      }
      f.depth.at(x, y, 0) = near ? 2.0f + 0.001f * float(y) : 8.0f;
      f.normal.at(x, y, 2) = 1.0f;
      f.id.at(x, y, 0) = near ? 2 : 1;
      f.motion.at(x, y, 0) = t > 0 ? 2.0f : 0.0f;
    }
  return f;
}

enum Stage { Accumulate, Variance, Atrous, Total };

void BM_Svgf(benchmark::State& st, Stage stage, int w, int h, int threads) {
  Exec ex;
  ex.threads = threads;
  svgf::SvgfDenoiser den({}, ex);
  Frame f0 = bench_frame(w, h, 0), f1 = bench_frame(w, h, 1);
  for (int i = 0; i < 5; ++i) den.process(i % 2 ? f1 : f0);  // n >= 4: the temporal variance
  int i = 0;
  for (auto _ : st) {
    Frame out = den.process(++i % 2 ? f1 : f0);
    benchmark::DoNotOptimize(out.color.data().data());
    const svgf::SvgfTimings& tm = den.last_timings();
    const double ms = stage == Accumulate ? tm.accumulate_ms
                      : stage == Variance ? tm.variance_ms
                      : stage == Atrous   ? tm.atrous_ms
                                          : tm.total_ms;
    st.SetIterationTime(ms * 1e-3);
    for (auto [name, v] : {std::pair{"prepare_ms", tm.prepare_ms},
                           {"accumulate_ms", tm.accumulate_ms},
                           {"variance_ms", tm.variance_ms},
                           {"atrous_ms", tm.atrous_ms},
                           {"remodulate_ms", tm.remodulate_ms},
                           {"total_ms", tm.total_ms}})
      st.counters[name] += v;
  }
  for (auto& [name, c] : st.counters) c.value /= double(st.iterations());
}

void register_all() {
  const char* names[] = {"accumulate", "variance", "atrous5", "total"};
  for (auto [w, h] : {std::pair{960, 540}, std::pair{1920, 1080}})
    for (int threads : {1, 2})
      for (int s = 0; s < 4; ++s)
        benchmark::RegisterBenchmark(
            (std::string("svgf.") + names[s] + "." + std::to_string(w) + "x" + std::to_string(h) +
             ".t" + std::to_string(threads))
                .c_str(),
            [=](benchmark::State& st) { BM_Svgf(st, Stage(s), w, h, threads); })
            ->UseManualTime()
            ->Unit(benchmark::kMillisecond);
}
const int kRegistered = (register_all(), 0);

}  // namespace
