#include "render/scene.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"

namespace afterimage::render {

namespace {

void add_quad(Mesh& m, Vec3f p0, Vec3f p1, Vec3f p2, Vec3f p3, Vec3f n) {
  // p0..p3 counter-clockwise seen from the side `n` points to; uv (0,0) (1,0) (1,1) (0,1).
  const uint32_t b = uint32_t(m.positions.size());
  for (Vec3f p : {p0, p1, p2, p3}) {
    m.positions.push_back(p);
    m.normals.push_back(n);
  }
  m.uvs.insert(m.uvs.end(), {Vec2f{0, 0}, Vec2f{1, 0}, Vec2f{1, 1}, Vec2f{0, 1}});
  m.indices.insert(m.indices.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
}

}  // namespace

Mesh make_box(Vec3d h) {
  const float x = float(h.x), y = float(h.y), z = float(h.z);
  Mesh m;
  add_quad(m, {x, -y, z}, {x, -y, -z}, {x, y, -z}, {x, y, z}, {1, 0, 0});
  add_quad(m, {-x, -y, -z}, {-x, -y, z}, {-x, y, z}, {-x, y, -z}, {-1, 0, 0});
  add_quad(m, {-x, y, z}, {x, y, z}, {x, y, -z}, {-x, y, -z}, {0, 1, 0});
  add_quad(m, {-x, -y, -z}, {x, -y, -z}, {x, -y, z}, {-x, -y, z}, {0, -1, 0});
  add_quad(m, {-x, -y, z}, {x, -y, z}, {x, y, z}, {-x, y, z}, {0, 0, 1});
  add_quad(m, {x, -y, -z}, {-x, -y, -z}, {-x, y, -z}, {x, y, -z}, {0, 0, -1});
  return m;
}

Mesh make_sphere(double radius, int segments, int rings) {
  AI_CHECK(segments >= 3 && rings >= 2);
  Mesh m;
  // (segments + 1) x (rings + 1) vertices so that the u = 0 / u = 1 seam has its own UVs.
  for (int r = 0; r <= rings; ++r) {
    const double v = double(r) / rings, theta = v * kPi;  // from +y (v = 0) to -y
    for (int s = 0; s <= segments; ++s) {
      const double u = double(s) / segments, phi = u * 2.0 * kPi;
      const Vec3d n{std::sin(theta) * std::cos(phi), std::cos(theta),
                    -std::sin(theta) * std::sin(phi)};
      m.positions.push_back(to_float(n * radius));
      m.normals.push_back(to_float(n));
      m.uvs.push_back({float(u), float(1.0 - v)});
    }
  }
  const uint32_t row = uint32_t(segments + 1);
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const uint32_t a = uint32_t(r) * row + uint32_t(s), b = a + row;
      // Skip the degenerate triangle at each pole.
      if (r != 0) m.indices.insert(m.indices.end(), {a, b, a + 1});
      if (r != rings - 1) m.indices.insert(m.indices.end(), {a + 1, b, b + 1});
    }
  return m;
}

Mesh make_plane(double size_x, double size_z, int nx, int nz) {
  AI_CHECK(nx >= 1 && nz >= 1);
  Mesh m;
  for (int j = 0; j <= nz; ++j)
    for (int i = 0; i <= nx; ++i) {
      const double u = double(i) / nx, v = double(j) / nz;
      m.positions.push_back({float((u - 0.5) * size_x), 0.0f, float((0.5 - v) * size_z)});
      m.normals.push_back({0, 1, 0});
      m.uvs.push_back({float(u), float(v)});
    }
  const uint32_t row = uint32_t(nx + 1);
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      const uint32_t a = uint32_t(j) * row + uint32_t(i), b = a + row;
      // v grows toward -z, so (a, a+1, b+1) is counter-clockwise seen from +y.
      m.indices.insert(m.indices.end(), {a, a + 1, b + 1, a, b + 1, b});
    }
  return m;
}

Mesh make_cylinder(double radius, double height, int segments) {
  AI_CHECK(segments >= 3);
  Mesh m;
  for (int k = 0; k <= 1; ++k)
    for (int s = 0; s <= segments; ++s) {
      const double u = double(s) / segments, phi = u * 2.0 * kPi;
      const Vec3d n{std::cos(phi), 0.0, -std::sin(phi)};
      m.positions.push_back({float(n.x * radius), float(k * height), float(n.z * radius)});
      m.normals.push_back(to_float(n));
      m.uvs.push_back({float(u), float(k)});
    }
  const uint32_t row = uint32_t(segments + 1);
  for (int s = 0; s < segments; ++s) {
    const uint32_t a = uint32_t(s), b = a + row;
    m.indices.insert(m.indices.end(), {a, a + 1, b + 1, a, b + 1, b});
  }
  return m;
}

Vec3f material_albedo(const Material& m, Vec2d uv) {
  const double f = m.frequency;
  switch (m.texture) {
    case Texture::None:
      return m.albedo;
    case Texture::Checker: {
      const long a = long(std::floor(uv.x * f)) + long(std::floor(uv.y * f));
      return (a & 1) ? m.albedo2 : m.albedo;
    }
    case Texture::Stripes:
      return (long(std::floor(uv.x * f)) & 1) ? m.albedo2 : m.albedo;
    case Texture::Sine: {
      const double s = 0.5 + 0.5 * std::sin(2 * kPi * f * uv.x) * std::sin(2 * kPi * f * uv.y);
      return to_float(lerp(to_double(m.albedo), to_double(m.albedo2), s));
    }
  }
  return m.albedo;
}

Mat4 Transform::matrix() const {
  return translate(translation) * rotation.to_matrix() * afterimage::scale(scale);
}

