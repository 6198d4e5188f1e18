// The depth-of-field gather written plainly, one pixel at a time: the specification of the pass
// (dof.h), which the fast schedule (dof_gather_fast.cpp) computes bit for bit, and what
// `--simd off` runs. Scatter as you gather after Jimenez, "Next Generation Post Processing in
// Call of Duty: Advanced Warfare" (SIGGRAPH 2014; seed 004 "Depth of Field"): each pixel is a
// disc of its CoC radius holding its color evenly, and a pixel sums the discs that cover it.
// resolution=half (composite_half_res): the tiles of large blur gathered over a CoC-aware 2x2
// downsample as a far and a near layer (Bukowski et al. 2013), upsampled and composited by CoC.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "camera/camera.h"
#include "core/error.h"
#include "post/dof.h"

namespace afterimage::post {

namespace {

// A gather tap: a whole-pixel offset (dx, dy) and how many spiral taps round to it.
struct PlainTap {
  int dx, dy;
  float count;
};
// The taps of a neighbourhood radius R, in row order (dy, then dx), and the spiral taps that
// round to the pixel itself (its own weight, at least 1).
struct SpiralTaps {
  std::vector<PlainTap> taps;
  float center = 0.0f;
};

// The golden-angle spiral over the unit disc (Vogel 1979: equal area a tap) scaled by R and
// rounded half away from zero to whole pixels, taps on the same pixel merged.
SpiralTaps spiral_taps(float big, int n_taps) {
  std::map<std::pair<int, int>, float> merged;  // (dy, dx): row order
  SpiralTaps s;
  for (int i = 0; i < n_taps; ++i) {
    const double rad = std::sqrt((i + 0.5) / n_taps), a = i * 2.39996322972865332;
    const int dx = int(std::lround(float(rad * std::cos(a)) * big));
    const int dy = int(std::lround(float(rad * std::sin(a)) * big));
    if (dx == 0 && dy == 0)
      s.center += 1.0f;
    else
      merged[{dy, dx}] += 1.0f;
  }
  for (const auto& [offset, count] : merged) s.taps.push_back({offset.second, offset.first, count});
  s.center = std::max(s.center, 1.0f);
  return s;
}

// A pixel's disc radius: its gather radius, at least half a pixel (a pixel covers itself).
float disc_radius(float raw) {
  return std::max(raw, 0.5f);
}

// The weight of tap q in pixel p's sum: its merged spiral taps times how far its disc, after the
// depth order, covers p (tap_coverage), spread over the disc's area (1 / r_q^2).
float tap_weight(float count, float dist, float r_q, float z_q, float r_p, float z_p) {
  return tap_coverage(count, effective_radius(r_q, z_q, r_p, z_p), tap_edge(count, dist)) *
         (1.0f / (r_q * r_q));
}

// The plane of one value per pixel.
struct Plane {
  int w, h;
  std::vector<float> v;
  float at(int x, int y) const { return v[size_t(y) * size_t(w) + size_t(x)]; }
};

// --- resolution=half: the large blurs gathered over a 2x2 downsample, composited by CoC ---

// The x86 vector max that the fast schedule's hn::Max(a, b) compiles to: b unless a is greater
// (also where either is NaN).
float max_x86(float a, float b) {
  return a > b ? a : b;
}

// A full-resolution tile takes the half-resolution layers where its neighbourhood is blurred
// (R >= 0.5: the focus field keeps its pixels) and R reaches half_from; the smaller blurs,
// which the 2x2 box and the bilinear upsample would widen, keep the full-resolution gather.
bool takes_half_res(float big, float half_from) {
  return big >= 0.5f && big >= half_from;
}

// A half pixel of the downsample: its 2x2 block's anchor's gather radius (half pixels, before
// the half-pixel floor) and depth, and the block's color.
struct HalfPixel {
  float raw, z, color[3];
};

// How much full pixel q counts in its 2x2 block's color, the block anchored at (r_a, z_a):
// fully at the anchor's depth or behind it, nearer by closeness of radius (1 - |r_q - r_a|,
// at least 0). A sharp foreground pixel then does not bleed into the blurred background
// behind it, while a near-field pixel is diluted by what lies behind it (CoC-aware, as the
// downsamples of Jimenez 2014 and UE4 are).
float downsample_weight(float r_q, float z_q, float r_a, float z_a) {
  return z_q >= z_a ? 1.0f : max_x86(1.0f - std::abs(r_q - r_a), 0.0f);
}

// Half pixel (hx, hy): the full pixels (2 hx .. 2 hx + 1, 2 hy .. 2 hy + 1), an odd size's last
// column or row paired with itself, anchored on the first (in row order) of their largest radii:
// the blur that reaches farthest survives the downsample, so a blurred field does not shrink at
// its edges. Its radius is half_res_radius of the anchor's (the resampling blurs too).
HalfPixel downsample(const Plane& raw, const Frame& f, const ImageF& color, int hx, int hy) {
  const int xs[2] = {2 * hx, std::min(raw.w - 1, 2 * hx + 1)};
  const int ys[2] = {2 * hy, std::min(raw.h - 1, 2 * hy + 1)};
  float r[4], z[4];
  for (int q = 0; q < 4; ++q) {
    r[q] = disc_radius(raw.at(xs[q % 2], ys[q / 2]));
    z[q] = f.depth.at(xs[q % 2], ys[q / 2], 0);
  }
  int a = 0;
  for (int q = 1; q < 4; ++q)
    if (r[q] > r[a]) a = q;
  float wsum = 0.0f, sum[3] = {0.0f, 0.0f, 0.0f};
  for (int q = 0; q < 4; ++q) {
    const float wq = downsample_weight(r[q], z[q], r[a], z[a]);
    wsum += wq;
    for (int c = 0; c < 3; ++c) sum[c] += wq * color.at(xs[q % 2], ys[q / 2], c);
  }
  HalfPixel p{half_res_radius(r[a]), z[a], {}};
  for (int c = 0; c < 3; ++c) p.color[c] = sum[c] / wsum;
  return p;
}

// A half pixel's gather split by depth order into Bukowski et al. 2013's fields: the far layer
// (the pixel itself and the taps behind it, which effective_radius clamps to its radius) and
// the near layer (the taps at its depth or in front, which keep their own), each divided by the
// whole gather's weight, and alpha, the near layer's share of that weight: its coverage of the
// sharp full-resolution color (HDRP and UE4 composite their half-resolution layers so).
struct HalfLayers {
  float far[3], near[3], alpha;
};

// Half pixel (x, y)'s layers: the full-resolution gather's taps and weights (tap_weight) over
// the half image, the taps outside it left out.
HalfLayers gather_layers(const std::vector<HalfPixel>& half, int hw, int hh, int x, int y,
                         const SpiralTaps& sp, const Bokeh& bokeh, float front_of) {
  const HalfPixel& p = half[size_t(y) * size_t(hw) + size_t(x)];
  const float r_p = disc_radius(p.raw);
  const float own = sp.center * (1.0f / (r_p * r_p));
  float wsum = own, wnear = 0.0f, far[3], near[3] = {0.0f, 0.0f, 0.0f};
  for (int c = 0; c < 3; ++c) far[c] = own * p.color[c];
  for (const PlainTap& t : sp.taps) {
    const int qx = x + t.dx, qy = y + t.dy;
    if (qx < 0 || qy < 0 || qx >= hw || qy >= hh) continue;
    const HalfPixel& q = half[size_t(qy) * size_t(hw) + size_t(qx)];
    // The side of the focus plane matters only to a bokeh whose sides differ (odd blades): a
    // disc's or an even polygon's distance is the same on both, and the fast layers take the
    // far side's.
    const float dist = bokeh_distance(bokeh, t.dx, t.dy, bokeh.flips() && q.z < front_of);
    const float wq = tap_weight(t.count, dist, disc_radius(q.raw), q.z, r_p, p.z);
    if (!(wq > 0.0f)) continue;  // as the full-resolution gather
    wsum += wq;
    const bool behind = q.z > p.z;
    if (!behind) wnear += wq;
    float* layer = behind ? far : near;
    for (int c = 0; c < 3; ++c) layer[c] = std::fma(wq, q.color[c], layer[c]);
  }
  const float inv = 1.0f / wsum;
  HalfLayers out{};
  for (int c = 0; c < 3; ++c) {
    out.far[c] = far[c] * inv;
    out.near[c] = near[c] * inv;
  }
  out.alpha = wnear * inv;
  return out;
}

// Full pixel (x, y)'s bilinear upsample of the half image's value(hx, hy): 3/4 of half pixel
// (x / 2, y / 2) and 1/4 of its neighbour on the pixel's side (x even: column x / 2 - 1, odd:
// x / 2 + 1; rows alike), clamped at the edges; down the columns first, then across.
template <class Value>
float upsample(int x, int y, int hw, int hh, Value&& value) {
  const int i = y / 2, j = y % 2 == 0 ? std::max(i - 1, 0) : std::min(i + 1, hh - 1);
  const int m = x / 2, n = x % 2 == 0 ? std::max(m - 1, 0) : std::min(m + 1, hw - 1);
  const auto column = [&](int hx) { return 0.75f * value(hx, i) + 0.25f * value(hx, j); };
  return 0.75f * column(m) + 0.25f * column(n);
}

// Whether a half pixel's near layer reaches a full pixel of blend a and depth z_p. A half pixel
// anchored on the blurred background beside an in-focus edge holds, in its near layer, what
// lies in front of that background, not in front of the sharp pixel: so in the focus field
// (a = 0) only the half pixels whose anchor is not behind the pixel. (Gating the blurred pixels
// as well measured worse on `focus`.)
bool near_layer_reaches(float a, float anchor_z, float z_p) {
  return a > 0.0f || anchor_z <= z_p;
}

// The composite at a full pixel (half_res_blend, dof.h): the near layer over the blurred far
// layer (weight a) and the sharp color ((1 - a)(1 - nf)); the sharp color itself, bit for bit,
// where neither layer reaches the pixel (a = 0, nf = 0).
float composite(float sharp, float a, float far, float near, float nf) {
  if (a == 0.0f && nf == 0.0f) return sharp;
  const float keep = (1.0f - a) * (1.0f - nf);
  return (keep * sharp + a * far) + near;
}

// The half-resolution layers composited into `out` at the full-resolution tiles (k x k, tw a
// row) marked in `coarse`. The half image's tiles are 2 kh x kh half pixels (kh = ceil(k / 2),
// at least the longest tap: twice as wide as tall, as the fast schedule's), each gathered with
// the taps of the largest radius of its 3x3 tiles (the pixel alone in its focus field).
void composite_half_res(const Frame& f, const ImageF& color, const Plane& raw,
                        const std::vector<uint8_t>& coarse, int k, int tw, const DofSettings& s,
                        const Bokeh& bokeh, float front_of, const Exec& exec, ImageF& out) {
  const int w = raw.w, h = raw.h, hw = (w + 1) / 2, hh = (h + 1) / 2;
  std::vector<HalfPixel> half(size_t(hw) * size_t(hh));
  parallel_rows(exec, hh, [&](int y) {
    for (int x = 0; x < hw; ++x)
      half[size_t(y) * size_t(hw) + size_t(x)] = downsample(raw, f, color, x, y);
  });
  const int kh = (k + 1) / 2, hkx = 2 * kh, htw = (hw + hkx - 1) / hkx, hth = (hh + kh - 1) / kh;
  std::vector<float> tile(size_t(htw) * size_t(hth), 0.0f);
  for (int y = 0; y < hh; ++y)
    for (int x = 0; x < hw; ++x) {
      float& t = tile[size_t(y / kh) * size_t(htw) + size_t(x / hkx)];
      t = std::max(t, half[size_t(y) * size_t(hw) + size_t(x)].raw);
    }
  const std::vector<float> neighbor = tile_neighbor_max(tile, htw, hth);
  std::map<float, SpiralTaps> taps_of;
  for (const float big : neighbor)
    if (big >= 0.5f && !taps_of.count(big)) taps_of[big] = spiral_taps(big, s.taps);
  std::vector<HalfLayers> layers(half.size());
  parallel_rows(exec, hh, [&](int y) {
    for (int x = 0; x < hw; ++x) {
      const float big = neighbor[size_t(y / kh) * size_t(htw) + size_t(x / hkx)];
      HalfLayers& l = layers[size_t(y) * size_t(hw) + size_t(x)];
      if (big < 0.5f) {  // the focus field: the pixel alone, no near layer
        l = {};
        for (int c = 0; c < 3; ++c) l.far[c] = half[size_t(y) * size_t(hw) + size_t(x)].color[c];
      } else {
        l = gather_layers(half, hw, hh, x, y, taps_of.at(big), bokeh, front_of);
      }
    }
  });
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      if (!coarse[size_t(y / k) * size_t(tw) + size_t(x / k)]) continue;
      const float a = half_res_blend(disc_radius(raw.at(x, y))), z_p = f.depth.at(x, y, 0);
      const auto at = [&](int hx, int hy) -> size_t {
        return size_t(hy) * size_t(hw) + size_t(hx);
      };
      // The near layer and its alpha from the half pixels that reach the pixel.
      const auto near_of = [&](auto value) {
        return upsample(x, y, hw, hh, [&](int hx, int hy) {
          return near_layer_reaches(a, half[at(hx, hy)].z, z_p) ? value(layers[at(hx, hy)]) : 0.0f;
        });
      };
      const float nf = near_of([](const HalfLayers& l) { return l.alpha; });
      for (int c = 0; c < 3; ++c) {
        const float far =
            upsample(x, y, hw, hh, [&](int hx, int hy) { return layers[at(hx, hy)].far[c]; });
        const float near = near_of([&](const HalfLayers& l) { return l.near[c]; });
        out.at(x, y, c) = composite(color.at(x, y, c), a, far, near, nf);
      }
    }
  });
}

}  // namespace

