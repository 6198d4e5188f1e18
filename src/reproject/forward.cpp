// Forward reprojection: splatting and hole filling (forward.h; seed 004, Mark, McMillan &
// Bishop 1997, Gortler et al. 1996, Grossman & Dally 1998).
#include "reproject/forward.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <limits>

#include "core/error.h"

namespace afterimage::reproject {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// View-space point at view z = `z` seen at NDC (nx, ny) through projection `p`: the equations
// clip.x = nx clip.w and clip.y = ny clip.w are linear in (X, Y) once Z is fixed (Cramer's
// rule), for perspective, orthographic and off-centre (jittered) projections alike.
bool unproject_at_z(const Mat4& p, double nx, double ny, double z, Vec3d* out) {
  const auto& m = p.m;
  const double a00 = m[0][0] - nx * m[3][0], a01 = m[0][1] - nx * m[3][1];
  const double a10 = m[1][0] - ny * m[3][0], a11 = m[1][1] - ny * m[3][1];
  const double wz = m[3][2] * z + m[3][3];
  const double b0 = nx * wz - (m[0][2] * z + m[0][3]);
  const double b1 = ny * wz - (m[1][2] * z + m[1][3]);
  const double det = a00 * a11 - a01 * a10;
  if (!(std::abs(det) > 0.0)) return false;
  *out = {(b0 * a11 - a01 * b1) / det, (a00 * b1 - b0 * a10) / det, z};
  return std::isfinite(out->x) && std::isfinite(out->y);
}

bool is_perspective(const Mat4& p) {
  return p.m[3][2] != 0.0;
}

}  // namespace

std::optional<PixelCoord> splat_target_position(int x, int y, Vec2d source_jitter,
                                                Vec2d displacement, Vec2d target_jitter, int width,
                                                int height) {
  if (!std::isfinite(displacement.x) || !std::isfinite(displacement.y)) return std::nullopt;
  const double tx = std::floor(x + 0.5 + source_jitter.x + displacement.x - target_jitter.x);
  const double ty = std::floor(y + 0.5 + source_jitter.y + displacement.y - target_jitter.y);
  if (!(tx >= 0.0 && tx < double(width) && ty >= 0.0 && ty < double(height))) return std::nullopt;
  return PixelCoord{int(tx), int(ty)};
}

CameraTransfer CameraTransfer::between(const FrameHeader& source, const FrameHeader& target) {
  CameraTransfer t;
  t.source_projection = source.projection;
  t.source_to_world = source.view.inverse();
  t.target_view = target.view;
  t.target_view_projection = target.projection * target.view;
  t.width = source.width;
  t.height = source.height;
  return t;
}

Reprojected camera_displacement(const CameraTransfer& t, Vec2d sample, float depth) {
  Reprojected r;
  const double nx = 2.0 * sample.x / t.width - 1.0, ny = 1.0 - 2.0 * sample.y / t.height;
  const bool sky = !(depth < kBackgroundDepth);
  Vec4d world;
  if (sky && is_perspective(t.source_projection)) {
    // A direction at infinity: two points on the sample's ray give it; w = 0.
    Vec3d p1, p2;
    if (!unproject_at_z(t.source_projection, nx, ny, -1.0, &p1) ||
        !unproject_at_z(t.source_projection, nx, ny, -2.0, &p2))
      return r;
    world = Vec4d(t.source_to_world.transform_dir(p2 - p1), 0.0);
  } else {
    double z = -double(depth);
    if (sky) {  // orthographic: the far plane, NDC z = 1 (m22 z + m23 = 1)
      const auto& m = t.source_projection.m;
      if (!(m[2][2] != 0.0)) return r;
      z = (1.0 - m[2][3]) / m[2][2];
    }
    Vec3d pv;
    if (!unproject_at_z(t.source_projection, nx, ny, z, &pv)) return r;
    world = Vec4d(t.source_to_world.transform_point(pv), 1.0);
  }
  const Vec4d c = t.target_view_projection * world;
  if (!(c.w > 0.0)) return r;  // behind the target camera
  const double px = (c.x / c.w + 1.0) * 0.5 * t.width, py = (1.0 - c.y / c.w) * 0.5 * t.height;
  if (!std::isfinite(px) || !std::isfinite(py)) return r;
  r.valid = true;
  r.displacement = {px - sample.x, py - sample.y};
  if (sky) {
    r.target_depth = kBackgroundDepth;
  } else {
    const double d = -(t.target_view * world).z;
    r.target_depth = d < double(kBackgroundDepth) ? float(d) : kBackgroundDepth;
  }
  return r;
}

