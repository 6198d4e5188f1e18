#include "post/motion_blur.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/error.h"

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

double length(Vec2d v) {
  return std::sqrt(v.x * v.x + v.y * v.y);
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

ImageF motion_blur(const Frame& f, const ImageF& color, const MotionBlurSettings& s,
                   const Exec& exec) {
  s.validate();
  if (!f.has_depth() || !f.has_motion())
    throw InputError(fmt::format("motion_blur: frame {} needs depth and motion", f.index));
  const int w = color.width(), h = color.height(), k = s.max_radius;
  if (w != f.width || h != f.height || color.channels() != 3)
    throw InputError(fmt::format("motion_blur: frame {} is {}x{}, its color {}x{}x{}", f.index,
                                 f.width, f.height, w, h, color.channels()));
  const size_t n = size_t(w) * size_t(h);
  std::vector<Vec2d> v(n);
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x)
      v[size_t(y) * size_t(w) + size_t(x)] =
          blur_half_vector(f.motion.at(x, y, 0), f.motion.at(x, y, 1), s.shutter, k);
  });
  // TileMax: the longest half vector of each k x k tile; NeighborMax: of the 3x3 tiles around.
  const int tw = (w + k - 1) / k, th = (h + k - 1) / k;
  std::vector<Vec2d> tile(size_t(tw) * size_t(th), Vec2d{0, 0}), neighbor(tile.size());
  parallel_rows(exec, th, [&](int ty) {
    for (int tx = 0; tx < tw; ++tx) {
      Vec2d best{0, 0};
      for (int y = ty * k; y < std::min(h, (ty + 1) * k); ++y)
        for (int x = tx * k; x < std::min(w, (tx + 1) * k); ++x) {
          const Vec2d c = v[size_t(y) * size_t(w) + size_t(x)];
          if (length(c) > length(best)) best = c;
        }
      tile[size_t(ty) * size_t(tw) + size_t(tx)] = best;
    }
  });
  parallel_rows(exec, th, [&](int ty) {
    for (int tx = 0; tx < tw; ++tx) {
      Vec2d best{0, 0};
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int ux = tx + dx, uy = ty + dy;
          if (ux < 0 || uy < 0 || ux >= tw || uy >= th) continue;
          const Vec2d c = tile[size_t(uy) * size_t(tw) + size_t(ux)];
          if (length(c) > length(best)) best = c;
        }
      neighbor[size_t(ty) * size_t(tw) + size_t(tx)] = best;
    }
  });

  ImageF out = color;
  const int pairs = (s.samples - 1) / 2;
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const Vec2d vn = neighbor[size_t(y / k) * size_t(tw) + size_t(x / k)];
      if (length(vn) <= 0.5) continue;  // nothing around moves half a pixel: unchanged
      const size_t ix = size_t(y) * size_t(w) + size_t(x);
      const double lx = std::max(length(v[ix]), 0.5), zx = f.depth.at(x, y, 0);
      // The pixel itself, weighted as McGuire's 1 / |V_X|.
      double weight = 1.0 / lx, sum[3];
      for (int c = 0; c < 3; ++c) sum[c] = color.at(x, y, c) * weight;
      const double j = pixel_jitter(x, y);
      for (int p = 0; p < pairs; ++p) {
        const double t = (p + 0.5 + 0.5 * j) / pairs;  // in (0, 1]; the pair at -t and +t
        for (double sign : {-1.0, 1.0}) {
          const int yx = std::clamp(int(std::lround(x + sign * t * vn.x)), 0, w - 1);
          const int yy = std::clamp(int(std::lround(y + sign * t * vn.y)), 0, h - 1);
          if (yx == x && yy == y) continue;
          const size_t iy = size_t(yy) * size_t(w) + size_t(yx);
          const double ly = std::max(length(v[iy]), 0.5), zy = f.depth.at(yx, yy, 0);
          const double dist = std::hypot(double(yx - x), double(yy - y));
          // McGuire et al. 2012, Sec. 3.3: a blurry tap in front reaching this pixel; a tap
          // behind a blurry pixel (the background it uncovers); both blurry together.
          const double a = soft_depth_compare(zy, zx, s.soft_depth) * cone_weight(dist, ly) +
                           soft_depth_compare(zx, zy, s.soft_depth) * cone_weight(dist, lx) +
                           2.0 * cylinder_weight(dist, ly) * cylinder_weight(dist, lx);
          if (a <= 0.0) continue;
          weight += a;
          for (int c = 0; c < 3; ++c) sum[c] += a * color.at(yx, yy, c);
        }
      }
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = float(sum[c] / weight);
    }
  });
  return out;
}

}  // namespace afterimage::post
