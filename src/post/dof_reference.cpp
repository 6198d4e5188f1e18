// The depth-of-field gather written plainly, one pixel at a time: the specification of the pass
// (dof.h), which the fast schedule (dof_gather_fast.cpp) computes bit for bit, and what
// `--simd off` runs. Scatter as you gather after Jimenez, "Next Generation Post Processing in
// Call of Duty: Advanced Warfare" (SIGGRAPH 2014; seed 004 "Depth of Field"): each pixel is a
// disc of its CoC radius holding its color evenly, and a pixel sums the discs that cover it.
#include <algorithm>
#include <cmath>
#include <cstddef>
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

}  // namespace

ImageF dof_reference(const Frame& f, const ImageF& color, const DofSettings& s, const Exec& exec) {
  const std::optional<ThinLens> thin = checked_dof_input(f, color, s);
  if (!thin) return color;
  if (s.mode != DofMode::gather || s.resolution != DofResolution::full)
    throw SettingsError("dof_reference: the gather at full resolution only");
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
  // The taps depend on the neighbourhood radius alone.
  std::map<float, SpiralTaps> taps_of;
  for (const float big : neighbor)
    if (big >= 0.5f && !taps_of.count(big)) taps_of[big] = spiral_taps(big, s.taps);

  ImageF out = color;
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const float big = neighbor[size_t(y / k) * size_t(tw) + size_t(x / k)];
      if (big < 0.5f) continue;  // the focus field: unchanged
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
  return out;
}

}  // namespace afterimage::post
