// Bloom written plainly, one pixel at a time: the specification of the pass (bloom.h), which the
// fast schedule (bloom.cpp: Highway lanes, bands of rows, the bright pass fused into the first
// downsample and the composite into the last upsample) computes bit for bit, and what
// `--simd off` runs. Jimenez, "Next Generation Post Processing in Call of Duty: Advanced
// Warfare" (SIGGRAPH 2014 course; seed 004 "Lens Flare and Bloom"): the 13-tap downsample, the
// partial Karis average on the first downsample, the 3x3 tent upsample.
//
// Each sum is in the fast schedule's order: the 13-tap downsample as its two separable terms
// 0.5 (u x u + v x v), rows first (downsample_13tap's weights, summed in another order); with
// Karis, downsample_13tap_weighted's group order; the tent upsample along x, then along y.
//
// Names: each public step's twin is <step>_reference, as motion_blur_reference is the motion
// blur's. The whole pass is bloom_mip_chain_reference rather than bloom_reference, which would
// read as a plain form of bloom_reference_fft: that one is another kind of reference, an FFT
// convolution with the chain's point-spread function that the chain only approximates.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "core/error.h"
#include "post/bloom.h"

namespace afterimage::post {

namespace {

void check_image(const ImageF& img, const char* what) {
  if (img.empty() || img.width() <= 0 || img.height() <= 0 || img.channels() <= 0)
    throw InputError(fmt::format("bloom: {} image is empty ({}x{}x{})", what, img.width(),
                                 img.height(), img.channels()));
}

// A level of n texels has half_size(n) texels at the next.
int half_size(int n) {
  return (n + 1) / 2;
}

// Texel (x, y) of plane c, 0 outside the image: the taps' zero padding.
float texel_or_zero(const ImageF& img, int x, int y, int c) {
  if (x < 0 || y < 0 || x >= img.width() || y >= img.height()) return 0.0f;
  return img.at(x, y, c);
}

// ---- The light that scatters, P ------------------------------------------------------------

// The factor every channel of a pixel is multiplied by: 0 if any channel is non-finite, else 1
// without a threshold, else the soft-knee bright pass of the brightest channel (at least 0).
float source_factor(const ImageF& hdr, int x, int y, const BloomSettings& s) {
  bool finite = true;
  float brightest = 0.0f;
  for (int c = 0; c < hdr.channels(); ++c) {
    const float v = hdr.at(x, y, c);
    finite = finite && std::isfinite(v);
    brightest = std::max(brightest, v);
  }
  if (!finite) return 0.0f;
  if (!(s.threshold > 0.0f)) return 1.0f;
  return soft_knee_bright_pass(brightest, s.threshold, s.knee);
}

// A channel's light: max(v, 0) times the pixel's factor, exactly 0 where the factor is (a NaN
// or an infinity times 0 would not be).
float source_value(float v, float factor) {
  if (factor == 0.0f) return 0.0f;
  return std::max(v, 0.0f) * factor;
}

ImageF source_image(const ImageF& hdr, const BloomSettings& s, const Exec& exec) {
  ImageF p(hdr.width(), hdr.height(), hdr.channels());
  parallel_rows(exec, hdr.height(), [&](int y) {
    for (int x = 0; x < hdr.width(); ++x) {
      const float factor = source_factor(hdr, x, y, s);
      for (int c = 0; c < hdr.channels(); ++c)
        p.at(x, y, c) = source_value(hdr.at(x, y, c), factor);
    }
  });
  return p;
}

// ---- Downsample: the 13 taps per axis ------------------------------------------------------

// Output texel i of the next level reads texels 2i-2 .. 2i+3 of a level. Per axis, the four
// outer 2x2-tap groups (weight 0.125 each) give those six texels u = (1, 1, 2, 2, 1, 1) / 8 and
// the inner group (weight 0.5) gives v = (0, 1, 1, 1, 1, 0) / 4: the 13-tap filter is
// 0.5 (u x u + v x v).
constexpr float kOuterU[6] = {0.125f, 0.125f, 0.25f, 0.25f, 0.125f, 0.125f};
constexpr float kInnerV[6] = {0.0f, 0.25f, 0.25f, 0.25f, 0.25f, 0.0f};

// The u and v sums of six texels t[0..5] in a line (paired as the taps' 2x2 boxes pair them).
float outer_sum(const float t[6]) {
  return (kOuterU[0] * (t[0] + t[1]) + kOuterU[2] * (t[2] + t[3])) + kOuterU[4] * (t[4] + t[5]);
}
float inner_sum(const float t[6]) {
  return kInnerV[1] * ((t[1] + t[2]) + (t[3] + t[4]));
}

// The edge policy ("conserve", bloom.h). Per axis, a texel's share of the next level: the sum of
// its u (or v) weights over the next level's texels inside the image, 0.5 away from the ends.
std::vector<float> downsample_shares(int n, const float (&weight)[6]) {
  std::vector<float> share(size_t(n), 0.0f);
  for (int i = 0; i < half_size(n); ++i)
    for (int o = 0; o < 6; ++o) {
      const int t = 2 * i - 2 + o;
      if (t >= 0 && t < n) share[size_t(t)] += weight[o];
    }
  return share;
}

// Each texel scaled by (its interior share, 0.5) / (its share 0.5 zu_x zu_y + 0.5 zv_x zv_y
// of the next level inside the image): with zero padding, every texel then gives exactly 1/4
// of itself to the next level. Interior texels are copied as they are.
ImageF conserving_prescale(const ImageF& level, const Exec& exec) {
  const int w = level.width(), h = level.height();
  const std::vector<float> ux = downsample_shares(w, kOuterU), vx = downsample_shares(w, kInnerV);
  const std::vector<float> uy = downsample_shares(h, kOuterU), vy = downsample_shares(h, kInnerV);
  ImageF out(w, h, level.channels());
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const float z = ux[size_t(x)] * uy[size_t(y)] + vx[size_t(x)] * vy[size_t(y)];
      const float factor = z == 0.5f ? 1.0f : 0.5f / z;
      for (int c = 0; c < level.channels(); ++c) {
        const float v = level.at(x, y, c);
        out.at(x, y, c) = factor == 1.0f ? v : v * factor;
      }
    }
  });
  return out;
}

