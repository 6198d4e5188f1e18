// Bloom (bloom.h) on its fast schedule: Highway lanes, bands of rows, the bright pass fused into
// the first downsample and the composite into the last upsample. With --simd off every entry
// point runs the pass's plain statement instead (bloom_reference.cpp), the same bits.
#include "post/bloom.h"

#include <fftw3.h>
#include <fmt/format.h>

#include <cmath>
#include <mutex>

#include "core/error.h"
#include "core/lanes.h"
#include "core/prefetch.h"

namespace afterimage::post {

const ParamTable<BloomSettings>& BloomSettings::params() {
  static const ParamTable<BloomSettings> kTable = [] {
    using S = BloomSettings;
    ParamTable<S> t("bloom");
    t.add_float("intensity", &S::intensity, 0.0f, 1.0f,
                "mix weight of the scattered light: out = hdr - intensity P + intensity scale L "
                "(0 = off)");
    t.add_int("levels", &S::levels, 1, 12,
              "mip levels of the blur (level k is 2^k smaller; widths ~2^k px, equal weights)");
    t.add_float("threshold", &S::threshold, 0.0f, 65504.0f,
                "bright-pass threshold on max(R,G,B); 0 = threshold-less, energy-conserving");
    t.add_float("knee", &S::knee, 0.0f, 1.0f,
                "soft-knee width as a fraction of the threshold (quadratic transition)");
    t.add_float("scale", &S::scale, 0.0f, 16.0f,
                "gain on the scattered light (1 conserves energy, > 1 adds glow)");
    t.add_bool("karis", &S::karis,
               "Karis average on the first downsample (suppresses fireflies; loses their energy)");
    return t;
  }();
  return kTable;
}

namespace {

void check_input(const ImageF& img, const char* what) {
  if (img.empty() || img.width() <= 0 || img.height() <= 0 || img.channels() <= 0)
    throw InputError(fmt::format("bloom: {} image is empty ({}x{}x{})", what, img.width(),
                                 img.height(), img.channels()));
}

// Luma for the Karis weights: Rec.709 luminance of RGB, the mean of other channel counts.
float luma_of(const float* v, int channels) {
  if (channels == 3) return 0.2126f * v[0] + 0.7152f * v[1] + 0.0722f * v[2];
  float s = 0.0f;
  for (int c = 0; c < channels; ++c) s += v[c];
  return s / float(channels);
}

int half_size(int n) {
  return (n + 1) / 2;
}

// ---- Downsample: the 13-tap filter is 0.5 (u x u + v x v) over the 6 source texels 2i-2 ..
// 2i+3 of output i (u: the four outer groups, v: the inner group), with per-axis
// u = (1, 1, 2, 2, 1, 1) / 8 and v = (0, 1, 1, 1, 1, 0) / 4.
constexpr float kU[6] = {0.125f, 0.125f, 0.25f, 0.25f, 0.125f, 0.125f};
constexpr float kV[6] = {0.0f, 0.25f, 0.25f, 0.25f, 0.25f, 0.0f};

// Share of texel t (of n) in the in-bounds outputs (of half_size(n)) for one axis' u and v:
// 0.5 each inside, less where outputs would fall outside.
void downsample_shares(int n, std::vector<float>& zu, std::vector<float>& zv) {
  const int m = half_size(n);
  zu.assign(size_t(n), 0.0f);
  zv.assign(size_t(n), 0.0f);
  for (int i = 0; i < m; ++i)
    for (int o = 0; o < 6; ++o) {
      const int t = 2 * i - 2 + o;
      if (t < 0 || t >= n) continue;
      zu[size_t(t)] += kU[o];
      zv[size_t(t)] += kV[o];
    }
}

// The source with each texel scaled by (interior share 1/4) / (in-bounds share
// 0.5 (zu_x zu_y + zv_x zv_y)): with zero padding, every texel then gives exactly 1/4 of
// itself to the next level (the "conserve" edge policy; interior texels are unchanged).
// Returned zero-padded by kPadLo texels before and kPadHi after on each axis, so the taps
// 2i-2 .. 2i+3 of every output need no bounds checks.
constexpr int kPadLo = 2, kPadHi = 3;
struct PrescaleShares {
  std::vector<float> zux, zvx, zuy, zvy;
  // [x_lo, x_hi): columns whose shares are all the interior's 0.5 (empty if they are not one
  // run). In a row whose shares are the interior's too every factor there is 1: 0.5 * 0.5 +
  // 0.5 * 0.5 is exactly 0.5.
  int x_lo = 0, x_hi = 0;
  PrescaleShares(int w, int h) {
    downsample_shares(w, zux, zvx);
    downsample_shares(h, zuy, zvy);
    const auto inner = [&](int x) { return zux[size_t(x)] == 0.5f && zvx[size_t(x)] == 0.5f; };
    int lo = 0, hi = w;
    while (lo < w && !inner(lo)) ++lo;
    while (hi > lo && !inner(hi - 1)) --hi;
    bool run = true;
    for (int x = lo; x < hi; ++x) run = run && inner(x);
    if (run) x_lo = lo, x_hi = hi;
  }
  float factor(int x, int y) const {
    const float z = zux[size_t(x)] * zuy[size_t(y)] + zvx[size_t(x)] * zvy[size_t(y)];
    return z == 0.5f ? 1.0f : 0.5f / z;
  }
  bool interior_row(int y) const { return zuy[size_t(y)] == 0.5f && zvy[size_t(y)] == 0.5f; }
};
// One row: o[x] = in[x] scaled (interior texels are copied as they are). In an interior row
// only the columns near the two ends scale; the rest is a copy (the per-texel factor and
// compare had been ~8% of the post chain's CPU at 1080p).
inline void prescale_row(const float* in, float* o, int w, int y, const PrescaleShares& z) {
  const auto scaled = [&](int x0, int x1) {
    for (int x = x0; x < x1; ++x) {
      const float f = z.factor(x, y);
      o[x] = f == 1.0f ? in[x] : in[x] * f;
    }
  };
  if (!z.interior_row(y)) return scaled(0, w);
  scaled(0, z.x_lo);
  if (in != o) std::copy(in + z.x_lo, in + z.x_hi, o + z.x_lo);
  scaled(z.x_hi, w);
}
ImageF conserving_prescale_padded(const ImageF& src, const Exec& exec) {
  const int w = src.width(), h = src.height();
  const PrescaleShares z(w, h);
  const int pw = w + kPadLo + kPadHi, ph = h + kPadLo + kPadHi;
  ImageF out(pw, ph, src.channels(), 0.0f);
  parallel_rows(exec, h, [&](int y) {
    for (int c = 0; c < src.channels(); ++c)
      prescale_row(src.row(c, y), out.row(c, y + kPadLo) + kPadLo, w, y, z);
  });
  return out;
}

// The 2x2 average at texel corner (cx, cy) of the padded image (texels cx-1..cx, cy-1..cy).
inline float box2(const float* p, int pw, int cx, int cy) {
  const float* r0 = p + size_t(cy - 1 + kPadLo) * pw + (cx - 1 + kPadLo);
  const float* r1 = r0 + pw;
  return 0.25f * ((r0[0] + r0[1]) + (r1[0] + r1[1]));
}

// 13-tap downsample with the partial Karis average (first level): the 13 bilinear taps and
// their group weights per output texel, shared by every channel.
ImageF downsample_karis(const ImageF& src, int w, int h, const Exec& exec) {
  const int pw = src.width(), nc = src.channels();
  const int mw = half_size(w), mh = half_size(h);
  ImageF out = ImageF::uninitialized(mw, mh, nc);
  parallel_rows(exec, mh, [&](int j) {
    std::vector<std::array<float, 13>> taps(static_cast<size_t>(nc));
    std::vector<float> px(static_cast<size_t>(nc));
    std::array<float, 13> luma{};
    for (int i = 0; i < mw; ++i) {
      const int cx = 2 * i + 1, cy = 2 * j + 1;  // output center, a source texel corner
      for (int c = 0; c < nc; ++c)
        for (int t = 0; t < 13; ++t)
          taps[size_t(c)][t] =
              box2(src.plane(c), pw, cx + kTap13Offset[t][0], cy + kTap13Offset[t][1]);
      for (int t = 0; t < 13; ++t) {
        for (int c = 0; c < nc; ++c) px[size_t(c)] = taps[size_t(c)][t];
        luma[t] = luma_of(px.data(), nc);
      }
      const std::array<float, 5> gw = karis_group_weights(luma);
      for (int c = 0; c < nc; ++c) out.at(i, j, c) = downsample_13tap_weighted(taps[size_t(c)], gw);
    }
  });
  return out;
}

// The plain 13-tap downsample as its two separable terms 0.5 (u x u + v x v): a horizontal
// pass at stride 2 giving the u- and v-filtered rows, then a vertical one (same weights as
// downsample_13tap, summed in another order). `padded_rows(y, rows)` writes row y of every
// plane c of the prescaled, zero-padded source (y in [0, h + kPadLo + kPadHi), texel t at
// [t + kPadLo]) into rows[c] (w + kPadLo + kPadHi floats), so the first level reads the
// full-resolution image once without storing a padded copy of it.
// The horizontal half of the 13-tap downsample for output texels i .. i + lanes - 1: taps
// t = r + 2i .. 2i + 5 as even/odd lanes (t0 t2 t4 / t1 t3 t5); the box sums (kU) and the
// inner-box sums (kV) in the scalar form's order, so every width gives the same bits.
template <class D>
HWY_INLINE void downsample_row_lanes(D d, const float* r, int i, float* ou, float* ov) {
  V<D> t0, t1, t2, t3, t4, t5;
  hn::LoadInterleaved2(d, r + 2 * i, t0, t1);
  hn::LoadInterleaved2(d, r + 2 * i + 2, t2, t3);
  hn::LoadInterleaved2(d, r + 2 * i + 4, t4, t5);
  const V<D> u = hn::Add(hn::Add(hn::Mul(hn::Set(d, kU[0]), hn::Add(t0, t1)),
                                 hn::Mul(hn::Set(d, kU[2]), hn::Add(t2, t3))),
                         hn::Mul(hn::Set(d, kU[4]), hn::Add(t4, t5)));
  const V<D> v = hn::Mul(hn::Set(d, kV[1]), hn::Add(hn::Add(t1, t2), hn::Add(t3, t4)));
  hn::StoreU(u, d, ou + i);
  hn::StoreU(v, d, ov + i);
}

template <class RowsFn>
ImageF downsample_linear(int w, int h, int nc, RowsFn&& padded_rows, const Exec& exec) {
  const int mw = half_size(w), mh = half_size(h);
  const size_t pw = size_t(w + kPadLo + kPadHi);
  // A band of 16 output rows per task: the horizontal pass over the padded rows the band reads
  // (2 j0 .. 2 j1 + 3; a band's last 4 are also its successor's first, 1/8 more horizontal
  // work) into the task's buffers, then the vertical pass. The same values as a horizontal pass
  // over the whole image first, without writing and re-reading its two images (25 MB at 1080p).
  constexpr int kBand = 16;
  ImageF out = ImageF::uninitialized(mw, mh, nc);
  parallel_rows(exec, (mh + kBand - 1) / kBand, [&](int band) {
    const int j0 = band * kBand, j1 = std::min(mh, j0 + kBand);
    const int y0 = 2 * j0, y1 = 2 * (j1 - 1) + 6;  // padded rows [y0, y1) are read
    const size_t plane_rows = size_t(y1 - y0) * size_t(mw);
    // Scratch, every float written before it is read (no zero fill).
    std::vector<float, DefaultInitAllocator<float>> buffer(size_t(nc) * pw);
    std::vector<float, DefaultInitAllocator<float>> hu(plane_rows * size_t(nc)),
        hv(plane_rows * size_t(nc));
    std::vector<float*> rows(static_cast<size_t>(nc));
    for (int c = 0; c < nc; ++c) rows[size_t(c)] = buffer.data() + size_t(c) * pw;
    for (int y = y0; y < y1; ++y) {
      padded_rows(y, rows.data());  // taps 2i-2.. of plane c -> rows[c][2i + o]
      for (int c = 0; c < nc; ++c) {
        const float* r = rows[size_t(c)];
        const size_t at = size_t(c) * plane_rows + size_t(y - y0) * size_t(mw);
        float* ou = hu.data() + at;
        float* ov = hv.data() + at;
        for_each_lane_block(exec, mw,
                            [&](auto d, int i) { downsample_row_lanes(d, r, i, ou, ov); });
      }
    }
    for (int j = j0; j < j1; ++j)
      for (int c = 0; c < nc; ++c) {
        const float* u[6];
        const float* v[6];
        for (int o = 0; o < 6; ++o) {
          const size_t at = size_t(c) * plane_rows + size_t(2 * j + o - y0) * size_t(mw);
          u[o] = hu.data() + at;
          v[o] = hv.data() + at;
        }
        float* o = out.row(c, j);
        // On full-width lanes (as the upsample's vertical taps); the same operations in order.
        for_each_lane_block(exec, mw, [&](auto d, int i) {
          // row `r` of the horizontal pass's u or v rows, and a weight, on lanes
          const auto at = [&](const float* const* rows, int r) {
            return hn::LoadU(d, rows[r] + i);
          };
          const auto weight = [&](float value) { return hn::Set(d, value); };
          const auto su = hn::Add(hn::Add(hn::Mul(weight(kU[0]), hn::Add(at(u, 0), at(u, 1))),
                                          hn::Mul(weight(kU[2]), hn::Add(at(u, 2), at(u, 3)))),
                                  hn::Mul(weight(kU[4]), hn::Add(at(u, 4), at(u, 5))));
          const auto sv = hn::Mul(
              weight(kV[1]), hn::Add(hn::Add(at(v, 1), at(v, 2)), hn::Add(at(v, 3), at(v, 4))));
          hn::StoreU(hn::Mul(weight(0.5f), hn::Add(su, sv)), d, o + i);
        });
      }
  });
  return out;
}

// The first level straight from a full-resolution image: `source_rows(y, rows)` writes row y
// of every plane c of the (unpadded) source into rows[c] (w floats), all planes at once
// (bloom's bright pass shares one factor per pixel between them).
template <class SourceRowsFn>
ImageF downsample_first(int w, int h, int nc, SourceRowsFn&& source_rows, const Exec& exec) {
  const PrescaleShares z(w, h);
  return downsample_linear(
      w, h, nc,
      [&](int y, float* const* rows) {
        const int sy = y - kPadLo;
        const bool inside = sy >= 0 && sy < h;
        for (int c = 0; c < nc; ++c) {
          std::fill(rows[c], rows[c] + kPadLo, 0.0f);
          std::fill(rows[c] + kPadLo + w, rows[c] + kPadLo + w + kPadHi, 0.0f);
          if (!inside) std::fill(rows[c] + kPadLo, rows[c] + kPadLo + w, 0.0f);
        }
        if (!inside) return;
        std::vector<float*> inner(static_cast<size_t>(nc));
        for (int c = 0; c < nc; ++c) inner[size_t(c)] = rows[c] + kPadLo;
        source_rows(sy, inner.data());
        for (int c = 0; c < nc; ++c)  // prescaled in place
          prescale_row(inner[size_t(c)], inner[size_t(c)], w, sy, z);
      },
      exec);
}

ImageF downsample(const ImageF& level, bool karis, const Exec& exec) {
  if (karis)
    return downsample_karis(conserving_prescale_padded(level, exec), level.width(), level.height(),
                            exec);
  return downsample_first(
      level.width(), level.height(), level.channels(),
      [&](int y, float* const* rows) {
        for (int c = 0; c < level.channels(); ++c)
          std::copy(level.row(c, y), level.row(c, y) + level.width(), rows[c]);
      },
      exec);
}

// ---- Upsample (3x3 tent, separable 4-tap polyphase weights in bloom.h) with the same
// conserving edge policy: low texel j is scaled by 2 / (its total weight into in-bounds high
// pixels) per axis (1 inside).
std::vector<float> upsample_scales(int n_low, int n_high) {
  std::vector<float> z(size_t(n_low), 0.0f);
  for (int p = 0; p < n_high; ++p) {
    const int j0 = tent_upsample_first_tap(p);
    const float* wt = tent_upsample_weights(p);
    for (int a = 0; a < 4; ++a)
      if (j0 + a >= 0 && j0 + a < n_low) z[size_t(j0 + a)] += wt[a];
  }
  for (float& v : z) v = v == 2.0f ? 1.0f : 2.0f / v;
  return z;
}

// up(low) at hw x hh, handed row by row to a sink of each task, make_sink(): sink(q, p0, n,
// rows) with rows[c][p] the upsampled value of plane c at pixel (p0 + p, q), p < n (a per-task
// buffer, valid during the call), a task's rows in increasing q, each in pieces of increasing
// p0 from 0 (post/row_pass.h kRowPiece).
template <class MakeSink>
void upsample_rows(const ImageF& low, int hw, int hh, MakeSink&& make_sink, const Exec& exec) {
  const int lw = low.width(), lh = low.height(), nc = low.channels();
  const std::vector<float> fx = upsample_scales(lw, hw), fy = upsample_scales(lh, hh);
  // The low image with the per-texel edge scales folded in, zero-padded by 2 texels on each
  // side: the taps m-2 .. m+2 of every high pixel need no bounds checks.
  constexpr int kPad = 2;
  const int pw = lw + 2 * kPad, ph = lh + 2 * kPad;
  // Only the pad is zeroed: the rows are written in parallel, and a serial fill of the whole
  // image (6 MB for the last level at 1080p) cost about 5% of the pass on 2 threads.
  ImageF padded = ImageF::uninitialized(pw, ph, nc);
  for (int c = 0; c < nc; ++c)
    for (int y : {0, 1, ph - 2, ph - 1}) std::fill(padded.row(c, y), padded.row(c, y) + pw, 0.0f);
  parallel_rows(exec, lh, [&](int y) {
    for (int c = 0; c < nc; ++c) {
      const float* in = low.row(c, y);
      float* row = padded.row(c, y + kPad);
      std::fill(row, row + kPad, 0.0f);
      std::fill(row + kPad + lw, row + pw, 0.0f);
      float* o = row + kPad;
      for_each_lane_block(exec, lw, [&](auto d, int x) {  // full-width lanes, same order
        hn::StoreU(hn::Mul(hn::LoadU(d, in + x),
                           hn::Mul(hn::LoadU(d, fx.data() + x), hn::Set(d, fy[size_t(y)]))),
                   d, o + x);
      });
    }
  });
  // Horizontal: padded row `row` (texel 0 at [0]) into o (hw floats). Pixels 2i and 2i + 1
  // on lanes: texels i - 2 .. i + 1 with kTentUpEven and i - 1 .. i + 2 with kTentUpOdd
  // (tent_upsample_3x3's sums in its order), stored interleaved.
  const auto horizontal = [&](const float* row, float* o) {
    for_each_lane_block(exec, hw / 2, [&](auto d, int i) {
      const auto t = [&](int o) { return hn::LoadU(d, row + i + o); };
      const auto w = [&](const float* k, int a) { return hn::Set(d, k[a]); };
      const auto even =
          hn::Add(hn::Add(hn::Mul(w(kTentUpEven, 0), t(-2)), hn::Mul(w(kTentUpEven, 1), t(-1))),
                  hn::Add(hn::Mul(w(kTentUpEven, 2), t(0)), hn::Mul(w(kTentUpEven, 3), t(1))));
      const auto odd =
          hn::Add(hn::Add(hn::Mul(w(kTentUpOdd, 0), t(-1)), hn::Mul(w(kTentUpOdd, 1), t(0))),
                  hn::Add(hn::Mul(w(kTentUpOdd, 2), t(1)), hn::Mul(w(kTentUpOdd, 3), t(2))));
      hn::StoreInterleaved2(even, odd, d, o + 2 * i);
    });
    if (hw % 2 == 1) {
      const int p = hw - 1;
      o[p] = tent_upsample_3x3(row + tent_upsample_first_tap(p), p);
    }
  };
  // A band of output rows per task: the padded rows it reads, upsampled horizontally into the
  // task's buffer, then the vertical taps. The same values as a horizontal pass over the whole
  // image first, without writing and re-reading that hw x ph image (12 MB at 1080p).
  constexpr int kBand = 16;
  parallel_rows(exec, (hh + kBand - 1) / kBand, [&](int band) {
    const int q0 = band * kBand, q1 = std::min(hh, q0 + kBand);
    const int r0 = tent_upsample_first_tap(q0) + kPad;
    const int r1 = tent_upsample_first_tap(q1 - 1) + kPad + 4;  // rows [r0, r1) are read
    const size_t plane_rows = size_t(r1 - r0) * size_t(hw);
    std::vector<float, DefaultInitAllocator<float>> across(plane_rows * size_t(nc));  // written
    for (int c = 0; c < nc; ++c)
      for (int r = r0; r < r1; ++r)
        horizontal(padded.row(c, r) + kPad,
                   across.data() + size_t(c) * plane_rows + size_t(r - r0) * size_t(hw));
    std::vector<float, DefaultInitAllocator<float>> buffer(size_t(hw) *
                                                           size_t(nc));  // written below
    std::vector<const float*> rows(static_cast<size_t>(nc));
    auto sink = make_sink();
    for (int q = q0; q < q1; ++q) {
      const int j0 = tent_upsample_first_tap(q) + kPad - r0;
      const float* wt = tent_upsample_weights(q);
      // In pieces (post/row_pass.h kRowPiece): the sink's reads and writes of a piece, and the
      // row passes fused after it, find its values in the first-level cache.
      for_each_row_piece(hw, [&](int p0, int n) {
        for (int c = 0; c < nc; ++c) {
          const float* r0p =
              across.data() + size_t(c) * plane_rows + size_t(j0) * size_t(hw) + size_t(p0);
          const float* r1p = r0p + hw;
          const float* r2p = r1p + hw;
          const float* r3p = r2p + hw;
          float* o = buffer.data() + size_t(c) * size_t(hw) + size_t(p0);
          // The vertical taps on full-width lanes (GCC's own vectorisation of the scalar loop
          // used half-width vectors here); the same products and sums in the same order.
          for_each_lane_block(exec, n, [&](auto d, int p) {
            const auto tap = [&](const float* r, int k) {
              return hn::Mul(hn::Set(d, wt[k]), hn::LoadU(d, r + p));
            };
            hn::StoreU(
                hn::Add(hn::Add(tap(r0p, 0), tap(r1p, 1)), hn::Add(tap(r2p, 2), tap(r3p, 3))), d,
                o + p);
          });
          rows[size_t(c)] = o;
        }
        sink(q, p0, n, rows.data());
      });
    }
  });
}

// out = weight * add + up(low), sized like `add` (or hw x hh when add is null, weight unused).
ImageF upsample_accumulate(const ImageF& low, int hw, int hh, const ImageF* add, float weight,
                           const Exec& exec) {
  const int nc = low.channels();
  ImageF out = ImageF::uninitialized(hw, hh, nc);
  upsample_rows(
      low, hw, hh,
      [&] {
        return [&](int q, int p0, int n, const float* const* up) {
          for (int c = 0; c < nc; ++c) {
            float* o = out.row(c, q) + p0;
            if (add) {
              const float* ad = add->row(c, q) + p0;
              for_each_lane_block(exec, n, [&](auto d, int p) {  // full-width lanes, same order
                hn::StoreU(hn::Add(hn::Mul(hn::Set(d, weight), hn::LoadU(d, ad + p)),
                                   hn::LoadU(d, up[c] + p)),
                           d, o + p);
              });
            } else {
              std::copy(up[c], up[c] + n, o);
            }
          }
        };
      },
      exec);
  return out;
}

}  // namespace

namespace {
// The factor P = factor * max(hdr, 0) applies to every channel of the lanes' pixels (planes
// `in`, nc of them, at x): 0 if any channel is non-finite, the soft-knee bright pass of the
// brightest channel (soft_knee_bright_pass, bloom.h), or 1. The scalar functions' operations
// and comparisons in order (std::max / std::clamp as selects), so every width gives their bits.
template <class D>
HWY_INLINE V<D> source_factor_lanes(D d, const float* const* in, int nc, int x,
                                    const BloomSettings& s) {
  const V<D> zero = hn::Zero(d);
  V<D> mx = zero;
  auto finite = hn::Eq(zero, zero);
  for (int c = 0; c < nc; ++c) {
    const V<D> v = hn::LoadU(d, in[c] + x);
    finite = hn::And(finite, hn::IsFinite(v));
    mx = hn::IfThenElse(hn::Lt(mx, v), v, mx);  // std::max(mx, v)
  }
  if (!(s.threshold > 0.0f)) return hn::IfThenElseZero(finite, hn::Set(d, 1.0f));
  // soft_knee_response(mx, threshold, knee) / mx where mx > 0.
  const float k = s.knee * s.threshold;
  const V<D> over = hn::Sub(mx, hn::Set(d, s.threshold));
  V<D> response;
  if (k <= 0.0f) {
    response = hn::IfThenElse(hn::Lt(over, zero), zero, over);  // std::max(x - t, 0)
  } else {
    const V<D> lo = zero, hi = hn::Set(d, 2.0f * k), v = hn::Add(over, hn::Set(d, k));
    const V<D> sc = hn::IfThenElse(hn::Lt(v, lo), lo, hn::IfThenElse(hn::Lt(hi, v), hi, v));
    const V<D> q = hn::Div(hn::Mul(sc, sc), hn::Set(d, 4.0f * k));
    response = hn::IfThenElse(hn::Lt(q, over), over, q);  // std::max(q, x - t)
  }
  const V<D> pass = hn::IfThenElseZero(hn::Gt(mx, zero), hn::Div(response, mx));
  return hn::IfThenElseZero(finite, pass);
}
// source_value: 0 where the factor is 0, else max(v, 0) * factor (std::max keeps a -0).
template <class D>
HWY_INLINE V<D> source_value_lanes(D d, V<D> v, V<D> factor) {
  const V<D> zero = hn::Zero(d);
  const V<D> p = hn::Mul(hn::IfThenElse(hn::Lt(v, zero), zero, v), factor);
  return hn::IfThenElse(hn::Eq(factor, zero), zero, p);
}
// Row y of every plane of P into o[c].
void source_rows(const ImageF& hdr, int y, const BloomSettings& s, float* const* o,
                 const Exec& exec) {
  const int nc = hdr.channels();
  std::vector<const float*> in(static_cast<size_t>(nc));
  for (int c = 0; c < nc; ++c) in[size_t(c)] = hdr.row(c, y);
  for_each_lane_block(exec, hdr.width(), [&](auto d, int x) {
    for (int c = 0; c < nc; ++c) __builtin_prefetch(in[size_t(c)] + x + kRowPrefetchAhead);
    const auto factor = source_factor_lanes(d, in.data(), nc, x, s);
    for (int c = 0; c < nc; ++c)
      hn::StoreU(source_value_lanes(d, hn::LoadU(d, in[size_t(c)] + x), factor), d, o[c] + x);
  });
}
}  // namespace

ImageF bloom_source(const ImageF& hdr, const BloomSettings& s, const Exec& exec) {
  // --simd off runs the plain statement of each step (bloom_reference.cpp; the same bits).
  if (!exec.simd) return bloom_source_reference(hdr, s, exec);
  s.validate();
  check_input(hdr, "input");
  ImageF out = ImageF::uninitialized(hdr.width(), hdr.height(), hdr.channels());
  parallel_rows(exec, hdr.height(), [&](int y) {
    std::vector<float*> o(static_cast<size_t>(hdr.channels()));
    for (int c = 0; c < hdr.channels(); ++c) o[size_t(c)] = out.row(c, y);
    source_rows(hdr, y, s, o.data(), exec);
  });
  return out;
}

namespace {
// Levels 1..levels of the chain (index 0 left empty: the source is not copied).
// `level1`: the first level when the caller computed it (bloom() downsamples P straight from
// the input image), else empty.
std::vector<ImageF> downsample_chain(const ImageF& source, const BloomSettings& s, const Exec& exec,
                                     ImageF level1 = {}) {
  s.validate();
  std::vector<ImageF> mips(size_t(s.levels) + 1);
  mips[1] = level1.empty() ? downsample(source, s.karis, exec) : std::move(level1);
  for (int k = 2; k <= s.levels; ++k)
    mips[size_t(k)] = downsample(mips[size_t(k - 1)], false, exec);
  return mips;
}
// acc_n = w mip_n; acc_k = w mip_k + up(acc_{k+1}), w = 1 / levels (equal weight per level,
// so sum(L) = sum(source)); returns acc_1 (L = up(acc_1)).
ImageF accumulate_levels(const std::vector<ImageF>& mips, const Exec& exec) {
  const int n = int(mips.size()) - 1;
  const float w = 1.0f / float(n);
  ImageF acc = mips[size_t(n)];
  for (float& v : acc.data()) v *= w;
  for (int k = n - 1; k >= 1; --k) {
    const ImageF& m = mips[size_t(k)];
    acc = upsample_accumulate(acc, m.width(), m.height(), &m, w, exec);
  }
  return acc;
}
}  // namespace

std::vector<ImageF> bloom_mips(const ImageF& source, const BloomSettings& s, const Exec& exec) {
  if (!exec.simd) return bloom_mips_reference(source, s, exec);
  check_input(source, "source");
  std::vector<ImageF> mips = downsample_chain(source, s, exec);
  mips[0] = source;
  return mips;
}

ImageF bloom_blur(const ImageF& source, const BloomSettings& s, const Exec& exec) {
  if (!exec.simd) return bloom_blur_reference(source, s, exec);
  check_input(source, "source");
  const ImageF acc = accumulate_levels(downsample_chain(source, s, exec), exec);
  return upsample_accumulate(acc, source.width(), source.height(), nullptr, 0.0f, exec);
}

ImageF bloom_composite(const ImageF& hdr, const ImageF& source, const ImageF& light,
                       const BloomSettings& s, const Exec& exec) {
  if (!exec.simd) return bloom_composite_reference(hdr, source, light, s, exec);
  s.validate();
  check_input(hdr, "input");
  if (!hdr.same_shape(source) || !hdr.same_shape(light))
    throw InputError("bloom: input, source and light images differ in shape");
  ImageF out = ImageF::uninitialized(hdr.width(), hdr.height(), hdr.channels());
  const float a = s.intensity, b = s.intensity * s.scale;
  const size_t n = hdr.data().size();
  parallel_rows(exec, hdr.height() * hdr.channels(), [&](int r) {
    const size_t o = size_t(r) * size_t(hdr.width());
    for (size_t i = o; i < o + size_t(hdr.width()) && i < n; ++i)
      out.data()[i] = (hdr.data()[i] - a * source.data()[i]) + b * light.data()[i];
  });
  return out;
}

ImageF bloom(const ImageF& hdr, const BloomSettings& s, const Exec& exec) {
  return bloom(hdr, s, exec, RowPass{});
}

namespace {
// bloom(hdr, s, exec, then), its output written over *own's planes when own is hdr (the caller
// gives it up), else into a new image.
ImageF bloom_into(const ImageF& hdr, ImageF* own, const BloomSettings& s, const Exec& exec,
                  const RowPass& then) {
  s.validate();
  check_input(hdr, "input");
  if (then && hdr.channels() != 3)
    throw InputError(
        fmt::format("bloom: a row pass needs RGB (3 planes), the image has {}", hdr.channels()));
  const auto finish = [&](ImageF img) { return apply_row_pass(std::move(img), then, exec); };
  // The input rows go to `then` (RowPass::input_row) as the first downsample reads them;
  // the other paths hand over none.
  const bool hands_rows = s.intensity > 0.0f && !s.karis && then.input_row;
  if (then.input_done && !hands_rows) then.input_done();
  if (s.intensity <= 0.0f) {
    if (!own) return finish(hdr);
    // Rewritten where it is, not moved first: `then` may still read the object (flare's light
    // of it, made in a task of its own when no rows came).
    apply_row_pass_in_place(*own, then, exec);
    return std::move(*own);
  }
  if (s.karis) {
    const ImageF p = bloom_source(hdr, s, exec);
    return finish(bloom_composite(hdr, p, bloom_blur(p, s, exec), s, exec));
  }
  // The same arithmetic as bloom_composite(hdr, P, bloom_blur(P)) without storing P or L at
  // full resolution: the first downsample computes P's rows from the input as it reads them,
  // and the last upsample composites each row as it produces it (the full-resolution passes
  // dominate the cost; the mips are a third of the pixels).
  const int w = hdr.width(), h = hdr.height(), nc = hdr.channels();
  ImageF level1 = downsample_first(
      w, h, nc,
      [&](int y, float* const* rows) {
        source_rows(hdr, y, s, rows, exec);
        if (hands_rows) then.input_row(y);  // while the row is in the cache
      },
      exec);
  if (then.input_done && hands_rows) then.input_done();
  const ImageF acc = accumulate_levels(downsample_chain(hdr, s, exec, std::move(level1)), exec);
  // Written over the input when the caller gave it up: every read of it but the composite's
  // own (its row, before the row is written) is done. The first downsample has read every
  // row, and `then` reads its input only while it makes a RowFn (post/row_pass.h), which each
  // task below does before it writes a row.
  ImageF out = own ? ImageF() : ImageF::uninitialized(w, h, nc);
  ImageF& dst = own ? *own : out;
  const float a = s.intensity, b = s.intensity * s.scale;
  // The row pass fused after this one (then), on a row still in the cache.
  upsample_rows(
      acc, w, h,
      [&] {
        return [&, fn = then ? then() : RowFn{}, in = std::vector<const float*>(size_t(nc)),
                o = std::vector<float*>(size_t(nc))](int y, int x0, int n,
                                                     const float* const* light) mutable {
          for (int c = 0; c < nc; ++c) {
            in[size_t(c)] = hdr.row(c, y) + x0;
            o[size_t(c)] = dst.row(c, y) + x0;
          }
          for_each_lane_block(exec, n, [&](auto d, int x) {
            // The input's lines ahead: the first load of each block had stalled on memory (a
            // quarter of this loop's samples at 1080p); a prefetch changes no value. Every
            // channel is loaded before a lane block is stored, so o may be in.
            for (int c = 0; c < nc; ++c) {
              __builtin_prefetch(in[size_t(c)] + x + kRowPrefetchAhead);
              if (!own) __builtin_prefetch(o[size_t(c)] + x + kRowPrefetchAhead, 1);
            }
            const auto factor = source_factor_lanes(d, in.data(), nc, x, s);
            for (int c = 0; c < nc; ++c) {
              const auto v = hn::LoadU(d, in[size_t(c)] + x);
              const auto p = source_value_lanes(d, v, factor);
              hn::StoreU(hn::Add(hn::Sub(v, hn::Mul(hn::Set(d, a), p)),
                                 hn::Mul(hn::Set(d, b), hn::LoadU(d, light[c] + x))),
                         d, o[size_t(c)] + x);
            }
          });
          if (fn) fn(y, x0, o.data(), n);
        };
      },
      exec);
  if (own) return std::move(*own);
  return out;  // moved (a conditional expression would copy it)
}
}  // namespace

ImageF bloom(const ImageF& hdr, const BloomSettings& s, const Exec& exec, const RowPass& then) {
  if (!exec.simd) return bloom_mip_chain_reference(hdr, s, exec, then);
  return bloom_into(hdr, nullptr, s, exec, then);
}
ImageF bloom(ImageF&& hdr, const BloomSettings& s, const Exec& exec, const RowPass& then) {
  if (!exec.simd) return bloom_mip_chain_reference(std::move(hdr), s, exec, then);
  return bloom_into(hdr, &hdr, s, exec, then);
}
int bloom_psf_radius(const BloomSettings& s) {
  return 6 << s.levels;
}

ImageF bloom_psf(const BloomSettings& s, const Exec& exec) {
  s.validate();
  if (s.levels > 8)
    throw SettingsError(fmt::format(
        "bloom setting levels: the point-spread function is computed for levels <= 8 (got {})",
        s.levels));
  const int r = bloom_psf_radius(s);
  ImageF impulse(2 * r + 1, 2 * r + 1, 1, 0.0f);
  impulse.at(r, r, 0) = 1.0f;
  BloomSettings linear = s;
  linear.karis = false;
  return bloom_blur(impulse, linear, exec);
}

namespace {

// Smallest n' >= n whose only prime factors are 2, 3, 5, 7 (sizes FFTW transforms fast).
int fft_size(int n) {
  for (int m = std::max(n, 1);; ++m) {
    int k = m;
    for (int p : {2, 3, 5, 7})
      while (k % p == 0) k /= p;
    if (k == 1) return m;
  }
}

// FFTW's planner is not thread-safe (only fftw_execute is): plans are made and destroyed
// under this lock. FFTW_ESTIMATE plans do not time anything, so results are deterministic.
std::mutex& fftw_planner_mutex() {
  static std::mutex m;
  return m;
}

// A real 2D FFT buffer of ny x nx with its forward and inverse plans.
class Fft2d {
 public:
  Fft2d(int nx, int ny) : nx_(nx), ny_(ny), nc_(size_t(ny) * size_t(nx / 2 + 1)) {
    real_ = fftw_alloc_real(size_t(nx) * size_t(ny));
    cplx_ = fftw_alloc_complex(nc_);
    AI_CHECK(real_ != nullptr && cplx_ != nullptr);
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    fwd_ = fftw_plan_dft_r2c_2d(ny, nx, real_, cplx_, FFTW_ESTIMATE);
    inv_ = fftw_plan_dft_c2r_2d(ny, nx, cplx_, real_, FFTW_ESTIMATE);
    AI_CHECK(fwd_ != nullptr && inv_ != nullptr);
  }
  ~Fft2d() {
    {
      std::lock_guard<std::mutex> lock(fftw_planner_mutex());
      fftw_destroy_plan(fwd_);
      fftw_destroy_plan(inv_);
    }
    fftw_free(real_);
    fftw_free(cplx_);
  }
  Fft2d(const Fft2d&) = delete;
  Fft2d& operator=(const Fft2d&) = delete;

