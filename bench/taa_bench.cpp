// Google Benchmark of the TAA resolve (names taa.<what>.<WxH>.<simd|scalar>, one thread;
// filter with --benchmark_filter=taa). The pass-level timing against the bandwidth floor is
// `afterimage bench`; this isolates the per-pixel kernels.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <string>

#include "reproject/gather.h"
#include "taa/presets.h"
#include "taa/resolver.h"
#include "taa/taa_kernels.h"

using namespace afterimage;

namespace {

// A panning textured frame with a moving square (exercises every branch of the kernels).
Frame bench_frame(int w, int h, int t) {
  Frame f = Frame::allocate(w, h);
  f.jitter = {0.25 - 0.125 * (t % 4), -0.2 + 0.1 * (t % 5)};
  const float sx = 0.3f * float(w) + 7.0f * float(t), sy = 0.3f * float(h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      bool sq = x >= sx && x < sx + 0.2f * float(w) && y >= sy && y < sy + 0.3f * float(h);
      float v =
          sq ? 3.0f : 0.5f + 0.4f * std::sin(0.3f * float(x + 2 * t)) * std::cos(0.2f * float(y));
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = v * (0.7f + 0.1f * float(c));
      f.depth.at(x, y, 0) = sq ? 2.0f : 10.0f;
      f.id.at(x, y, 0) = sq ? 2 : 1;
      f.motion.at(x, y, 0) = sq ? -7.0f : -2.0f;
      f.motion.at(x, y, 1) = sq ? 0.0f : 0.3f;
    }
  return f;
}

void BM_Resolve(benchmark::State& st, const char* preset, int w, int h, bool simd) {
  Exec ex;
  ex.simd = simd;
  ex.threads = 1;
  taa::TaaSettings s = std::string(preset) == "convex_hull" ? taa::make_preset("afterimage")
                                                            : taa::make_preset(preset);
  if (std::string(preset) == "convex_hull") s.rectify = taa::Rectify::ConvexHull;
  taa::TemporalResolver r(s, ex);
  Frame f0 = bench_frame(w, h, 0), f1 = bench_frame(w, h, 1);
  r.process(f0);  // history in place: steady state
  for (auto _ : st) {
    ImageF out = r.process(f1);
    benchmark::DoNotOptimize(out.data().data());
  }
  // Bytes of the minimal traffic: color 3 + depth 1 + motion 2 + id 1 + history 3 + count 1
  // planes read, output 3 + history 3 + count 1 written (4 bytes each).
  st.SetBytesProcessed(int64_t(st.iterations()) * int64_t(w) * h * 4 * 18);
}

// History fetch of three planes at a sub-pixel offset (the resampling part of the resolve).
// `scattered`: a random offset per pixel (within +-4 px) instead of one for the frame, so the
// fetches' indices are not consecutive and every fetch is a gather (gather.h's slow path).
void BM_HistoryFetch(benchmark::State& st, int kind, bool simd, bool scattered = false) {
  const int w = 1920, h = 1080;
  ImageF src(w, h, 3), dst(w, h, 3), offset(w, h, 2, 0.3f);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0, 1);
  for (auto& v : src.data()) v = u(rng);
  if (scattered)
    for (auto& v : offset.data()) v = 8.0f * u(rng) - 4.0f;
  const reproject::Planes<3> p = reproject::planes_of<3>(src);
  const reproject::HistoryFilter kinds[4] = {
      reproject::HistoryFilter::Bilinear, reproject::HistoryFilter::CatmullRom5,
      reproject::HistoryFilter::CatmullRom9, reproject::HistoryFilter::CatmullRom16};
  Exec ex;
  ex.simd = simd;
  for (auto _ : st) {
    for (int y = 0; y < h; ++y)
      for_each_lane_block(ex, w, [&](auto d, int x) {
        auto px = hn::Add(pixel_center_x(d, x), hn::LoadU(d, offset.row(0, y) + x));
        auto py = hn::Add(hn::Set(d, float(y)), hn::LoadU(d, offset.row(1, y) + x));
        const auto c = reproject::sample_history(d, kinds[kind], p, px, py);
        hn::StoreU(c.v[0], d, dst.row(0, y) + x);
        hn::StoreU(c.v[1], d, dst.row(1, y) + x);
        hn::StoreU(c.v[2], d, dst.row(2, y) + x);
      });
    benchmark::DoNotOptimize(dst.data().data());
  }
  st.SetBytesProcessed(int64_t(st.iterations()) * w * h * 4 * 6);
}

}  // namespace

// Names are built at run time: a macro pasting the preset into the name would get a space
// inserted by the preprocessor ("none .1920x1080").
const bool kResolveBenchmarks = [] {
  for (const char* p : {"none", "uncharted4", "ue4", "inside", "hdrp", "variance", "afterimage"})
    for (bool simd : {true, false})
      benchmark::RegisterBenchmark(
          ("taa.resolve." + std::string(p) + ".1920x1080." + (simd ? "simd" : "scalar")).c_str(),
          [p, simd](benchmark::State& st) { BM_Resolve(st, p, 1920, 1080, simd); })
          ->Unit(benchmark::kMillisecond);
  // The convex hull clip is a scalar reference option: measured at a smaller size.
  benchmark::RegisterBenchmark("taa.resolve.convex_hull.480x270.simd", [](benchmark::State& st) {
    BM_Resolve(st, "convex_hull", 480, 270, true);
  })->Unit(benchmark::kMillisecond);
  return true;
}();

const bool kHistoryBenchmarks = [] {
  const char* names[4] = {"bilinear", "catmull_rom_5", "catmull_rom_9", "bicubic_16"};
  for (int kind = 0; kind < 4; ++kind)
    for (bool simd : {true, false})
      benchmark::RegisterBenchmark(
          ("taa.history." + std::string(names[kind]) + ".1920x1080." + (simd ? "simd" : "scalar"))
              .c_str(),
          [kind, simd](benchmark::State& st) { BM_HistoryFetch(st, kind, simd); })
          ->Unit(benchmark::kMillisecond);
  for (int kind = 0; kind < 4; ++kind)
    benchmark::RegisterBenchmark(
        ("taa.history." + std::string(names[kind]) + ".scattered.1920x1080.simd").c_str(),
        [kind](benchmark::State& st) { BM_HistoryFetch(st, kind, true, true); })
        ->Unit(benchmark::kMillisecond);
  return true;
}();