// The 13-tap downsample of plane c of a prescaled level at output texel (i, j): the u and v
// sums of each of the six rows it reads, then the u and v sums of those down the column.
float downsample_13tap_at(const ImageF& pre, int i, int j, int c) {
  float row_u[6], row_v[6];
  for (int r = 0; r < 6; ++r) {
    float t[6];
    for (int o = 0; o < 6; ++o) t[o] = texel_or_zero(pre, 2 * i - 2 + o, 2 * j - 2 + r, c);
    row_u[r] = outer_sum(t);
    row_v[r] = inner_sum(t);
  }
  return 0.5f * (outer_sum(row_u) + inner_sum(row_v));
}

// Luma for the Karis weights: Rec.709 luminance of RGB, the mean of other channel counts.
float karis_luma(const float* v, int channels) {
  if (channels == 3) return 0.2126f * v[0] + 0.7152f * v[1] + 0.0722f * v[2];
  float sum = 0.0f;
  for (int c = 0; c < channels; ++c) sum += v[c];
  return sum / float(channels);
}

// The mean of the 2x2 texels around texel corner (cx, cy) of plane c: cx-1 .. cx, cy-1 .. cy.
float box2x2(const ImageF& pre, int cx, int cy, int c) {
  return 0.25f * ((texel_or_zero(pre, cx - 1, cy - 1, c) + texel_or_zero(pre, cx, cy - 1, c)) +
                  (texel_or_zero(pre, cx - 1, cy, c) + texel_or_zero(pre, cx, cy, c)));
}

// The next level of a level: the 13-tap downsample of its prescaled texels, with the partial
// Karis average (group weights from the taps' luma, shared by every channel) if `karis`.
ImageF downsample(const ImageF& level, bool karis, const Exec& exec) {
  const ImageF pre = conserving_prescale(level, exec);
  const int nc = level.channels();
  ImageF out(half_size(level.width()), half_size(level.height()), nc);
  parallel_rows(exec, out.height(), [&](int j) {
    std::vector<std::array<float, 13>> taps(static_cast<size_t>(nc));
    std::vector<float> pixel(static_cast<size_t>(nc));
    for (int i = 0; i < out.width(); ++i) {
      if (!karis) {
        for (int c = 0; c < nc; ++c) out.at(i, j, c) = downsample_13tap_at(pre, i, j, c);
        continue;
      }
      // The output's center is the texel corner (2i + 1, 2j + 1); each tap a 2x2 mean there.
      std::array<float, 13> luma{};
      for (int t = 0; t < 13; ++t) {
        for (int c = 0; c < nc; ++c) {
          taps[size_t(c)][size_t(t)] =
              box2x2(pre, 2 * i + 1 + kTap13Offset[t][0], 2 * j + 1 + kTap13Offset[t][1], c);
          pixel[size_t(c)] = taps[size_t(c)][size_t(t)];
        }
        luma[size_t(t)] = karis_luma(pixel.data(), nc);
      }
      const std::array<float, 5> weights = karis_group_weights(luma);
      for (int c = 0; c < nc; ++c)
        out.at(i, j, c) = downsample_13tap_weighted(taps[size_t(c)], weights);
    }
  });
  return out;
}

