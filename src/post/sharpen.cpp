#include "post/sharpen.h"

#include "core/neighborhood.h"
#include "core/simd.h"

namespace afterimage::post {

const ParamTable<SharpenSettings>& SharpenSettings::params() {
  static const ParamTable<SharpenSettings> kTable = [] {
    ParamTable<SharpenSettings> t("sharpen");  // errors read "sharpen setting sharpen: ..."
    t.add_float("sharpen", &SharpenSettings::sharpen, 0.0f, 4.0f,
                "Laplacian sharpen strength after the temporal pass (seed 000 Eq.5), 0 = off");
    return t;
  }();
  return kTable;
}

namespace {

// One lane block of every plane: the 3x3 neighbourhood, its min/max, Eq.5.
template <class D>
HWY_INLINE void sharpen_block(D d, const ImageF& in, ImageF& out, float strength, int x, int y) {
  const int w = in.width();
  const auto rows = neighborhood_rows(y, w, in.height());
  for (int c = 0; c < in.channels(); ++c) {
    const float* p = in.plane(c);
    V<D> v[9];
    for (int i = 0; i < 9; ++i)
      v[i] = load_row_shifted(d, p + rows[kNeighborDy[i] + 1], x, kNeighborDx[i], w);
    auto lo = v[0], hi = v[0];
    for (int i = 1; i < 9; ++i) {
      lo = hn::Min(lo, v[i]);
      hi = hn::Max(hi, v[i]);
    }
    // v[1] left, v[2] right, v[3] up, v[4] down.
    auto r = sharpen_laplacian(d, v[0], v[3], v[4], v[1], v[2], strength, lo, hi);
    hn::StoreU(r, d, out.plane(c) + rows[1] + x);
  }
}

}  // namespace

ImageF sharpen(const ImageF& image, const SharpenSettings& s, const Exec& exec) {
  SharpenSettings::params().validate(s);
  if (s.sharpen <= 0.0f) return image;
  // Every lane block of every row and plane is written below.
  ImageF out = ImageF::uninitialized(image.width(), image.height(), image.channels());
  parallel_rows(exec, image.height(), [&](int y) {
    for_each_lane_block(exec, image.width(),
                        [&](auto d, int x) { sharpen_block(d, image, out, s.sharpen, x, y); });
  });
  return out;
}

}  // namespace afterimage::post
