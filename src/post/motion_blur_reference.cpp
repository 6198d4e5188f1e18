// Motion blur written plainly, one pixel at a time: the specification of the pass
// (motion_blur.h), which the fast schedule (motion_blur_fast.cpp) computes bit for bit, and what
// `--simd off` runs. McGuire, Hennessy, Bukowski, Osman, "A Reconstruction Filter for Plausible
// Motion Blur" (I3D 2012; seed 004 "Motion Blur"), with Jimenez 2014's mirrored pair weights and
// box-filter fast path. The per-pixel reconstruction is in float, in the order of operations of
// the fast schedule's lanes; the half vectors and the tiles are in double.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "core/error.h"
#include "post/motion_blur.h"
#include "post/motion_blur_camera.h"
#include "post/tiles.h"
#include "reproject/forward.h"

namespace afterimage::post {

namespace {

// min and max as the x86 lanes take them (minps, maxps): the second operand where either is
// NaN. clamp01 is then 0 for NaN.
float lane_min(float a, float b) {
  return a < b ? a : b;
}
float lane_max(float a, float b) {
  return a > b ? a : b;
}
float clamp01(float v) {
  return lane_min(lane_max(v, 0.0f), 1.0f);
}

// cone_weight from inv_len = 1 / |v| (float): clamp(1 - distance / |v|, 0, 1).
float cone(float dist, float inv_len) {
  return clamp01(1.0f - dist * inv_len);
}
// cylinder_weight from inv_tenth = 1 / (0.1 |v|): 1 - smoothstep(0.95 |v|, 1.05 |v|, distance).
float cylinder(float dist, float len, float inv_tenth) {
  const float t = clamp01((dist - 0.95f * len) * inv_tenth);
  return 1.0f - (t * t) * (3.0f - (t + t));
}
// soft_depth_compare(z_a, z_b) and soft_depth_compare(z_b, z_a) in float from one quotient.
void soft_depth_pair(float za, float zb, float extent, float& ab, float& ba) {
  const float q = (za - zb) / (extent * lane_min(za, zb));
  ab = clamp01(1.0f - q);
  ba = clamp01(1.0f - -q);
}

// The pixel a tap reads: `fraction` (tap_fraction) of the way along +-(vx, vy) from pixel (x,
// y), rounded to the nearest pixel inside the image.
struct TapPixel {
  int x, y;
};
// (p + 0.5 + 0.5 j) / pairs: the way along the half vector of tap pair p (j: tap_jitter).
float tap_fraction(float jitter, int p, float pairs) {
  return ((float(p) + 0.5f) + 0.5f * jitter) / pairs;
}
TapPixel tap_pixel(int x, int y, float vx, float vy, float fraction, float sign, int w, int h) {
  const float t = sign * fraction;
  const float px = std::floor((float(x) + t * vx) + 0.5f);
  const float py = std::floor((float(y) + t * vy) + 0.5f);
  return {int(lane_min(lane_max(px, 0.0f), float(w - 1))),
          int(lane_min(lane_max(py, 0.0f), float(h - 1)))};
}

double length(Vec2d v) {
  return std::sqrt(v.x * v.x + v.y * v.y);
}

// TileMax / NeighborMax: the first longest half vector (in the order added) and their box.
void add_to_tile(MotionTile& t, Vec2d c) {
  if (length(c) > length(t.longest)) t.longest = c;
  t.min_x = std::min(t.min_x, c.x);
  t.max_x = std::max(t.max_x, c.x);
  t.min_y = std::min(t.min_y, c.y);
  t.max_y = std::max(t.max_y, c.y);
}
// Tile u added to tile n: u's longest replaces n's only if strictly longer, the boxes joined.
void merge_tiles(MotionTile& n, const MotionTile& u) {
  if (length(u.longest) > length(n.longest)) n.longest = u.longest;
  n.min_x = std::min(n.min_x, u.min_x);
  n.max_x = std::max(n.max_x, u.max_x);
  n.min_y = std::min(n.min_y, u.min_y);
  n.max_y = std::max(n.max_y, u.max_y);
}
MotionTile empty_tile() {
  return {{0, 0}, HUGE_VAL, -HUGE_VAL, HUGE_VAL, -HUGE_VAL};
}

// A pixel's reconstruction: copy (a still neighbourhood), the box filter (one that moves as
// one), or McGuire's full filter.
enum class Path { copy, box, full };
Path path_of(const MotionTile& nb, float uniform_tolerance) {
  if (length(nb.longest) <= 0.5) return Path::copy;
  const double tol = uniform_tolerance;
  const bool uniform = nb.max_x - nb.min_x <= tol && nb.max_y - nb.min_y <= tol;
  return uniform_tolerance > 0 && uniform ? Path::box : Path::full;
}

// What the reconstruction reads: per pixel |V| (floored at half a pixel), depth and color.
struct Planes {
  int w, h;
  const std::vector<float>& len;
  const ImageF& depth;
  const ImageF& color;
  size_t at(int x, int y) const { return size_t(y) * size_t(w) + size_t(x); }
};

// The fast path (Jimenez 2014): the equal-weight mean of the taps along the neighbourhood's
// half vector (vx, vy), ceil(|v| / spacing) pairs (1 .. pairs; spacing 0: pairs).
void box_filter(const Planes& pl, int x, int y, float vx, float vy, int pairs, float spacing,
                float out[3]) {
  float n = float(pairs);
  if (spacing > 0.0f) {
    const float len = std::sqrt(vx * vx + vy * vy);
    n = lane_min(lane_max(std::ceil(len / spacing), 1.0f), n);
  }
  const float jitter = tap_jitter(x, y);
  float sum[3] = {0.0f, 0.0f, 0.0f};
  for (int p = 0; p < int(n); ++p) {
    const float fraction = tap_fraction(jitter, p, n);
    for (const float sign : {-1.0f, 1.0f}) {
      const TapPixel q = tap_pixel(x, y, vx, vy, fraction, sign, pl.w, pl.h);
      for (int c = 0; c < 3; ++c) sum[c] += pl.color.at(q.x, q.y, c);
    }
  }
  for (int c = 0; c < 3; ++c) out[c] = sum[c] / (n + n);
}

// The full path (McGuire et al. 2012, Sec. 3.3): the pixel weighted 1 / |V_X|, each tap by a
// blurry tap in front reaching this pixel (cone of the tap's |V|), a tap behind a blurry pixel
// (the background it uncovers: cone of the pixel's |V|) and both blurry together (the
// cylinders); taps on the pixel itself count once, as the pixel. With `mirror`, Jimenez 2014's
// mirrored pair weights: the tap in front that moves at least as fast lends its weight to its
// partner.
void full_filter(const Planes& pl, int x, int y, float vx, float vy, int pairs, float soft_depth,
                 bool mirror, float out[3]) {
  const float lx = pl.len[pl.at(x, y)], zx = pl.depth.at(x, y, 0);
  const float inv_lx = 1.0f / lx, inv_tenth_lx = 1.0f / (0.1f * lx);
  float weight = inv_lx, sum[3];
  for (int c = 0; c < 3; ++c) sum[c] = pl.color.at(x, y, c) * weight;
  const float jitter = tap_jitter(x, y);
  for (int p = 0; p < pairs; ++p) {
    const float fraction = tap_fraction(jitter, p, float(pairs));
    TapPixel q[2];
    float a[2], z[2], l[2];
    bool on_self[2];
    for (int side = 0; side < 2; ++side) {
      q[side] = tap_pixel(x, y, vx, vy, fraction, side == 0 ? -1.0f : 1.0f, pl.w, pl.h);
      on_self[side] = q[side].x == x && q[side].y == y;
      z[side] = pl.depth.at(q[side].x, q[side].y, 0);
      l[side] = pl.len[pl.at(q[side].x, q[side].y)];
      const float dx = float(q[side].x - x), dy = float(q[side].y - y);
      const float dist = std::sqrt(dx * dx + dy * dy);
      float front, back;
      soft_depth_pair(z[side], zx, soft_depth, front, back);
      const float inv_l = 1.0f / l[side];
      const float w =
          (front * cone(dist, inv_l) + back * cone(dist, inv_lx)) +
          2.0f * (cylinder(dist, l[side], 10.0f * inv_l) * cylinder(dist, lx, inv_tenth_lx));
      a[side] = on_self[side] ? 0.0f : w;
    }
    if (mirror) {
      const bool behind = z[0] > z[1], faster = l[1] > l[0];
      const float m0 = behind && faster ? a[1] : a[0];
      const float m1 = behind || faster ? a[1] : a[0];
      a[0] = on_self[0] ? 0.0f : m0;
      a[1] = on_self[1] ? 0.0f : m1;
    }
    for (int side = 0; side < 2; ++side) {
      const bool used = a[side] > 0.0f;
      weight = weight + (used ? a[side] : 0.0f);
      for (int c = 0; c < 3; ++c)
        sum[c] = sum[c] + (used ? a[side] * pl.color.at(q[side].x, q[side].y, c) : 0.0f);
    }
  }
  for (int c = 0; c < 3; ++c) out[c] = sum[c] / weight;
}

// Every pixel's half vector (motion_blur_half_vectors, in double): blur_half_vector of its
// motion, or with the split, split_blur_half_vector of its camera and object parts.
std::vector<Vec2d> half_vectors(const Frame& f, const MotionBlurSettings& s,
                                const FrameHeader* previous) {
  const bool split = splits_camera_motion(s);
  const CameraMotionSplit camera(f, s, previous);
  std::vector<Vec2d> v(size_t(f.width) * size_t(f.height));
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const float mx = f.motion.at(x, y, 0), my = f.motion.at(x, y, 1);
      Vec2d& out = v[size_t(y) * size_t(f.width) + size_t(x)];
      if (!split) {
        out = blur_half_vector(mx, my, s.shutter, s.max_radius);
        continue;
      }
      out = {0, 0};  // non-finite motion: still
      if (!std::isfinite(mx) || !std::isfinite(my)) continue;
      const CameraMotion cam = camera.at(x, y, f.depth.at(x, y, 0));
      out = split_blur_half_vector({mx, my}, cam.full, cam.blur, s.shutter, s.camera_max_radius,
                                   s.object_max_radius, s.max_radius);
    }
  return v;
}

}  // namespace

