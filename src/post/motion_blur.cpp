#include "post/motion_blur.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/lanes.h"
#include "reproject/forward.h"

namespace afterimage::post {

namespace {

// Per-pixel jitter in [-0.5, 0.5): a hash of the pixel (deterministic, thread-independent).
double pixel_jitter(int x, int y) {
  uint32_t h = uint32_t(x) * 0x8da6b343u ^ uint32_t(y) * 0xd8163841u;
  h ^= h >> 15;
  h *= 0x2c1b3c6du;
  h ^= h >> 12;
  return double(h >> 8) * (1.0 / 16777216.0) - 0.5;
}

// A second, independent per-pixel value in [-0.5, 0.5) (other constants): the tile lookup's
// jitter must not correlate with the tap jitter.
double pixel_jitter2(int x, int y, uint32_t salt) {
  uint32_t h = (uint32_t(x) * 0x9e3779b1u + salt) ^ uint32_t(y) * 0x85ebca77u;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return double(h >> 8) * (1.0 / 16777216.0) - 0.5;
}

double length(Vec2d v) {
  return std::sqrt(v.x * v.x + v.y * v.y);
}

// Tile of the NeighborMax lookup for pixel coordinate x: its own, or (Jimenez 2014) the one
// under x + 0.5 + an offset of up to `jitter` tiles, inside the grid.
int jittered_tile(int x, double offset_tiles, int k, int tiles) {
  if (offset_tiles == 0.0) return x / k;
  const int t = int(std::floor((x + 0.5) / k + offset_tiles));
  return std::clamp(t, 0, tiles - 1);
}

// TileMax of one tile (or NeighborMax of 3x3 tiles) and the box that holds all of their half
// vectors: a small box means the neighbourhood moves as one (the fast path).
struct VelocityTile {
  Vec2d longest{0, 0};
  double min_x = HUGE_VAL, max_x = -HUGE_VAL, min_y = HUGE_VAL, max_y = -HUGE_VAL;
  void add(Vec2d c) {
    if (length(c) > length(longest)) longest = c;
    min_x = std::min(min_x, c.x);
    max_x = std::max(max_x, c.x);
    min_y = std::min(min_y, c.y);
    max_y = std::max(max_y, c.y);
  }
  void merge(const VelocityTile& t) {
    if (length(t.longest) > length(longest)) longest = t.longest;
    min_x = std::min(min_x, t.min_x);
    max_x = std::max(max_x, t.max_x);
    min_y = std::min(min_y, t.min_y);
    max_y = std::max(max_y, t.max_y);
  }
  bool uniform(double tolerance) const {
    return max_x - min_x <= tolerance && max_y - min_y <= tolerance;
  }
};

// ---- The reconstruction at the lanes of one block (core/simd.h): pixels x .. x + lanes - 1
// of one row, all of the same path. Float arithmetic, the same order at every width, so the
// 1-lane path (--simd off) gives the same bits.

// What a pixel's row pre-pass found: its NeighborMax vector, its tap jitter in [-0.5, 0.5) and
// its path.
enum PixelPath : uint8_t { kCopy = 0, kFast = 1, kFull = 2 };
struct BlurRow {
  std::vector<float> vx, vy, jitter;
  std::vector<uint8_t> path;
};
struct BlurPlanes {
  int w, h;
  const float *len, *depth, *color[3];
};

// clamp(1 - (z_a - z_b) / (extent * min(z_a, z_b)), 0, 1) (soft_depth_compare).
template <class D>
HWY_INLINE V<D> soft_depth_compare_lanes(D d, V<D> za, V<D> zb, float extent) {
  const V<D> r = hn::Sub(hn::Set(d, 1.0f),
                         hn::Div(hn::Sub(za, zb), hn::Mul(hn::Set(d, extent), hn::Min(za, zb))));
  return hn::Min(hn::Max(r, hn::Zero(d)), hn::Set(d, 1.0f));
}
// clamp(1 - distance / |v|, 0, 1) (cone_weight; |v| >= 0.5 here).
template <class D>
HWY_INLINE V<D> cone_lanes(D d, V<D> dist, V<D> len) {
  return hn::Min(hn::Max(hn::Sub(hn::Set(d, 1.0f), hn::Div(dist, len)), hn::Zero(d)),
                 hn::Set(d, 1.0f));
}
// 1 - smoothstep(0.95 |v|, 1.05 |v|, distance) (cylinder_weight).
template <class D>
HWY_INLINE V<D> cylinder_lanes(D d, V<D> dist, V<D> len) {
  const V<D> t = hn::Min(hn::Max(hn::Div(hn::Sub(dist, hn::Mul(hn::Set(d, 0.95f), len)),
                                         hn::Mul(hn::Set(d, 0.1f), len)),
                                 hn::Zero(d)),
                         hn::Set(d, 1.0f));
  return hn::Sub(hn::Set(d, 1.0f),
                 hn::Mul(hn::Mul(t, t), hn::Sub(hn::Set(d, 3.0f), hn::Add(t, t))));
}

// Flat index of tap p on side `sign` of every lane: (p + 0.5 + 0.5 j) / pairs of the way along
// +-vn, rounded to a pixel inside the image; also its offset from the lane's pixel.
template <class D>
HWY_INLINE VI<D> tap_index(D d, const BlurPlanes& pl, V<D> xs, V<D> ys, V<D> vx, V<D> vy, V<D> jit,
                           int p, float sign, int pairs, VI<D>& dx, VI<D>& dy) {
  const hn::RebindToSigned<D> di;
  const V<D> t =
      hn::Mul(hn::Set(d, sign),
              hn::Div(hn::Add(hn::Set(d, float(p) + 0.5f), hn::Mul(hn::Set(d, 0.5f), jit)),
                      hn::Set(d, float(pairs))));
  const V<D> half = hn::Set(d, 0.5f);
  const VI<D> px =
      hn::Min(hn::Max(hn::ConvertTo(di, hn::Floor(hn::Add(hn::Add(xs, hn::Mul(t, vx)), half))),
                      hn::Zero(di)),
              hn::Set(di, pl.w - 1));
  const VI<D> py =
      hn::Min(hn::Max(hn::ConvertTo(di, hn::Floor(hn::Add(hn::Add(ys, hn::Mul(t, vy)), half))),
                      hn::Zero(di)),
              hn::Set(di, pl.h - 1));
  dx = hn::Sub(px, hn::ConvertTo(di, xs));  // xs, ys: whole numbers (the lanes' pixels)
  dy = hn::Sub(py, hn::ConvertTo(di, ys));
  return hn::Add(hn::Mul(py, hn::Set(di, pl.w)), px);
}

// Fast path: the equal-weight mean of the taps (the box filter along the motion).
template <class D>
HWY_INLINE void box_block(D d, const BlurPlanes& pl, const BlurRow& row, int x, int y, int pairs,
                          float* const dst[3]) {
  const V<D> xs = iota_from(d, float(x)), ys = hn::Set(d, float(y));
  const V<D> vx = hn::LoadU(d, row.vx.data() + x), vy = hn::LoadU(d, row.vy.data() + x),
             jit = hn::LoadU(d, row.jitter.data() + x);
  V<D> sum[3] = {hn::Zero(d), hn::Zero(d), hn::Zero(d)};
  for (int p = 0; p < pairs; ++p)
    for (const float sign : {-1.0f, 1.0f}) {
      VI<D> dx, dy;
      const VI<D> idx = tap_index(d, pl, xs, ys, vx, vy, jit, p, sign, pairs, dx, dy);
      for (int c = 0; c < 3; ++c) sum[c] = hn::Add(sum[c], hn::GatherIndex(d, pl.color[c], idx));
    }
  const V<D> n = hn::Set(d, float(2 * pairs));
  for (int c = 0; c < 3; ++c) hn::StoreU(hn::Div(sum[c], n), d, dst[c] + x);
}

// Full path (McGuire et al. 2012, Sec. 3.3): the pixel weighted 1 / |V_X|, each tap by a
// blurry tap in front reaching this pixel, a tap behind a blurry pixel (the background it
// uncovers) and both blurry together; taps on the pixel itself count once, as the pixel.
// With `mirror`, Jimenez 2014's mirrored pair weights (see mirror_weights).
template <class D>
HWY_INLINE void full_block(D d, const BlurPlanes& pl, const BlurRow& row, int x, int y, int pairs,
                           float soft_depth, bool mirror, float* const dst[3]) {
  const hn::RebindToSigned<D> di;
  const V<D> xs = iota_from(d, float(x)), ys = hn::Set(d, float(y));
  const VI<D> self = iota_from(di, y * pl.w + x);
  const size_t ix = size_t(y) * size_t(pl.w) + size_t(x);
  const V<D> vx = hn::LoadU(d, row.vx.data() + x), vy = hn::LoadU(d, row.vy.data() + x),
             jit = hn::LoadU(d, row.jitter.data() + x);
  const V<D> lx = hn::LoadU(d, pl.len + ix), zx = hn::LoadU(d, pl.depth + ix);
  V<D> weight = hn::Div(hn::Set(d, 1.0f), lx), sum[3];
  for (int c = 0; c < 3; ++c) sum[c] = hn::Mul(hn::LoadU(d, pl.color[c] + ix), weight);
  for (int p = 0; p < pairs; ++p) {
    VI<D> idx[2];
    V<D> a[2], z[2], l[2];
    hn::Mask<D> on_self[2];
    for (int side = 0; side < 2; ++side) {
      VI<D> dx, dy;
      idx[side] = tap_index(d, pl, xs, ys, vx, vy, jit, p, side == 0 ? -1.0f : 1.0f, pairs, dx, dy);
      on_self[side] = hn::RebindMask(d, hn::Eq(idx[side], self));
      z[side] = hn::GatherIndex(d, pl.depth, idx[side]);
      l[side] = hn::GatherIndex(d, pl.len, idx[side]);
      const V<D> dist = hn::Sqrt(hn::ConvertTo(d, hn::Add(hn::Mul(dx, dx), hn::Mul(dy, dy))));
      const V<D> w = hn::Add(hn::Add(hn::Mul(soft_depth_compare_lanes(d, z[side], zx, soft_depth),
                                             cone_lanes(d, dist, l[side])),
                                     hn::Mul(soft_depth_compare_lanes(d, zx, z[side], soft_depth),
                                             cone_lanes(d, dist, lx))),
                             hn::Mul(hn::Set(d, 2.0f), hn::Mul(cylinder_lanes(d, dist, l[side]),
                                                               cylinder_lanes(d, dist, lx))));
      a[side] = hn::IfThenZeroElse(on_self[side], w);
    }
    if (mirror) {
      // The tap in front that moves at least as fast lends its weight to its partner.
      const auto behind = hn::Gt(z[0], z[1]), faster = hn::Gt(l[1], l[0]);
      const V<D> m0 = hn::IfThenElse(hn::And(behind, faster), a[1], a[0]);
      const V<D> m1 = hn::IfThenElse(hn::Or(behind, faster), a[1], a[0]);
      a[0] = hn::IfThenZeroElse(on_self[0], m0);
      a[1] = hn::IfThenZeroElse(on_self[1], m1);
    }
    for (int side = 0; side < 2; ++side) {
      const auto used = hn::Gt(a[side], hn::Zero(d));
      weight = hn::Add(weight, hn::IfThenElseZero(used, a[side]));
      for (int c = 0; c < 3; ++c)
        sum[c] = hn::Add(
            sum[c],
            hn::IfThenElseZero(used, hn::Mul(a[side], hn::GatherIndex(d, pl.color[c], idx[side]))));
    }
  }
  for (int c = 0; c < 3; ++c) hn::StoreU(hn::Div(sum[c], weight), d, dst[c] + x);
}

void check_frame(const Frame& f, const ImageF* color) {
  if (!f.has_depth() || !f.has_motion())
    throw InputError(fmt::format("motion_blur: frame {} needs depth and motion", f.index));
  if (color && (color->width() != f.width || color->height() != f.height || color->channels() != 3))
    throw InputError(fmt::format("motion_blur: frame {} is {}x{}, its color {}x{}x{}", f.index,
                                 f.width, f.height, color->width(), color->height(),
                                 color->channels()));
}

// The half vector of every pixel (row-major).
std::vector<Vec2d> half_vectors(const Frame& f, const MotionBlurSettings& s,
                                const FrameHeader* previous, const Exec& exec) {
  const int w = f.width, h = f.height, k = s.max_radius;
  std::vector<Vec2d> v(size_t(w) * size_t(h));
  if (!splits_camera_motion(s)) {
    parallel_rows(exec, h, [&](int y) {
      for (int x = 0; x < w; ++x)
        v[size_t(y) * size_t(w) + size_t(x)] =
            blur_half_vector(f.motion.at(x, y, 0), f.motion.at(x, y, 1), s.shutter, k);
    });
    return v;
  }
  // No previous camera of this size: nothing is known about the camera's motion, so all of
  // the motion is object motion (camera part zero).
  const bool known = previous && previous->width == w && previous->height == h;
  reproject::CameraTransfer full, translation;
  if (known) {
    full = reproject::CameraTransfer::between(f, *previous);
    FrameHeader turned = *previous;
    turned.view = view_without_rotation_change(previous->view, f.view);
    translation = reproject::CameraTransfer::between(f, turned);
  }
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const Vec2d m{f.motion.at(x, y, 0), f.motion.at(x, y, 1)};
      if (!std::isfinite(m.x) || !std::isfinite(m.y)) {
        v[size_t(y) * size_t(w) + size_t(x)] = {0, 0};  // unknown motion: still, as unsplit
        continue;
      }
      Vec2d cam{0, 0}, cam_blur{0, 0};
      if (known) {
        // Motion vectors are for unjittered positions: the camera part at the pixel center.
        const Vec2d p{x + 0.5, y + 0.5};
        const float d = f.depth.at(x, y, 0);
        const reproject::Reprojected r = reproject::camera_displacement(full, p, d);
        if (r.valid) {
          cam = r.displacement;
          cam_blur = cam;
          if (!s.camera_rotation) {
            const reproject::Reprojected t = reproject::camera_displacement(translation, p, d);
            cam_blur = t.valid ? t.displacement : Vec2d{0, 0};
          }
        }
      }
      v[size_t(y) * size_t(w) + size_t(x)] = split_blur_half_vector(
          m, cam, cam_blur, s.shutter, s.camera_max_radius, s.object_max_radius, k);
    }
  });
  return v;
}

}  // namespace