const char* displacement_kind_name(DisplacementKind k) {
  switch (k) {
    case DisplacementKind::motion_next:
      return "motion_next";
    case DisplacementKind::motion:
      return "motion";
    default:
      return "camera";
  }
}

DisplacementField displacement_field(const Frame& source, const FrameHeader& target,
                                     DisplacementKind kind, const Exec& ex) {
  const int w = source.width, h = source.height;
  AI_CHECK(source.has_depth());
  AI_CHECK(target.width == w && target.height == h);
  const ImageF* motion = nullptr;
  if (kind == DisplacementKind::motion_next) motion = &source.motion_next;
  if (kind == DisplacementKind::motion) motion = &source.motion;
  AI_CHECK(!motion ||
           source.has(kind == DisplacementKind::motion ? Channel::motion : Channel::motion_next));
  const CameraTransfer t = CameraTransfer::between(source, target);
  DisplacementField f{ImageF(w, h, 2, kNaN), ImageF(w, h, 1, kBackgroundDepth)};
  parallel_rows(ex, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const float d = source.depth.at(x, y, 0);
      const Vec2d sample{x + 0.5 + source.jitter.x, y + 0.5 + source.jitter.y};
      const Reprojected r = camera_displacement(t, sample, d);
      if (motion) {
        f.displacement.at(x, y, 0) = motion->at(x, y, 0);
        f.displacement.at(x, y, 1) = motion->at(x, y, 1);
        // The exact motion moves the sample; only its depth comes from the cameras.
        f.target_depth.at(x, y, 0) = r.valid ? r.target_depth : d;
      } else if (r.valid) {
        f.displacement.at(x, y, 0) = float(r.displacement.x);
        f.displacement.at(x, y, 1) = float(r.displacement.y);
        f.target_depth.at(x, y, 0) = r.target_depth;
      }
    }
  });
  return f;
}

ForwardSplat ForwardSplat::empty(int width, int height) {
  return {ImageF(width, height, 3, 0.0f),
          ImageF(width, height, 1, kBackgroundDepth),
          ImageU32(width, height, 1, 0u),
          Image<uint8_t>(width, height, 1, uint8_t(1)),
          ImageF(width, height, 2, kNaN),
          ImageF(width, height, 3, 0.0f),
          ImageF(width, height, 1, kBackgroundDepth),
          Image<uint8_t>(width, height, 1, uint8_t(0))};
}

size_t ForwardSplat::hole_count() const {
  return size_t(std::count(hole.data().begin(), hole.data().end(), uint8_t(1)));
}

double ForwardSplat::hole_fraction() const {
  const size_t n = hole.plane_size();
  return n ? double(hole_count()) / double(n) : 0.0;
}

bool sample_wins(float depth, float offset, float current_depth, float current_offset) {
  if (depth < current_depth * (1.0f - kSameSurfaceDepthRatio)) return true;   // nearer
  if (depth > current_depth * (1.0f + kSameSurfaceDepthRatio)) return false;  // farther
  return offset < current_offset;  // one surface: the sample nearer the pixel's sample
}