bool Blink::on(double t) const {
  if (!(period > 0)) return true;
  const double x = (t + phase) / period;
  return x - std::floor(x) < on_fraction;
}

Transform Animation::at(double t) const {
  if (function) return function(t);
  if (keys.empty()) return {};
  if (t <= keys.front().time) return keys.front().transform;
  if (t >= keys.back().time) return keys.back().transform;
  // First key with time > t (keys are sorted; validate() checks it).
  size_t i = 1;
  while (keys[i].time <= t) ++i;
  const Keyframe& a = keys[i - 1];
  const Keyframe& b = keys[i];
  const double s = (t - a.time) / (b.time - a.time);
  Transform r;
  r.translation = lerp(a.transform.translation, b.transform.translation, s);
  r.rotation = slerp(a.transform.rotation, b.transform.rotation, s);
  r.scale = lerp(a.transform.scale, b.transform.scale, s);
  return r;
}

Light light_at(const Light& light, double t) {
  Light l = light;
  if (!l.animation.is_identity()) {
    const Mat4 m = l.animation.matrix(t);
    l.position = l.type == LightType::Directional ? normalize(m.transform_dir(l.position))
                                                  : m.transform_point(l.position);
    if (l.type == LightType::Quad) {
      l.edge_u = m.transform_dir(l.edge_u);
      l.edge_v = m.transform_dir(l.edge_v);
    }
  }
  if (!l.blink.on(t)) l.color = {0.0f, 0.0f, 0.0f};
  return l;
}

Vec3f sky_radiance(const Sky& sky, Vec3d d) {
  d = normalize(d);
  const double y = std::clamp(d.y, -1.0, 1.0);
  // sqrt of the elevation keeps the horizon band narrow, as in a real sky.
  Vec3d c = y >= 0 ? lerp(to_double(sky.horizon), to_double(sky.zenith), std::sqrt(y))
                   : lerp(to_double(sky.horizon), to_double(sky.ground), std::sqrt(-y));
  const double azimuth = std::atan2(d.z, d.x);
  c *= 1.0 + sky.azimuth_variation * std::sin(3.0 * azimuth) * (1.0 - std::abs(y));
  return to_float(c);
}

bool Scene::camera_cut_at(int frame) const {
  if (is_static || frame <= 0) return false;
  const double t0 = eval_time(frame - 1), t1 = eval_time(frame);
  for (double c : camera_cuts)
    if (c > t0 && c <= t1) return true;
  return false;
}

Mat4 Scene::view_at(double t) const {
  // The camera pose is rigid, so its inverse is exact enough in double precision.
  return camera_motion.matrix(t).inverse();
}

int Scene::add_mesh(Mesh m) {
  meshes.push_back(std::move(m));
  return int(meshes.size()) - 1;
}

uint32_t Scene::add_object(const std::string& object_name, int mesh, const Material& mat,
                           const Animation& anim) {
  objects.push_back(Object{object_name, mesh, mat, anim});
  return uint32_t(objects.size());
}

void Scene::validate() const {
  for (size_t k = 0; k < meshes.size(); ++k) {
    const Mesh& m = meshes[k];
    if (m.normals.size() != m.positions.size() || m.uvs.size() != m.positions.size())
      throw SettingsError(
          fmt::format("scene '{}': mesh {} needs one normal and uv per vertex", name, k));
    if (m.indices.size() % 3 != 0)
      throw SettingsError(fmt::format("scene '{}': mesh {} index count is not 3 n", name, k));
    for (uint32_t i : m.indices)
      if (i >= m.positions.size())
        throw SettingsError(fmt::format("scene '{}': mesh {} index {} out of range", name, k, i));
  }
  auto check_keys = [&](const Animation& a, const std::string& what) {
    for (size_t i = 1; i < a.keys.size(); ++i)
      if (!(a.keys[i].time > a.keys[i - 1].time))
        throw SettingsError(
            fmt::format("scene '{}': {} keyframes not strictly increasing in time", name, what));
  };
  for (const Object& o : objects) {
    if (o.mesh < 0 || size_t(o.mesh) >= meshes.size())
      throw SettingsError(
          fmt::format("scene '{}': object '{}' has no mesh {}", name, o.name, o.mesh));
    check_keys(o.animation, "object '" + o.name + "'");
  }
  check_keys(camera_motion, "camera");
  for (size_t i = 0; i < camera_cuts.size(); ++i)
    if (!(camera_cuts[i] > (i == 0 ? 0.0 : camera_cuts[i - 1])))
      throw SettingsError(
          fmt::format("scene '{}': camera cuts must be > 0 and strictly increasing", name));
  for (const Light& l : lights) {
    if (l.type == LightType::Sphere && !(l.radius > 0))
      throw SettingsError(fmt::format("scene '{}': sphere light needs radius > 0", name));
    if (l.type == LightType::Quad && !(length(cross(l.edge_u, l.edge_v)) > 0))
      throw SettingsError(fmt::format("scene '{}': quad light needs two non-parallel edges", name));
    check_keys(l.animation, "light");
  }
  for (const Object& o : objects)
    if (o.material.bump != Bump::None &&
        !(o.material.bump_frequency > 0 && o.material.bump_slope >= 0))
      throw SettingsError(fmt::format(
          "scene '{}': object '{}' bump needs frequency > 0 and slope >= 0", name, o.name));
  if (!(fps > 0)) throw SettingsError(fmt::format("scene '{}': fps must be > 0", name));
}

Keyframe camera_keyframe(double time, Vec3d eye, Vec3d target, Vec3d up) {
  const Mat4 cam_to_world = look_at(eye, target, up).inverse();
  Keyframe k;
  k.time = time;
  k.transform.translation = eye;
  k.transform.rotation = Quat::from_matrix(cam_to_world);
  return k;
}

}  // namespace afterimage::render