const ParamTable<MotionBlurSettings>& MotionBlurSettings::params() {
  static const ParamTable<MotionBlurSettings> kTable = [] {  // immutable once built
    using S = MotionBlurSettings;
    ParamTable<S> t("motion_blur");
    t.add_float("shutter", &S::shutter, 0.0f, 1.0f,
                "fraction of the frame interval the shutter is open (0.5 = 180 degrees)");
    t.add_int("max_radius", &S::max_radius, 1, 256,
              "half-length clamp of the blur in pixels, also the tile size");
    t.add_int("samples", &S::samples, 3, 63, "taps along the dominant velocity (odd)");
    t.add_float("soft_depth", &S::soft_depth, 1e-4f, 10.0f,
                "relative depth extent of the soft front/back comparison");
    t.add_int("camera_max_radius", &S::camera_max_radius, 0, 256,
              "clamp of the camera-motion half vector in pixels (0: none, only max_radius)");
    t.add_int("object_max_radius", &S::object_max_radius, 0, 256,
              "clamp of the object-motion half vector in pixels (0: none, only max_radius)");
    t.add_bool("camera_rotation", &S::camera_rotation,
               "false: the camera's rotation does not blur, only its translation and objects");
    t.add_int("trail_frames", &S::trail_frames, 1, 32,
              "running-sum trail over the last N frames (seed 004); 1 = off");
    t.add_float("tile_jitter", &S::tile_jitter, 0.0f, 0.5f,
                "per-pixel offset of the NeighborMax lookup in tiles (Jimenez 2014); 0 = none");
    t.add_float("uniform_tolerance", &S::uniform_tolerance, 0.0f, 64.0f,
                "fast path where the neighbourhood's half vectors agree within this many pixels "
                "per axis (box filter, no depth test; Jimenez 2014); 0 = always the full path");
    t.add_bool("mirror_weights", &S::mirror_weights,
               "Jimenez 2014 mirrored tap-pair weights (the faster tap in front lends its weight)");
    t.check([](const S& s) {
      return s.samples % 2 == 1 ? std::string() : fmt::format("samples {} must be odd", s.samples);
    });
    return t;
  }();
  return kTable;
}
void MotionBlurSettings::set_assignment(const std::string& assignment) {
  params().set_assignment(*this, assignment);
}
void MotionBlurSettings::validate() const {
  params().validate(*this);
}