namespace {

// Hole pixels covered by the warped quad of source samples (x, y), (x+1, y), (x, y+1),
// (x+1, y+1) when all four lie on one surface (target depths within the same-surface ratio of
// the background rule) and the quad spans at most kMaxStretch pixels: the pixel takes the
// color of the corner that landed nearest its sample position, clamped per channel to the
// range of the other three corners (corner_color_within_others); among quads, the nearest
// depth wins.
constexpr double kMaxStretch = 4.0;

// Channel `c` of quad corner `k` (of the four colors `corner`), clamped to the range the
// other three corners span. A corner outside that range shows a feature smaller than the
// sample spacing (a glint of a sub-pixel flake, a firefly, a one-sample highlight) that the
// hole pixel's own sample, elsewhere in the quad, most likely misses; the range of the
// surrounding samples is the same plausibility bound TAA puts on history (Karis 2014, "High
// Quality Temporal Supersampling"). Measured (FillComparison, 192x108): `sparkle`'s hole
// error 0.0446 -> 0.0367 (naive 0.0430: a third of its holes are stretched-quad pixels of the
// glinting floor, where the nearest corner copied glints the truth did not have, and they
// made all of the loss), the mean over the 11 moving scenes 0.0338 -> 0.0324, only `thin`
// worse (by 0.0004).
float corner_color_within_others(const std::array<std::array<float, 3>, 4>& corner, int k, int c) {
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (int i = 0; i < 4; ++i) {
    if (i == k) continue;
    lo = std::min(lo, corner[size_t(i)][size_t(c)]);
    hi = std::max(hi, corner[size_t(i)][size_t(c)]);
  }
  return std::clamp(corner[size_t(k)][size_t(c)], lo, hi);
}

void splat_stretched_quads(const Frame& source, const DisplacementField& field, Vec2d target_jitter,
                           ForwardSplat& into) {
  const int w = into.width(), h = into.height();
  for (int y = 0; y + 1 < h; ++y)
    for (int x = 0; x + 1 < w; ++x) {
      double px[4], py[4];
      float dz[4];
      bool ok = true;
      for (int k = 0; k < 4 && ok; ++k) {
        const int sx = x + (k & 1), sy = y + (k >> 1);
        const double dx = field.displacement.at(sx, sy, 0), dy = field.displacement.at(sx, sy, 1);
        dz[k] = field.target_depth.at(sx, sy, 0);
        ok = std::isfinite(dx) && std::isfinite(dy) && dz[k] < kBackgroundDepth;
        px[k] = sx + 0.5 + source.jitter.x + dx - target_jitter.x;
        py[k] = sy + 0.5 + source.jitter.y + dy - target_jitter.y;
      }
      if (!ok) continue;
      const float zmin = std::min({dz[0], dz[1], dz[2], dz[3]}),
                  zmax = std::max({dz[0], dz[1], dz[2], dz[3]});
      if (!(zmin >= kBackgroundDepthRatio * zmax)) continue;  // an edge, not one surface
      const double x0 = std::min({px[0], px[1], px[2], px[3]}),
                   x1 = std::max({px[0], px[1], px[2], px[3]}),
                   y0 = std::min({py[0], py[1], py[2], py[3]}),
                   y1 = std::max({py[0], py[1], py[2], py[3]});
      if (x1 - x0 > kMaxStretch || y1 - y0 > kMaxStretch) continue;
      // Pixels whose sample position (i + 0.5) lies inside the quad's bounding box.
      for (int ty = std::max(0, int(std::ceil(y0 - 0.5)));
           ty <= std::min(h - 1, int(std::floor(y1 - 0.5))); ++ty)
        for (int tx = std::max(0, int(std::ceil(x0 - 0.5)));
             tx <= std::min(w - 1, int(std::floor(x1 - 0.5))); ++tx) {
          if (!into.hole.at(tx, ty, 0)) continue;
          int best = 0;
          double best_d2 = 1e30;
          for (int k = 0; k < 4; ++k) {
            const double ex = px[k] - (tx + 0.5), ey = py[k] - (ty + 0.5);
            if (ex * ex + ey * ey < best_d2) best_d2 = ex * ex + ey * ey, best = k;
          }
          const float z = dz[best];
          if (into.stretch_valid.at(tx, ty, 0) && !(z < into.stretch_depth.at(tx, ty, 0)))
            continue;  // the nearest quad wins
          into.stretch_valid.at(tx, ty, 0) = 1;
          into.stretch_depth.at(tx, ty, 0) = z;
          std::array<std::array<float, 3>, 4> corner;
          for (int k = 0; k < 4; ++k)
            for (int c = 0; c < 3; ++c)
              corner[size_t(k)][size_t(c)] = source.color.at(x + (k & 1), y + (k >> 1), c);
          for (int c = 0; c < 3; ++c)
            into.stretch_color.at(tx, ty, c) = corner_color_within_others(corner, best, c);
        }
    }
}

}  // namespace