// mips[1 .. levels] of a source (mips[0] left empty).
std::vector<ImageF> downsample_chain(const ImageF& source, const BloomSettings& s,
                                     const Exec& exec) {
  std::vector<ImageF> mips(size_t(s.levels) + 1);
  mips[1] = downsample(source, s.karis, exec);
  for (int k = 2; k <= s.levels; ++k)
    mips[size_t(k)] = downsample(mips[size_t(k - 1)], false, exec);
  return mips;
}

// ---- Upsample: the 3x3 tent ------------------------------------------------------------------

// The edge policy per axis: low texel j scaled by 2 / (its total tent weight into the high
// pixels inside the image), 1 away from the ends (where that total is 2).
std::vector<float> upsample_scales(int n_low, int n_high) {
  std::vector<float> total(size_t(n_low), 0.0f);
  for (int p = 0; p < n_high; ++p)
    for (int a = 0; a < 4; ++a) {
      const int j = tent_upsample_first_tap(p) + a;
      if (j >= 0 && j < n_low) total[size_t(j)] += tent_upsample_weights(p)[a];
    }
  std::vector<float> scale(total.size());
  for (size_t j = 0; j < total.size(); ++j) scale[j] = total[j] == 2.0f ? 1.0f : 2.0f / total[j];
  return scale;
}

// The low image with both axes' scales applied: texel * (scale_x * scale_y).
ImageF conserving_upsample_scale(const ImageF& low, int hw, int hh, const Exec& exec) {
  const std::vector<float> sx = upsample_scales(low.width(), hw);
  const std::vector<float> sy = upsample_scales(low.height(), hh);
  ImageF out(low.width(), low.height(), low.channels());
  parallel_rows(exec, low.height(), [&](int y) {
    for (int c = 0; c < low.channels(); ++c)
      for (int x = 0; x < low.width(); ++x)
        out.at(x, y, c) = low.at(x, y, c) * (sx[size_t(x)] * sy[size_t(y)]);
  });
  return out;
}

// Pixel (p, q) of plane c of the tent upsample of a scaled low image: the tent along x in each
// of the four low rows it reads, then along y.
float tent_upsample_at(const ImageF& scaled, int p, int q, int c) {
  const int x0 = tent_upsample_first_tap(p), y0 = tent_upsample_first_tap(q);
  float across[4];
  for (int b = 0; b < 4; ++b) {
    float row[4];
    for (int a = 0; a < 4; ++a) row[a] = texel_or_zero(scaled, x0 + a, y0 + b, c);
    across[b] = tent_upsample_3x3(row, p);
  }
  return tent_upsample_3x3(across, q);
}

// weight * add + up(low) at add's size, or up(low) at hw x hh when add is null.
ImageF upsample_accumulate(const ImageF& low, int hw, int hh, const ImageF* add, float weight,
                           const Exec& exec) {
  const ImageF scaled = conserving_upsample_scale(low, hw, hh, exec);
  ImageF out(hw, hh, low.channels());
  parallel_rows(exec, hh, [&](int q) {
    for (int c = 0; c < low.channels(); ++c)
      for (int p = 0; p < hw; ++p) {
        const float up = tent_upsample_at(scaled, p, q, c);
        out.at(p, q, c) = add ? weight * add->at(p, q, c) + up : up;
      }
  });
  return out;
}

// L: acc_n = w mip_n, acc_k = w mip_k + up(acc_{k+1}) for k = n-1 .. 1 (w = 1 / n), and
// L = up(acc_1) at the source's size.
ImageF scattered_light(const ImageF& source, const std::vector<ImageF>& mips, const Exec& exec) {
  const int n = int(mips.size()) - 1;
  const float w = 1.0f / float(n);
  ImageF acc = mips[size_t(n)];
  for (float& v : acc.data()) v = v * w;
  for (int k = n - 1; k >= 1; --k) {
    const ImageF& m = mips[size_t(k)];
    acc = upsample_accumulate(acc, m.width(), m.height(), &m, w, exec);
  }
  return upsample_accumulate(acc, source.width(), source.height(), nullptr, 0.0f, exec);
}

