#include "metrics/display.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"

namespace afterimage::metrics {

void DisplaySettings::validate() const {
  if (!(exposure > 0.0f) || !std::isfinite(exposure))
    throw SettingsError(
        fmt::format("display: exposure must be a positive number, got {}", exposure));
}

namespace {
template <class F>
ImageF map_planes(const ImageF& in, const Exec& ex, F f) {
  ImageF out(in.width(), in.height(), in.channels());
  const int w = in.width();
  parallel_rows(ex, in.height(), [&](int y) {
    for (int c = 0; c < in.channels(); ++c) {
      const float* s = in.row(c, y);
      float* d = out.row(c, y);
      for (int x = 0; x < w; ++x) d[x] = f(s[x]);
    }
  });
  return out;
}
}  // namespace

ImageF to_display(const ImageF& linear, const DisplaySettings& s, const Exec& ex) {
  s.validate();
  return map_planes(linear, ex, [&](float v) { return display_value(v, s); });
}

ImageF to_tonemapped_linear(const ImageF& linear, const DisplaySettings& s, const Exec& ex) {
  s.validate();
  return map_planes(linear, ex, [&](float v) { return tonemapped_linear_value(v, s); });
}

ImageF luma(const ImageF& rgb, const Exec& ex) {
  AI_CHECK_EQ(rgb.channels(), 3);
  const int w = rgb.width();
  ImageF out(w, rgb.height(), 1);
  parallel_rows(ex, rgb.height(), [&](int y) {
    const float *r = rgb.row(0, y), *g = rgb.row(1, y), *b = rgb.row(2, y);
    float* o = out.row(0, y);
    for (int x = 0; x < w; ++x) o[x] = luminance({r[x], g[x], b[x]});
  });
  return out;
}

void check_same_shape(const ImageF& a, const ImageF& b, const char* what) {
  if (a.empty() || b.empty()) throw InputError(fmt::format("{}: empty image", what));
  if (!a.same_shape(b))
    throw InputError(fmt::format("{}: images differ in shape ({}x{}x{} vs {}x{}x{})", what,
                                 a.width(), a.height(), a.channels(), b.width(), b.height(),
                                 b.channels()));
}

}  // namespace afterimage::metrics