Mat4 view_without_rotation_change(const Mat4& previous, const Mat4& current) {
  // The previous camera's position C (world), seen with the current rotation R: x -> R (x - C).
  const Vec3d c = previous.inverse().transform_point({0, 0, 0});
  Mat4 v = current;
  const Vec3d rc = current.transform_dir(c);
  v.m[0][3] = -rc.x;
  v.m[1][3] = -rc.y;
  v.m[2][3] = -rc.z;
  return v;
}

bool splits_camera_motion(const MotionBlurSettings& s) {
  return s.camera_max_radius > 0 || s.object_max_radius > 0 || !s.camera_rotation;
}
bool keeps_frames(const MotionBlurSettings& s) {
  return splits_camera_motion(s) || s.trail_frames > 1;
}

ImageF motion_blur_half_vectors(const Frame& f, const MotionBlurSettings& s,
                                const FrameHeader* previous, const Exec& exec) {
  s.validate();
  check_frame(f, nullptr);
  const std::vector<Vec2d> v = half_vectors(f, s, previous, exec);
  ImageF out(f.width, f.height, 2);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const Vec2d& c = v[size_t(y) * size_t(f.width) + size_t(x)];
      out.at(x, y, 0) = float(c.x);
      out.at(x, y, 1) = float(c.y);
    }
  return out;
}

