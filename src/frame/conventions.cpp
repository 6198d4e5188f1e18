#include "frame/conventions.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "core/error.h"

namespace afterimage {

namespace {

std::vector<std::string> split(std::string_view s, char sep) {
  std::vector<std::string> out;
  size_t b = 0;
  while (true) {
    const size_t e = s.find(sep, b);
    out.emplace_back(s.substr(b, e == std::string_view::npos ? s.npos : e - b));
    if (e == std::string_view::npos) return out;
    b = e + 1;
  }
}

double parse_number(const std::string& s, std::string_view spec) {
  if (s == "inf") return std::numeric_limits<double>::infinity();
  try {
    size_t used = 0;
    const double v = std::stod(s, &used);
    if (used == s.size() && std::isfinite(v)) return v;
  } catch (const std::exception&) {
  }
  throw SettingsError(fmt::format("convention '{}': '{}' is not a number", spec, s));
}

bool is_perspective(const Mat4& p) {
  return p.m[3][2] != 0.0 && p.m[3][3] == 0.0;
}

// View-space ray slopes (x / -z, y / -z) through pixel position `px` (y down) of a
// perspective projection (inverse of clip = P * view, off-centre terms included).
Vec2d ray_slopes(const Mat4& p, Vec2d px, int width, int height) {
  const double nx = 2.0 * px.x / width - 1.0, ny = 1.0 - 2.0 * px.y / height;
  return {(nx + p.m[0][2]) / p.m[0][0], (ny + p.m[1][2]) / p.m[1][1]};
}

}  // namespace

const std::vector<MotionConvention>& motion_conventions() {
  static const std::vector<MotionConvention> table = {
      {"afterimage",
       MotionUnits::Pixels,
       MotionDirection::ToOther,
       false,
       {1, 1},
       {0, 0},
       "DESIGN.md section 3: p_prev - p_curr, pixels, y down"},
      // Measured on tests/data/blender (README.md there): a quad moving (+4, +2) px/frame
      // (y down) has Vector.XY = (-4, +2).
      {"blender",
       MotionUnits::Pixels,
       MotionDirection::ToOther,
       true,
       {1, 1},
       {0, 0},
       "Blender 3.4 Cycles Vector.XY: previous - current, pixels, +y up (measured)"},
      {"blender-next",
       MotionUnits::Pixels,
       MotionDirection::FromOther,
       true,
       {1, 1},
       {0, 0},
       "Blender 3.4 Cycles Vector.ZW: current - next, pixels, +y up (measured)"},
      // Unity Manual, "Introduction to motion vectors in URP": each texel stores the UV
      // offset; current UV minus the vector is last frame's UV. Unity's UV origin is the
      // bottom-left corner (y up); not verified on an exported file.
      {"unity",
       MotionUnits::Uv,
       MotionDirection::FromOther,
       true,
       {1, 1},
       {0, 0},
       "Unity URP motion vector texture: current - previous UV, y up"},
      // UE4 Common.ush EncodeVelocityToTexture: V = ScreenPos - PrevScreenPos (NDC, y up,
      // unjittered), stored as V * 0.499 * 0.5 + 32767/65535 in R16G16 UNORM. Unsure whether
      // Movie Render Queue's EXR motion pass writes this encoding or the decoded V.
      {"unreal",
       MotionUnits::Ndc,
       MotionDirection::FromOther,
       true,
       {0.2495, 0.2495},
       {32767.0 / 65535.0, 32767.0 / 65535.0},
       "UE4 velocity buffer: encoded (current - previous) NDC, y up"},
      // FidelityFX FSR2 README, "Providing motion vectors / Space": current pixel to its
      // previous position, in [-size, size] pixels, upper-left to lower-right is +x +y
      // (y down); apps scale their vectors into this with motionVectorScale.
      {"fsr2",
       MotionUnits::Pixels,
       MotionDirection::ToOther,
       false,
       {1, 1},
       {0, 0},
       "FSR2 input after motionVectorScale: previous - current, pixels, y down"},
  };
  return table;
}

MotionConvention parse_motion_convention(std::string_view spec) {
  const std::vector<std::string> parts = split(spec, ':');
  for (const MotionConvention& c : motion_conventions()) {
    if (c.name != parts[0]) continue;
    MotionConvention out = c;
    if (parts.size() == 3) {
      // Extra per-axis factor: file = factor * registered encoding (FSR2: the file holds
      // vectors that motionVectorScale (sx, sy) brings to pixels, so factor = 1 / scale).
      out.scale.x *= 1.0 / parse_number(parts[1], spec);
      out.scale.y *= 1.0 / parse_number(parts[2], spec);
    } else if (parts.size() != 1) {
      throw SettingsError(fmt::format("motion convention '{}': expected NAME or NAME:SX:SY", spec));
    }
    return out;
  }
  std::string names;
  for (const MotionConvention& c : motion_conventions())
    names += (names.empty() ? "" : ", ") + c.name;
  throw SettingsError(fmt::format("unknown motion convention '{}' (known: {})", spec, names));
}

Vec2d motion_to_afterimage(Vec2d file, const MotionConvention& c, int width, int height) {
  Vec2d v{(file.x - c.offset.x) / c.scale.x, (file.y - c.offset.y) / c.scale.y};
  if (c.units == MotionUnits::Uv) v = {v.x * width, v.y * height};
  if (c.units == MotionUnits::Ndc) v = {v.x * 0.5 * width, v.y * 0.5 * height};
  if (c.y_up) v.y = -v.y;
  if (c.direction == MotionDirection::FromOther) v = v * -1.0;
  return v;
}

Vec2d motion_from_afterimage(Vec2d ours, const MotionConvention& c, int width, int height) {
  Vec2d v = ours;
  if (c.direction == MotionDirection::FromOther) v = v * -1.0;
  if (c.y_up) v.y = -v.y;
  if (c.units == MotionUnits::Uv) v = {v.x / width, v.y / height};
  if (c.units == MotionUnits::Ndc) v = {v.x * 2.0 / width, v.y * 2.0 / height};
  return {v.x * c.scale.x + c.offset.x, v.y * c.scale.y + c.offset.y};
}

void convert_motion(ImageF& motion, const MotionConvention& c) {
  AI_CHECK(motion.channels() == 2);
  float* x = motion.plane(0);
  float* y = motion.plane(1);
  for (size_t i = 0; i < motion.plane_size(); ++i) {
    const Vec2d v = motion_to_afterimage({x[i], y[i]}, c, motion.width(), motion.height());
    x[i] = float(v.x);
    y[i] = float(v.y);
  }
}

DepthConvention parse_depth_convention(std::string_view spec) {
  const std::vector<std::string> parts = split(spec, ':');
  DepthConvention c;
  c.name = parts[0];
  if (c.name == "linear")
    c.kind = DepthKind::Linear;
  else if (c.name == "ray")
    c.kind = DepthKind::RayDistance;
  else if (c.name == "hardware")
    c.kind = DepthKind::Hardware;
  else if (c.name == "hardware-reversed")
    c.kind = DepthKind::HardwareReversed;
  else
    throw SettingsError(
        fmt::format("unknown depth convention '{}' (known: linear, ray, hardware[:near:far], "
                    "hardware-reversed[:near:far])",
                    spec));
  const bool hw = c.kind == DepthKind::Hardware || c.kind == DepthKind::HardwareReversed;
  if (parts.size() == 3 && hw) {
    c.near_plane = parse_number(parts[1], spec);
    c.far_plane = parse_number(parts[2], spec);
    if (!(c.near_plane > 0 && c.far_plane > c.near_plane))
      throw SettingsError(fmt::format("depth convention '{}': need 0 < near < far", spec));
  } else if (parts.size() != 1) {
    throw SettingsError(fmt::format("depth convention '{}': unexpected parameters", spec));
  }
  return c;
}

// Perspective window depth (GL projection, glDepthRange(0, 1); the same as D3D's):
// z01 = f (d - n) / (d (f - n)); reversed-Z stores 1 - z01 = n (f - d) / (d (f - n)),
// which tends to n / d for an infinite far plane.
double hardware_depth(double d, double n, double f, bool reversed) {
  if (std::isinf(f)) return reversed ? n / d : 1.0 - n / d;
  const double z = f * (d - n) / (d * (f - n));
  return reversed ? 1.0 - z : z;
}

double depth_from_hardware(double z01, double n, double f, bool reversed) {
  const double zr = reversed ? z01 : 1.0 - z01;  // n / d scaled: zr = n (f - d) / (d (f - n))
  if (std::isinf(f)) return n / zr;
  return n * f / (n + zr * (f - n));
}

void planes_of_projection(const Mat4& p, double& n, double& f) {
  // Camera::projection: P22 = -(f + n) / (f - n), P23 = -2 f n / (f - n).
  n = p.m[2][3] / (p.m[2][2] - 1.0);
  f = p.m[2][3] / (p.m[2][2] + 1.0);
}

void convert_depth(Frame& f, const DepthConvention& c, bool camera_known, const std::string& what) {
  if (c.kind == DepthKind::Linear || f.depth.empty()) return;
  const bool hw = c.kind != DepthKind::RayDistance;
  const bool need_camera = !hw || c.near_plane == 0.0;
  if (need_camera && !camera_known)
    throw InputError(
        fmt::format("{}: depth convention '{}' needs the camera (give --jitter-file with view and "
                    "projection, or near and far)",
                    what, c.name));
  const bool persp = is_perspective(f.projection);
  const bool reversed = c.kind == DepthKind::HardwareReversed;
  double n = c.near_plane, fa = c.far_plane;
  if (hw && n == 0.0) {
    if (persp) {
      planes_of_projection(f.projection, n, fa);
    } else {  // orthographic: P22 = -2 / (f - n), P23 = -(f + n) / (f - n)
      n = (f.projection.m[2][3] + 1.0) / f.projection.m[2][2];
      fa = (f.projection.m[2][3] - 1.0) / f.projection.m[2][2];
    }
  }
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      float& d = f.depth.at(x, y, 0);
      if (c.kind == DepthKind::RayDistance) {
        if (!(d < kBackgroundDepth) || !persp) continue;  // orthographic rays are parallel
        const Vec2d s = ray_slopes(f.projection, {x + 0.5 + f.jitter.x, y + 0.5 + f.jitter.y},
                                   f.width, f.height);
        d = float(d / std::sqrt(1.0 + s.x * s.x + s.y * s.y));
        continue;
      }
      const double z = d;
      const bool clear = reversed ? !(z > 0.0) : !(z < 1.0);  // cleared depth: sky
      double lin = 0;
      if (!clear) {
        if (persp || c.near_plane != 0.0)
          lin = depth_from_hardware(z, n, fa, reversed);
        else
          lin = n + (reversed ? 1.0 - z : z) * (fa - n);
      }
      d = clear || !(lin < kBackgroundDepth) ? kBackgroundDepth : float(lin);
    }
}

bool fill_background_motion(Frame& f, const FrameHeader& other, ImageF& plane) {
  if (!is_perspective(f.projection) || !is_perspective(other.projection)) return false;
  if (plane.empty()) plane = ImageF(f.width, f.height, 2);
  const Mat4 to_world = f.view.inverse();
  const Mat4 other_vp = other.projection * other.view;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      if (f.depth.at(x, y, 0) < kBackgroundDepth) continue;
      const Vec2d p{x + 0.5, y + 0.5};  // unjittered pixel centre (motion is unjittered)
      const Vec2d s = ray_slopes(f.projection, p, f.width, f.height);
      const Vec3d dir = to_world.transform_dir({s.x, s.y, -1.0});
      const Vec4d c = other_vp * Vec4d(dir, 0.0);  // w = 0: a point at infinity
      if (!(c.w > 0.0)) continue;                  // behind the other camera
      const Vec2d q{(c.x / c.w + 1.0) * 0.5 * f.width, (1.0 - c.y / c.w) * 0.5 * f.height};
      plane.at(x, y, 0) = float(q.x - p.x);
      plane.at(x, y, 1) = float(q.y - p.y);
    }
  return true;
}

}  // namespace afterimage
