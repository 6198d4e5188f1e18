#include "camera/camera.h"

#include <cmath>
#include <string>

#include <fmt/format.h>

#include "core/error.h"

namespace afterimage {

Mat4 Camera::projection(int width, int height) const {
  const double aspect = double(width) / double(height);
  const double n = near_plane, f = far_plane;
  Mat4 p;
  if (type == ProjectionType::Perspective) {
    const double t = 1.0 / std::tan(0.5 * vfov_degrees * kPi / 180.0);
    p.m[0][0] = t / aspect;
    p.m[1][1] = t;
    p.m[2][2] = -(f + n) / (f - n);
    p.m[2][3] = -2.0 * f * n / (f - n);
    p.m[3][2] = -1.0;
  } else {
    const double h = 0.5 * ortho_height, w = h * aspect;
    p.m[0][0] = 1.0 / w;
    p.m[1][1] = 1.0 / h;
    p.m[2][2] = -2.0 / (f - n);
    p.m[2][3] = -(f + n) / (f - n);
    p.m[3][3] = 1.0;
  }
  return p;
}

Mat4 jittered_projection(const Mat4& projection, Vec2d jitter_px, int width, int height) {
  // -jitter.x px = -2 jx / W in NDC x; -jitter.y px (down) = +2 jy / H in NDC y (NDC +y up).
  Mat4 t = Mat4::identity();
  t.m[0][3] = -2.0 * jitter_px.x / width;
  t.m[1][3] = 2.0 * jitter_px.y / height;
  return t * projection;
}

Vec2d project_to_pixel(const Mat4& vp, Vec3d world, int width, int height, double* w_out) {
  Vec4d c = vp * Vec4d(world, 1.0);
  if (w_out) *w_out = c.w;
  const double nx = c.x / c.w, ny = c.y / c.w;
  return {(nx + 1.0) * 0.5 * width, (1.0 - ny) * 0.5 * height};
}

void validate_lens(const ThinLens& l) {
  const bool finite = std::isfinite(l.focal_length_mm) && std::isfinite(l.f_number) &&
                      std::isfinite(l.focus_distance) && std::isfinite(l.sensor_width_mm) &&
                      std::isfinite(l.blade_rotation_deg);
  if (!finite) throw SettingsError("lens: parameters must be finite");
  if (!(l.focal_length_mm > 0.0))
    throw SettingsError(fmt::format("lens focal length {} mm: must be > 0", l.focal_length_mm));
  if (!(l.sensor_width_mm > 0.0))
    throw SettingsError(fmt::format("lens sensor width {} mm: must be > 0", l.sensor_width_mm));
  if (l.f_number < 0.0)
    throw SettingsError(fmt::format("lens f-number {}: must be 0 (pinhole) or > 0", l.f_number));
  if (!(l.focus_distance > l.focal_length_mm * 1e-3))
    throw SettingsError(fmt::format("lens focus distance {}: must exceed the focal length ({} m)",
                                    l.focus_distance, l.focal_length_mm * 1e-3));
  if (l.blades != 0 && (l.blades < 3 || l.blades > 16))
    throw SettingsError(fmt::format("lens blades {}: must be 0 (disc) or 3..16", l.blades));
}

double circle_of_confusion_px(const ThinLens& l, double depth, int image_width) {
  if (!(l.f_number > 0.0)) return 0.0;
  const double f = l.focal_length_mm * 1e-3, s = l.focus_distance;  // m
  const double a = f / l.f_number;                                  // aperture diameter, m
  const double c_sensor_m = a * (depth - s) / depth * f / (s - f);
  return c_sensor_m * 1e3 * image_width / l.sensor_width_mm;
}

double focal_length_for_fov_mm(double vfov_degrees, double sensor_width_mm, double aspect) {
  const double tan_h = aspect * std::tan(0.5 * vfov_degrees * kPi / 180.0);
  return sensor_width_mm / (2.0 * tan_h);
}

double fov_for_focal_length_deg(double focal_length_mm, double sensor_width_mm, double aspect) {
  const double tan_h = sensor_width_mm / (2.0 * focal_length_mm);
  return 2.0 * std::atan(tan_h / aspect) * 180.0 / kPi;
}

double thin_lens_ray_radius(const ThinLens& l) {
  if (!(l.f_number > 0.0)) return 0.0;
  const double f = l.focal_length_mm * 1e-3, s = l.focus_distance;
  return l.aperture_radius() * s / (s - f);
}

ThinLens frame_lens(const Camera& camera, int width, int height) {
  ThinLens l = camera.lens;
  if (camera.type == ProjectionType::Perspective)
    l.focal_length_mm = focal_length_for_fov_mm(camera.vfov_degrees, l.sensor_width_mm,
                                                double(width) / double(height));
  return l;
}

double halton(unsigned index, unsigned base) {
  double f = 1.0, r = 0.0;
  while (index > 0) {
    f /= base;
    r += f * (index % base);
    index /= base;
  }
  return r;
}

Vec2d JitterSequence::at(long frame) const {
  if (pattern == JitterPattern::None || length <= 0) return {0.0, 0.0};
  const unsigned k = unsigned(((frame % length) + length) % length) + 1;  // skip index 0
  return {halton(k, 2) - 0.5, halton(k, 3) - 0.5};
}

JitterSequence parse_jitter(const std::string& name) {
  if (name == "none") return {JitterPattern::None, 1};
  if (name.rfind("halton", 0) == 0) {
    const std::string n = name.substr(6);
    int len = 16;
    if (!n.empty()) {
      try {
        size_t used = 0;
        len = std::stoi(n, &used);
        if (used != n.size()) throw std::invalid_argument(n);
      } catch (const std::exception&) {
        throw SettingsError("jitter pattern '" + name +
                            "': expected haltonN with N a whole number");
      }
    }
    if (len < 1 || len > 1024)
      throw SettingsError("jitter pattern '" + name + "': length must be in [1, 1024]");
    return {JitterPattern::Halton, len};
  }
  throw SettingsError("unknown jitter pattern '" + name +
                      "' (expected halton16, halton8, haltonN, none)");
}

}  // namespace afterimage