ImageF dof_reference(const Frame& f, const ImageF& color, const DofSettings& s, const Exec& exec) {
  const std::optional<ThinLens> thin = checked_dof_input(f, color, s);
  if (!thin) return color;
  if (s.mode != DofMode::gather) throw SettingsError("dof_reference: the gather only");
  const int w = color.width(), h = color.height(), k = s.max_radius;
  const bool ranges = s.coc == DofCoc::ranges;
  const CocLens lens(*thin, w, k);
  const CocRanges range(s);
  const Bokeh bokeh = lens_bokeh(*thin);
  // In front of the focus plane (its bokeh point-reflected) below this depth: the focus
  // distance, or near_end for the ranges (between them the radius is 0).
  const float front_of = ranges ? range.near_end : float(thin->focus_distance);
  const auto radius_of = [&](float z) {
    return ranges ? range_radius(z, range) : gather_radius(z, lens);
  };

  // Each pixel's gather radius, and the largest over each tile of k x k pixels and its 3x3
  // neighbours: how far a disc can reach into the tile (TileMax / NeighborMax).
  Plane raw{w, h, std::vector<float>(size_t(w) * size_t(h))};
  const int tw = (w + k - 1) / k, th = (h + k - 1) / k;
  std::vector<float> tile(size_t(tw) * size_t(th), 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float r = radius_of(f.depth.at(x, y, 0));
      raw.v[size_t(y) * size_t(w) + size_t(x)] = r;
      float& t = tile[size_t(y / k) * size_t(tw) + size_t(x / k)];
      t = std::max(t, r);
    }
  const std::vector<float> neighbor = tile_neighbor_max(tile, tw, th);
  // resolution=half: the tiles that take the half-resolution layers instead of the gather.
  const bool half = s.resolution == DofResolution::half;
  std::vector<uint8_t> coarse(neighbor.size(), 0);
  for (size_t t = 0; t < neighbor.size(); ++t)
    coarse[t] = half && takes_half_res(neighbor[t], s.half_from);
  // The taps depend on the neighbourhood radius alone.
  std::map<float, SpiralTaps> taps_of;
  for (size_t t = 0; t < neighbor.size(); ++t)
    if (neighbor[t] >= 0.5f && !coarse[t] && !taps_of.count(neighbor[t]))
      taps_of[neighbor[t]] = spiral_taps(neighbor[t], s.taps);

  ImageF out = color;
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t at = size_t(y / k) * size_t(tw) + size_t(x / k);
      const float big = neighbor[at];
      if (big < 0.5f) continue;  // the focus field: unchanged
      if (coarse[at]) continue;  // the half-resolution layers (composite_half_res)
      const SpiralTaps& sp = taps_of.at(big);
      const float r_p = disc_radius(raw.at(x, y)), z_p = f.depth.at(x, y, 0);
      // The pixel itself, spread over its own disc.
      const float own = sp.center * (1.0f / (r_p * r_p));
      float wsum = own, sum[3];
      for (int c = 0; c < 3; ++c) sum[c] = own * color.at(x, y, c);
      for (const PlainTap& t : sp.taps) {
        const int qx = x + t.dx, qy = y + t.dy;
        if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;  // nothing outside the image
        const float z_q = f.depth.at(qx, qy, 0);
        const float dist = bokeh_distance(bokeh, t.dx, t.dy, z_q < front_of);
        const float wq = tap_weight(t.count, dist, disc_radius(raw.at(qx, qy)), z_q, r_p, z_p);
        // Only a positive weight adds its colors (0 times an infinite color is NaN).
        if (!(wq > 0.0f)) continue;
        wsum += wq;
        for (int c = 0; c < 3; ++c) sum[c] = std::fma(wq, color.at(qx, qy, c), sum[c]);
      }
      const float inv = 1.0f / wsum;
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = sum[c] * inv;
    }
  });
  if (std::find(coarse.begin(), coarse.end(), uint8_t(1)) != coarse.end())
    composite_half_res(f, color, raw, coarse, k, tw, s, bokeh, front_of, exec, out);
  return out;
}

}  // namespace afterimage::post