ImageF motion_blur_reference(const Frame& f, const ImageF& color, const MotionBlurSettings& s,
                             const FrameHeader* previous, const Exec& exec) {
  s.validate();
  check_motion_blur_input(f, &color);
  check_motion_blur_camera(f, s);
  const int w = f.width, h = f.height, k = s.max_radius;
  const std::vector<Vec2d> v = half_vectors(f, s, previous);

  // TileMax over tiles of k x k pixels, then NeighborMax over each tile's 3x3 tiles.
  const int tw = (w + k - 1) / k, th = (h + k - 1) / k;
  std::vector<MotionTile> tile(size_t(tw) * size_t(th), empty_tile());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      add_to_tile(tile[size_t(y / k) * size_t(tw) + size_t(x / k)],
                  v[size_t(y) * size_t(w) + size_t(x)]);
  const std::vector<MotionTile> neighbor =
      tile_neighbor_reduce(tile, tw, th, empty_tile(), [](MotionTile n, const MotionTile& u) {
        merge_tiles(n, u);
        return n;
      });

  // |V| per pixel, floored at half a pixel as McGuire's weights need.
  std::vector<float> len(v.size());
  for (size_t i = 0; i < v.size(); ++i) len[i] = float(std::max(length(v[i]), 0.5));
  const Planes planes{w, h, len, f.depth, color};
  const int pairs = (s.samples - 1) / 2;
  ImageF out = color;
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      // NeighborMax at the pixel's tile, or (tile_jitter) at a tile near it.
      const double jt = s.tile_jitter;
      const int tx = jittered_tile(x, 2.0 * jt * tile_jitter_hash(x, y, 1u), k, tw);
      const int ty = jittered_tile(y, 2.0 * jt * tile_jitter_hash(x, y, 2u), k, th);
      const MotionTile& nb = neighbor[size_t(ty) * size_t(tw) + size_t(tx)];
      const float vx = float(nb.longest.x), vy = float(nb.longest.y);
      float o[3];
      switch (path_of(nb, s.uniform_tolerance)) {
        case Path::copy:
          continue;
        case Path::box:
          box_filter(planes, x, y, vx, vy, pairs, s.fast_tap_spacing, o);
          break;
        case Path::full:
          full_filter(planes, x, y, vx, vy, pairs, s.soft_depth, s.mirror_weights, o);
          break;
      }
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = o[c];
    }
  });
  return out;
}

}  // namespace afterimage::post