ImageF motion_blur(const Frame& f, const ImageF& color, const MotionBlurSettings& s,
                   const Exec& exec) {
  return motion_blur(f, color, s, nullptr, exec);
}

ImageF motion_blur(const Frame& f, const ImageF& color, const MotionBlurSettings& s,
                   const FrameHeader* previous, const Exec& exec) {
  s.validate();
  check_frame(f, &color);
  const int w = color.width(), h = color.height(), k = s.max_radius;
  const std::vector<Vec2d> v = half_vectors(f, s, previous, exec);
  // |V| of every pixel, floored at half a pixel as McGuire's weights need (computed once: the
  // taps read it up to samples times).
  std::vector<float> len(v.size());
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      len[i] = float(std::max(length(v[i]), 0.5));
    }
  });
  // TileMax / NeighborMax: the longest half vector of each k x k tile and of the 3x3 tiles
  // around, with the box that holds all their half vectors (the fast path's test).
  const int tw = (w + k - 1) / k, th = (h + k - 1) / k;
  std::vector<VelocityTile> tile(size_t(tw) * size_t(th)), neighbor(tile.size());
  parallel_rows(exec, th, [&](int ty) {
    for (int tx = 0; tx < tw; ++tx) {
      VelocityTile t;
      for (int y = ty * k; y < std::min(h, (ty + 1) * k); ++y)
        for (int x = tx * k; x < std::min(w, (tx + 1) * k); ++x)
          t.add(v[size_t(y) * size_t(w) + size_t(x)]);
      tile[size_t(ty) * size_t(tw) + size_t(tx)] = t;
    }
  });
  parallel_rows(exec, th, [&](int ty) {
    for (int tx = 0; tx < tw; ++tx) {
      VelocityTile n;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int ux = tx + dx, uy = ty + dy;
          if (ux < 0 || uy < 0 || ux >= tw || uy >= th) continue;
          n.merge(tile[size_t(uy) * size_t(tw) + size_t(ux)]);
        }
      neighbor[size_t(ty) * size_t(tw) + size_t(tx)] = n;
    }
  });

  ImageF out = color;
  const int pairs = (s.samples - 1) / 2;
  const BlurPlanes planes{
      w, h, len.data(), f.depth.plane(0), {color.plane(0), color.plane(1), color.plane(2)}};
  parallel_rows(exec, h, [&](int y) {
    // Row pre-pass: each pixel's NeighborMax (through the jittered tile lookup), tap jitter and
    // path — still neighbourhood: copy (early exit); one that moves as one: fast; else full.
    BlurRow row;
    row.vx.resize(size_t(w));
    row.vy.resize(size_t(w));
    row.jitter.resize(size_t(w));
    row.path.resize(size_t(w));
    for (int x = 0; x < w; ++x) {
      const double jt = s.tile_jitter;
      const int tx = jittered_tile(x, jt == 0 ? 0.0 : 2.0 * jt * pixel_jitter2(x, y, 1u), k, tw);
      const int ty = jittered_tile(y, jt == 0 ? 0.0 : 2.0 * jt * pixel_jitter2(x, y, 2u), k, th);
      const VelocityTile& nb = neighbor[size_t(ty) * size_t(tw) + size_t(tx)];
      row.vx[size_t(x)] = float(nb.longest.x);
      row.vy[size_t(x)] = float(nb.longest.y);
      row.jitter[size_t(x)] = float(pixel_jitter(x, y));
      row.path[size_t(x)] = length(nb.longest) <= 0.5                                    ? kCopy
                            : s.uniform_tolerance > 0 && nb.uniform(s.uniform_tolerance) ? kFast
                                                                                         : kFull;
    }
    float* dst[3] = {out.row(0, y), out.row(1, y), out.row(2, y)};
    const auto one_pixel = [&](int x) {
      const OneTag d1;
      if (row.path[size_t(x)] == kFast)
        box_block(d1, planes, row, x, y, pairs, dst);
      else if (row.path[size_t(x)] == kFull)
        full_block(d1, planes, row, x, y, pairs, s.soft_depth, s.mirror_weights, dst);
    };
    for_each_lane_block(exec, w, [&](auto d, int x) {
      const int n = int(hn::Lanes(d));
      if (n == 1) return one_pixel(x);
      const uint8_t first = row.path[size_t(x)];
      bool same = true;
      for (int i = 1; i < n; ++i) same = same && row.path[size_t(x + i)] == first;
      if (!same) {
        for (int i = 0; i < n; ++i) one_pixel(x + i);  // a mixed block: pixel by pixel
      } else if (first == kFast) {
        box_block(d, planes, row, x, y, pairs, dst);
      } else if (first == kFull) {
        full_block(d, planes, row, x, y, pairs, s.soft_depth, s.mirror_weights, dst);
      }
    });
  });
  return out;
}