  double* real() { return real_; }
  fftw_complex* spectrum() { return cplx_; }
  size_t spectrum_size() const { return nc_; }
  void clear() { std::fill(real_, real_ + size_t(nx_) * size_t(ny_), 0.0); }
  void forward() { fftw_execute(fwd_); }
  void inverse() { fftw_execute(inv_); }  // unnormalised (times nx * ny)

 private:
  int nx_, ny_;
  size_t nc_;
  double* real_ = nullptr;
  fftw_complex* cplx_ = nullptr;
  fftw_plan fwd_ = nullptr, inv_ = nullptr;
};

}  // namespace

ImageF bloom_reference_fft(const ImageF& source, const ImageF& psf, const Exec& exec) {
  check_input(source, "source");
  check_input(psf, "psf");
  if (psf.channels() != 1 || psf.width() != psf.height() || psf.width() % 2 == 0)
    throw InputError(
        fmt::format("bloom: the PSF must be one channel, square and of odd size "
                    "(got {}x{}x{})",
                    psf.width(), psf.height(), psf.channels()));
  const int w = source.width(), h = source.height(), r = psf.width() / 2;
  // Only offsets within the image are ever used; with a period >= size + radius no in-image
  // pair of pixels sees a wrapped offset.
  const int rx = std::min(r, w - 1), ry = std::min(r, h - 1);
  const int nx = fft_size(w + rx), ny = fft_size(h + ry);
  const size_t nxs = size_t(nx);
  Fft2d f(nx, ny);

  // Spectrum of the PSF with its center at (0, 0).
  f.clear();
  for (int dy = -ry; dy <= ry; ++dy)
    for (int dx = -rx; dx <= rx; ++dx)
      f.real()[size_t((dy + ny) % ny) * nxs + size_t((dx + nx) % nx)] = psf.at(r + dx, r + dy, 0);
  f.forward();
  std::vector<std::array<double, 2>> kernel(f.spectrum_size());
  for (size_t i = 0; i < kernel.size(); ++i) kernel[i] = {f.spectrum()[i][0], f.spectrum()[i][1]};
  const double norm = 1.0 / (double(nx) * double(ny));

  // Share of each pixel's PSF inside the image: Z = indicator correlated with the PSF.
  f.clear();
  for (int y = 0; y < h; ++y)
    std::fill(f.real() + size_t(y) * nxs, f.real() + size_t(y) * nxs + w, 1.0);
  f.forward();
  for (size_t i = 0; i < f.spectrum_size(); ++i) {
    const double ar = f.spectrum()[i][0], ai = f.spectrum()[i][1];
    const double br = kernel[i][0], bi = -kernel[i][1];  // conj: correlation
    f.spectrum()[i][0] = (ar * br - ai * bi) * norm;
    f.spectrum()[i][1] = (ar * bi + ai * br) * norm;
  }
  f.inverse();
  std::vector<double> share(size_t(w) * size_t(h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      share[size_t(y) * size_t(w) + size_t(x)] =
          std::max(f.real()[size_t(y) * nxs + size_t(x)], 1e-12);

  ImageF out(w, h, source.channels());
  for (int c = 0; c < source.channels(); ++c) {
    f.clear();
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        f.real()[size_t(y) * nxs + size_t(x)] =
            double(source.at(x, y, c)) / share[size_t(y) * size_t(w) + size_t(x)];
    f.forward();
    for (size_t i = 0; i < f.spectrum_size(); ++i) {
      const double ar = f.spectrum()[i][0], ai = f.spectrum()[i][1];
      const double br = kernel[i][0], bi = kernel[i][1];
      f.spectrum()[i][0] = (ar * br - ai * bi) * norm;
      f.spectrum()[i][1] = (ar * bi + ai * br) * norm;
    }
    f.inverse();
    parallel_rows(exec, h, [&](int y) {
      for (int x = 0; x < w; ++x) out.at(x, y, c) = float(f.real()[size_t(y) * nxs + size_t(x)]);
    });
  }
  return out;
}

}  // namespace afterimage::post