// ---- Composite ---------------------------------------------------------------------------------

// out = hdr - intensity P + intensity scale L.
float composite(float hdr, float source, float light, const BloomSettings& s) {
  const float a = s.intensity, b = s.intensity * s.scale;
  return (hdr - a * source) + b * light;
}

}  // namespace

ImageF bloom_source_reference(const ImageF& hdr, const BloomSettings& s, const Exec& exec) {
  s.validate();
  check_image(hdr, "input");
  return source_image(hdr, s, exec);
}

std::vector<ImageF> bloom_mips_reference(const ImageF& source, const BloomSettings& s,
                                         const Exec& exec) {
  check_image(source, "source");
  s.validate();
  std::vector<ImageF> mips = downsample_chain(source, s, exec);
  mips[0] = source;
  return mips;
}

ImageF bloom_blur_reference(const ImageF& source, const BloomSettings& s, const Exec& exec) {
  check_image(source, "source");
  s.validate();
  return scattered_light(source, downsample_chain(source, s, exec), exec);
}

ImageF bloom_composite_reference(const ImageF& hdr, const ImageF& source, const ImageF& light,
                                 const BloomSettings& s, const Exec& exec) {
  s.validate();
  check_image(hdr, "input");
  if (!hdr.same_shape(source) || !hdr.same_shape(light))
    throw InputError("bloom: input, source and light images differ in shape");
  ImageF out(hdr.width(), hdr.height(), hdr.channels());
  parallel_rows(exec, hdr.height(), [&](int y) {
    for (int c = 0; c < hdr.channels(); ++c)
      for (int x = 0; x < hdr.width(); ++x)
        out.at(x, y, c) = composite(hdr.at(x, y, c), source.at(x, y, c), light.at(x, y, c), s);
  });
  return out;
}

namespace {

// The whole pass, written over *own when own is hdr (the caller gave it up), else into a new
// image; `then` on each finished row. Each band of rows makes its RowFn before it writes a row,
// and a RowPass reads its input no more once one is made (post/row_pass.h): writing over hdr
// changes nothing `then` reads.
ImageF whole_pass(const ImageF& hdr, ImageF* own, const BloomSettings& s, const Exec& exec,
                  const RowPass& then) {
  s.validate();
  check_image(hdr, "input");
  if (then && hdr.channels() != 3)
    throw InputError(
        fmt::format("bloom: a row pass needs RGB (3 planes), the image has {}", hdr.channels()));
  // No input rows are handed to `then`: it reads the input itself.
  if (then.input_done) then.input_done();
  if (s.intensity <= 0.0f) {
    if (!own) return apply_row_pass(hdr, then, exec);
    apply_row_pass_in_place(*own, then, exec);
    return std::move(*own);
  }
  const ImageF p = source_image(hdr, s, exec);
  const ImageF light = scattered_light(p, downsample_chain(p, s, exec), exec);
  const int w = hdr.width(), h = hdr.height();
  ImageF out = own ? ImageF() : ImageF(w, h, hdr.channels());
  ImageF& dst = own ? *own : out;
  constexpr int kBand = 8;
  parallel_rows(exec, (h + kBand - 1) / kBand, [&](int band) {
    const RowFn fn = then ? then() : RowFn{};
    for (int y = band * kBand; y < std::min(h, (band + 1) * kBand); ++y) {
      for (int c = 0; c < hdr.channels(); ++c)
        for (int x = 0; x < w; ++x)
          dst.at(x, y, c) = composite(hdr.at(x, y, c), p.at(x, y, c), light.at(x, y, c), s);
      if (!fn) continue;
      for_each_row_piece(w, [&](int x0, int n) {
        float* const rows[3] = {dst.row(0, y) + x0, dst.row(1, y) + x0, dst.row(2, y) + x0};
        fn(y, x0, rows, n);
      });
    }
  });
  if (own) return std::move(*own);
  return out;
}

}  // namespace

ImageF bloom_mip_chain_reference(const ImageF& hdr, const BloomSettings& s, const Exec& exec) {
  return whole_pass(hdr, nullptr, s, exec, RowPass{});
}
ImageF bloom_mip_chain_reference(const ImageF& hdr, const BloomSettings& s, const Exec& exec,
                                 const RowPass& then) {
  return whole_pass(hdr, nullptr, s, exec, then);
}
ImageF bloom_mip_chain_reference(ImageF&& hdr, const BloomSettings& s, const Exec& exec,
                                 const RowPass& then) {
  return whole_pass(hdr, &hdr, s, exec, then);
}

}  // namespace afterimage::post