void RunningSumTrail::reset() {
  window_.clear();
  sum_.clear();
  pushes_since_rebuild_ = 0;
}

ImageF RunningSumTrail::push(const ImageF& image, int frames, const Exec& exec) {
  AI_CHECK(frames >= 1);
  const auto finite = [](float v) { return std::isfinite(v) ? double(v) : 0.0; };
  if (!window_.empty() &&
      (window_.front().width() != image.width() || window_.front().height() != image.height() ||
       window_.front().channels() != image.channels() || int(window_.size()) > frames))
    reset();  // another size, or a shorter window: start again
  const size_t n = image.data().size();
  if (sum_.empty()) sum_.assign(n, 0.0);
  window_.push_back(image);
  const bool leaves = int(window_.size()) > frames;
  const ImageF* oldest = leaves ? &window_.front() : nullptr;
  const bool rebuild = ++pushes_since_rebuild_ >= frames;
  const int count = leaves ? frames : int(window_.size());
  ImageF out(image.width(), image.height(), image.channels());
  parallel_rows(exec, image.height(), [&](int y) {
    for (int c = 0; c < image.channels(); ++c)
      for (int x = 0; x < image.width(); ++x) {
        const size_t i =
            (size_t(c) * size_t(image.height()) + size_t(y)) * size_t(image.width()) + size_t(x);
        double& sum = sum_[i];
        if (rebuild) {
          // Once per turn of the window: the exact sum of what it holds (oldest first).
          sum = 0.0;
          for (size_t k = leaves ? 1 : 0; k < window_.size(); ++k)
            sum += finite(window_[k].data()[i]);
        } else {
          sum += finite(image.data()[i]);
          if (oldest) sum -= finite(oldest->data()[i]);
        }
        out.data()[i] = float(sum / count);
      }
  });
  if (rebuild) pushes_since_rebuild_ = 0;
  if (leaves) window_.pop_front();
  return out;
}

void MotionBlurSequence::reset() {
  has_previous_ = false;
  trail_.reset();
}

ImageF MotionBlurSequence::process(const Frame& frame, const ImageF& color,
                                   const MotionBlurSettings& s, const Exec& exec) {
  const bool restart = frame.camera_cut || !has_previous_ || previous_.width != frame.width ||
                       previous_.height != frame.height;
  if (restart) trail_.reset();
  ImageF out = motion_blur(frame, color, s, restart ? nullptr : &previous_, exec);
  previous_ = frame;  // the header part
  has_previous_ = true;
  if (s.trail_frames > 1) return trail_.push(out, s.trail_frames, exec);
  trail_.reset();  // trail off: no frames kept
  return out;
}

}  // namespace afterimage::post