void splat_frame(const Frame& source, const DisplacementField& field, Vec2d target_jitter,
                 ForwardSplat& into) {
  const int w = into.width(), h = into.height();
  AI_CHECK(source.width == w && source.height == h && source.has_color());
  AI_CHECK(field.displacement.width() == w && field.displacement.height() == h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Vec2d disp{field.displacement.at(x, y, 0), field.displacement.at(x, y, 1)};
      const auto q = splat_target_position(x, y, source.jitter, disp, target_jitter, w, h);
      if (!q) continue;
      ++into.sources.at(q->x, q->y, 0);
      const float d = field.target_depth.at(x, y, 0);
      const double ox = x + 0.5 + source.jitter.x + disp.x - target_jitter.x - (q->x + 0.5);
      const double oy = y + 0.5 + source.jitter.y + disp.y - target_jitter.y - (q->y + 0.5);
      const float off = float(ox * ox + oy * oy);
      if (!into.hole.at(q->x, q->y, 0)) {
        const double cx = into.sample_offset.at(q->x, q->y, 0);
        const double cy = into.sample_offset.at(q->x, q->y, 1);
        if (!sample_wins(d, off, into.depth.at(q->x, q->y, 0), float(cx * cx + cy * cy))) continue;
      }
      into.sample_offset.at(q->x, q->y, 0) = float(ox);
      into.sample_offset.at(q->x, q->y, 1) = float(oy);
      into.hole.at(q->x, q->y, 0) = 0;
      into.depth.at(q->x, q->y, 0) = d;
      for (int c = 0; c < 3; ++c) into.color.at(q->x, q->y, c) = source.color.at(x, y, c);
    }
  splat_stretched_quads(source, field, target_jitter, into);
}

ImageF fill_holes_naive(const ForwardSplat& s, const Exec& ex) {
  const int w = s.width(), h = s.height();
  ImageF out = s.color;
  std::vector<uint8_t> row_has(size_t(h), 0);
  parallel_rows(ex, h, [&](int y) {
    std::vector<int> filled;
    for (int x = 0; x < w; ++x)
      if (!s.hole.at(x, y, 0)) filled.push_back(x);
    if (filled.empty()) return;
    row_has[size_t(y)] = 1;
    size_t k = 0;  // filled[k] is the first filled pixel right of x (or past the end)
    for (int x = 0; x < w; ++x) {
      while (k < filled.size() && filled[k] < x) ++k;
      if (!s.hole.at(x, y, 0)) continue;
      const int left = k > 0 ? filled[k - 1] : -1;
      const int right = k < filled.size() ? filled[k] : -1;
      const int src = right < 0 || (left >= 0 && x - left <= right - x) ? left : right;
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = s.color.at(src, y, c);
    }
  });
  // Rows without any sample: the nearest filled row's result in the same column.
  std::vector<int> rows;
  for (int y = 0; y < h; ++y)
    if (row_has[size_t(y)]) rows.push_back(y);
  if (rows.empty()) return out;  // nothing landed: black
  for (int y = 0; y < h; ++y) {
    if (row_has[size_t(y)]) continue;
    int best = rows.front();
    for (int r : rows)
      if (std::abs(r - y) < std::abs(best - y)) best = r;
    for (int c = 0; c < 3; ++c) std::copy_n(out.row(c, best), size_t(w), out.row(c, y));
  }
  return out;
}

