#include "post/uber.h"

#include <fmt/format.h>

#include <algorithm>

#include "core/error.h"
#include "core/lanes.h"

namespace afterimage::post {

constexpr bool kStoreBloom = 0;

void bloom_flare_tonemap_into(const ImageF& hdr, const BloomSettings& b, const FlareSettings& f,
                              const TonemapSettings& t, ImageF& out, const Exec& exec) {
  b.validate();
  f.validate();
  t.validate();
  if (&out == &hdr) throw InputError("bloom_flare_tonemap: output aliases the input");
  if (hdr.channels() != 3 || hdr.empty())
    throw InputError(
        fmt::format("bloom_flare_tonemap: expected a non-empty RGB image, got {}x{}x{}",
                    hdr.width(), hdr.height(), hdr.channels()));
  if (!bloom_rows_supported(b) || !lens_flare_adds_light(f)) {
    out = tonemap(lens_flare(bloom(hdr, b, exec), f, exec), t, exec);
    return;
  }
  const int w = hdr.width(), h = hdr.height();
  ensure_shape(out, w, h, 3);
  const BloomRows bloom_out(hdr, b, exec);
  FlareRows flare(w, h, f);
  const auto finish_row = [&](int y, float* const* rows, float* const* o,
                              FlareRows::Scratch& scratch) {
    flare.add_row(y, rows, rows, scratch);
    for_each_lane_block(exec, w, [&](auto d, int x) {
      const auto r = tonemap_pixel(
          d, {hn::LoadU(d, rows[0] + x), hn::LoadU(d, rows[1] + x), hn::LoadU(d, rows[2] + x)}, t);
      hn::StoreU(r.c0, d, o[0] + x);
      hn::StoreU(r.c1, d, o[1] + x);
      hn::StoreU(r.c2, d, o[2] + x);
    });
  };
  // 1. bloom's rows written into `out` and fed to the flare's bright pass while in cache.
  bloom_out.run([&] { return [&](int y, float* const* rows) { flare.input_row(y, rows); }; }, exec,
                &out);
  flare.prepare(exec);
  // 2. In place: the flare's light added and tonemapped, 16-row bands per task.
  constexpr int kBand = 16;
  parallel_rows(exec, (h + kBand - 1) / kBand, [&](int band) {
    FlareRows::Scratch scratch;
    for (int y = band * kBand; y < std::min(h, (band + 1) * kBand); ++y) {
      float* o[3] = {out.row(0, y), out.row(1, y), out.row(2, y)};
      finish_row(y, o, o, scratch);
    }
  });
}

ImageF bloom_flare_tonemap(const ImageF& hdr, const BloomSettings& b, const FlareSettings& f,
                           const TonemapSettings& t, const Exec& exec) {
  ImageF out;
  bloom_flare_tonemap_into(hdr, b, f, t, out, exec);
  return out;
}

}  // namespace afterimage::post
