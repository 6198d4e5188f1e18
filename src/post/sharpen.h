// Post-resolve sharpening (seed 000 Eq.5, Uncharted 4's Laplacian sharpen): a stateless pass
// any pipeline can append after a temporal method (run/methods.h appends it for the
// `sharpen` key of a method spec). Temporal history never sees the sharpened image.
#pragma once

#include "core/image.h"
#include "core/lanes.h"
#include "core/parallel.h"
#include "core/params.h"

namespace afterimage::post {

struct SharpenSettings {
  // Laplacian strength s of out = c + s (4c - up - down - left - right); 0 = off.
  float sharpen = 0.0f;

  static const ParamTable<SharpenSettings>& params();
  bool operator==(const SharpenSettings&) const = default;
};

// c + s (4c - up - down - left - right), then clamped to the 3x3 [lo, hi] of the input image:
// only the overshoot is removed, HDR values above 1 stay (no saturate, unlike U4).
template <class D>
HWY_INLINE V<D> sharpen_laplacian(D d, V<D> c, V<D> up, V<D> down, V<D> left, V<D> right,
                                  float strength, V<D> lo, V<D> hi) {
  auto lap =
      hn::Sub(hn::Mul(hn::Set(d, 4.0f), c), hn::Add(hn::Add(up, down), hn::Add(left, right)));
  auto s = hn::MulAdd(hn::Set(d, strength), lap, c);
  return hn::Min(hn::Max(s, lo), hi);
}

// Sharpens every plane of `image` (edges clamp). Returns a copy when strength is 0.
// Throws SettingsError for settings out of range.
ImageF sharpen(const ImageF& image, const SharpenSettings& s, const Exec& exec = {});

}  // namespace afterimage::post