ImageF fill_holes_background(const ForwardSplat& s, const Exec& ex) {
  const int w = s.width(), h = s.height();
  ImageF out = s.color;
  // The row first (left, right), then the column, then the diagonals.
  static constexpr std::array<std::array<int, 2>, 8> kDirs = {
      {{-1, 0}, {1, 0}, {0, -1}, {0, 1}, {-1, -1}, {1, -1}, {-1, 1}, {1, 1}}};
  parallel_rows(ex, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      if (!s.hole.at(x, y, 0)) continue;
      // A stretched surface covers it (splat_frame): its color, no guess.
      if (s.stretch_valid.at(x, y, 0)) {
        for (int c = 0; c < 3; ++c) out.at(x, y, c) = s.stretch_color.at(x, y, c);
        continue;
      }
      std::array<PixelCoord, 8> found;
      int n = 0;
      float farthest = 0.0f;
      for (const auto& d : kDirs) {
        int px = x + d[0], py = y + d[1];
        while (px >= 0 && px < w && py >= 0 && py < h && s.hole.at(px, py, 0)) {
          px += d[0];
          py += d[1];
        }
        if (px < 0 || px >= w || py < 0 || py >= h) continue;
        found[size_t(n++)] = {px, py};
        farthest = std::max(farthest, s.depth.at(px, py, 0));
      }
      // A crack: every sample around lies on one surface (depths within the background
      // ratio of each other), typically a stretched surface the one-pixel splats did not
      // cover. Nothing was disoccluded, so blend the surface from all sides, weighted by
      // inverse squared distance, instead of copying one side.
      float nearest = std::numeric_limits<float>::infinity();
      for (int i = 0; i < n; ++i)
        nearest = std::min(nearest, s.depth.at(found[size_t(i)].x, found[size_t(i)].y, 0));
      // Mean of found samples weighted by 1 / d^4, d = distance to where each really landed.
      auto blend = [&](std::initializer_list<int> which_or_all) {
        double sum[3] = {0, 0, 0}, wsum = 0;
        auto add = [&](int i) {
          const PixelCoord f = found[size_t(i)];
          const double dx = f.x - x + s.sample_offset.at(f.x, f.y, 0);
          const double dy = f.y - y + s.sample_offset.at(f.x, f.y, 1);
          const double d2 = std::max(dx * dx + dy * dy, 1e-6), wgt = 1.0 / (d2 * d2);
          for (int c = 0; c < 3; ++c) sum[c] += wgt * s.color.at(f.x, f.y, c);
          wsum += wgt;
        };
        if (which_or_all.size() == 0)
          for (int i = 0; i < n; ++i) add(i);
        for (int i : which_or_all) add(i);
        for (int c = 0; c < 3; ++c) out.at(x, y, c) = float(sum[c] / wsum);
      };
      if (n >= 2 && nearest >= kBackgroundDepthRatio * farthest) {
        blend({});
        continue;
      }
      // A crack across one axis: the two samples facing each other along the row (or the
      // column) lie on one surface, though something else is near along another direction.
      bool bridged = false;
      for (const std::array<int, 2>& axis : {std::array<int, 2>{1, 0}, std::array<int, 2>{0, 1}}) {
        int a = -1, b = -1;
        for (int i = 0; i < n; ++i) {
          const PixelCoord f = found[size_t(i)];
          const int along = axis[0] ? f.x - x : f.y - y, across = axis[0] ? f.y - y : f.x - x;
          if (across != 0) continue;
          (along < 0 ? a : b) = i;
        }
        if (a < 0 || b < 0) continue;
        const float da = s.depth.at(found[size_t(a)].x, found[size_t(a)].y, 0),
                    db = s.depth.at(found[size_t(b)].x, found[size_t(b)].y, 0);
        if (!(std::min(da, db) >= kBackgroundDepthRatio * std::max(da, db))) continue;
        blend({a, b});
        bridged = true;
        break;
      }
      if (bridged) continue;
      int best = -1;
      double best_d2 = 0.0;
      // The row's samples when there are any (found lists them first), else all.
      int in_row = 0;
      while (in_row < n && found[size_t(in_row)].y == y) ++in_row;
      if (in_row > 0) {
        n = in_row;
        farthest = 0.0f;
        for (int i = 0; i < n; ++i)
          farthest = std::max(farthest, s.depth.at(found[size_t(i)].x, y, 0));
      }
      for (int i = 0; i < n; ++i) {
        const PixelCoord f = found[size_t(i)];
        if (!(s.depth.at(f.x, f.y, 0) >= kBackgroundDepthRatio * farthest)) continue;
        // Where that sample really landed, relative to this pixel's sample position.
        const double dx = f.x - x + s.sample_offset.at(f.x, f.y, 0);
        const double dy = f.y - y + s.sample_offset.at(f.x, f.y, 1);
        const double d2 = dx * dx + dy * dy;
        if (best < 0 || d2 < best_d2) best = i, best_d2 = d2;
      }
      if (best < 0) continue;  // nothing landed anywhere: stays black
      const PixelCoord f = found[size_t(best)];
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = s.color.at(f.x, f.y, c);
    }
  });
  return out;
}

namespace {

// One pyramid level: color (3 planes, the weighted mean), weight (clamped to 1), depth.
struct Level {
  ImageF color, weight, depth;
};

Level pull(const Level& fine, bool background_only, const Exec& ex) {
  const int w = (fine.color.width() + 1) / 2, h = (fine.color.height() + 1) / 2;
  const int fw = fine.color.width(), fh = fine.color.height();
  Level c{ImageF(w, h, 3, 0.0f), ImageF(w, h, 1, 0.0f), ImageF(w, h, 1, kBackgroundDepth)};
  parallel_rows(ex, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      float farthest = 0.0f;
      for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) {
          const int fx = 2 * x + i, fy = 2 * y + j;
          if (fx < fw && fy < fh && fine.weight.at(fx, fy, 0) > 0.0f)
            farthest = std::max(farthest, fine.depth.at(fx, fy, 0));
        }
      double sum[3] = {0, 0, 0}, wsum = 0, dsum = 0;
      for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) {
          const int fx = 2 * x + i, fy = 2 * y + j;
          if (fx >= fw || fy >= fh) continue;
          const float wt = fine.weight.at(fx, fy, 0);
          if (!(wt > 0.0f)) continue;
          const float d = fine.depth.at(fx, fy, 0);
          if (background_only && !(d >= kBackgroundDepthRatio * farthest)) continue;
          for (int k = 0; k < 3; ++k) sum[k] += double(wt) * fine.color.at(fx, fy, k);
          wsum += wt;
          dsum += double(wt) * d;
        }
      if (!(wsum > 0.0)) continue;
      for (int k = 0; k < 3; ++k) c.color.at(x, y, k) = float(sum[k] / wsum);
      c.weight.at(x, y, 0) = float(std::min(1.0, wsum));
      c.depth.at(x, y, 0) = float(dsum / wsum);
    }
  });
  return c;
}

// Level `fine` with its partial weights completed from `coarse` (already complete), bilinear.
void push(Level& fine, const Level& coarse, const Exec& ex) {
  const int w = fine.color.width(), h = fine.color.height();
  const int cw = coarse.color.width(), ch = coarse.color.height();
  parallel_rows(ex, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const float wt = fine.weight.at(x, y, 0);
      if (wt >= 1.0f) continue;
      const double cx = std::clamp((x + 0.5) * 0.5 - 0.5, 0.0, double(cw - 1));
      const double cy = std::clamp((y + 0.5) * 0.5 - 0.5, 0.0, double(ch - 1));
      const int x0 = int(cx), y0 = int(cy);
      const int x1 = std::min(x0 + 1, cw - 1), y1 = std::min(y0 + 1, ch - 1);
      const double ax = cx - x0, ay = cy - y0;
      for (int k = 0; k < 3; ++k) {
        const double up =
            (1 - ay) * ((1 - ax) * coarse.color.at(x0, y0, k) + ax * coarse.color.at(x1, y0, k)) +
            ay * ((1 - ax) * coarse.color.at(x0, y1, k) + ax * coarse.color.at(x1, y1, k));
        fine.color.at(x, y, k) = float(wt * fine.color.at(x, y, k) + (1.0 - wt) * up);
      }
      fine.weight.at(x, y, 0) = 1.0f;
    }
  });
}

}  // namespace

ImageF fill_holes_push_pull(const ForwardSplat& s, bool background_only, const Exec& ex) {
  const int w = s.width(), h = s.height();
  std::vector<Level> levels;
  Level l0{s.color, ImageF(w, h, 1, 0.0f), s.depth};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) l0.weight.at(x, y, 0) = s.hole.at(x, y, 0) ? 0.0f : 1.0f;
  levels.push_back(std::move(l0));
  while (levels.back().color.width() > 1 || levels.back().color.height() > 1)
    levels.push_back(pull(levels.back(), background_only, ex));
  // The coarsest level: a pixel without weight stays black (nothing landed anywhere).
  levels.back().weight.fill(1.0f);
  for (size_t l = levels.size() - 1; l > 0; --l) push(levels[l - 1], levels[l], ex);
  // Non-hole pixels had weight 1 and were never touched: exactly the splat's color.
  return std::move(levels.front().color);
}

const std::vector<HoleFillInfo>& hole_fills() {
  static const std::vector<HoleFillInfo> table = {
      {HoleFill::naive, "naive",
       "baseline: nearest sample along the row, either side, ties left, depth ignored"},
      {HoleFill::background, "background",
       "stretched-surface quads (nearest corner, clamped to the other corners), cracks "
       "blended from the surface around them, disocclusions from the far (background) side"},
      {HoleFill::push_pull, "pushpull",
       "push-pull pyramid (Gortler et al. 1996, Grossman & Dally 1998), depth-blind"},
      {HoleFill::push_pull_background, "pushpull-background",
       "push-pull whose pull keeps only the far (background) children of each 2x2"},
  };
  return table;
}

std::vector<std::string> hole_fill_names() {
  std::vector<std::string> v;
  for (const HoleFillInfo& f : hole_fills()) v.push_back(f.name);
  return v;
}

const char* hole_fill_name(HoleFill f) {
  for (const HoleFillInfo& i : hole_fills())
    if (i.fill == f) return i.name;
  return "?";
}

HoleFill parse_hole_fill(const std::string& name) {
  for (const HoleFillInfo& f : hole_fills())
    if (name == f.name) return f.fill;
  throw SettingsError(
      fmt::format("--fill '{}': expected one of {}", name, fmt::join(hole_fill_names(), ", ")));
}

ImageF fill_holes(const ForwardSplat& s, const FillSettings& settings, const Exec& ex) {
  switch (settings.fill) {
    case HoleFill::naive:
      return fill_holes_naive(s, ex);
    case HoleFill::background:
      return fill_holes_background(s, ex);
    case HoleFill::push_pull:
      return fill_holes_push_pull(s, false, ex);
    default:
      return fill_holes_push_pull(s, true, ex);
  }
}

}  // namespace afterimage::reproject
