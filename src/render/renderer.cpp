#include "render/renderer.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <string>
#include <utility>

#include "camera/aperture.h"
#include "core/error.h"
#include "render/accel.h"
#include "render/frame_context.h"
#include "render/shading.h"

namespace afterimage::render {

void RenderSettings::validate() const {
  if (width < 1 || height < 1)
    throw SettingsError(
        fmt::format("render size {}x{}: width and height must be >= 1", width, height));
  samples_per_axis(light_samples, "light_samples");
  effects.validate();
  if (path_trace) {
    path_trace->validate();
    if (shading_cache) throw SettingsError("path tracing and the shading cache cannot be combined");
    if (effects.any())
      throw SettingsError("path tracing has no camera effects (depth of field, motion blur)");
  }
  if (gradients && !path_trace)
    throw SettingsError("temporal gradients (--gradients) need path tracing (--path-trace)");
}

ShutterProfile parse_shutter_profile(const std::string& name) {
  if (name == "box") return ShutterProfile::Box;
  if (name == "triangle") return ShutterProfile::Triangle;
  throw SettingsError("shutter profile '" + name + "': expected box or triangle");
}

void CameraEffects::validate() const {
  if (!(shutter_angle_deg >= 0.0 && shutter_angle_deg <= 360.0))  // NaN fails too
    throw SettingsError(
        fmt::format("shutter angle {}: must be in [0, 360] degrees", shutter_angle_deg));
  if (shutter_samples < 0)
    throw SettingsError(fmt::format("shutter samples {}: must be >= 0", shutter_samples));
}

double shutter_time_offset(const CameraEffects& fx, double fps, int i, int strata) {
  const double u = (i + 0.5) / strata;
  // Position in the shutter interval, [0, 1]; triangle: inverse of its CDF 2x^2 | 1 - 2(1-x)^2.
  double phi = u;
  if (fx.shutter_profile == ShutterProfile::Triangle)
    phi = u < 0.5 ? std::sqrt(0.5 * u) : 1.0 - std::sqrt(0.5 * (1.0 - u));
  return (phi - 0.5) * (fx.shutter_angle_deg / 360.0) / fps;
}

int samples_per_axis(int spp, const std::string& what) {
  if (spp >= 1) {
    const int n = int(std::lround(std::sqrt(double(spp))));
    if (n * n == spp) return n;
  }
  throw SettingsError(
      fmt::format("{} = {}: must be a perfect square >= 1 (1, 4, 16, 64, 256, ...)", what, spp));
}

namespace {
void check_render_scale(double scale) {
  if (!(scale >= 1.0 && scale <= 4.0))  // NaN fails too
    throw SettingsError(fmt::format("--render-scale {}: must be in [1, 4]", scale));
}
}  // namespace

std::pair<int, int> scaled_render_size(int width, int height, double scale) {
  check_render_scale(scale);
  return {std::max(1, int(std::lround(width / scale))),
          std::max(1, int(std::lround(height / scale)))};
}

int jitter_length_for_scale(double scale) {
  check_render_scale(scale);
  // FSR2's phase count 8 * scale^2 (FidelityFX FSR2 README, "Camera jitter"); the 1e-9 keeps
  // 8 * 1.5^2 = 18 from rounding up to 19.
  return int(std::ceil(8.0 * scale * scale - 1e-9));
}

FrameCamera frame_camera(const Scene& scene, int frame_index, int width, int height) {
  return {scene.view_at(scene.eval_time(frame_index)), scene.camera.projection(width, height)};
}

// Helpers shared with path_tracer.cpp (frame_context.h declares them) and the renderer's own.
namespace detail {

// Direct light at a surface, split as compose_shading takes it.
struct DirectLight {
  Vec3d diffuse{0.0}, specular{0.0};
};

// Direct lighting at a surface point (Lambert + Blinn-Phong, shadow rays to every light),
// demodulated: the color it adds is albedo * diffuse + specular (compose_shading).
DirectLight direct_light(const FrameContext& fc, const Material& mat, Vec3d albedo, Vec3d p,
                         Vec3d n, Vec3d ng, Vec3d v, Rng& rng, RayCounts& counts) {
  const Vec3d origin = offset_origin(p, ng);
  DirectLight sum;
  const bool black = albedo.x <= 0.0 && albedo.y <= 0.0 && albedo.z <= 0.0;
  for (const Light& l : fc.lights) {
    const bool area = fc.soft_shadows && (l.type == LightType::Sphere || l.type == LightType::Quad);
    const int na = area ? fc.light_axis : 1;
    DirectLight acc;
    for (int k = 0; k < na * na; ++k) {
      Vec2d uv{0.5, 0.5};
      if (area) uv = {(k % na + rng.uniform()) / na, (k / na + rng.uniform()) / na};
      LightSample s;
      if (!sample_light(l, p, uv, !area, &s)) continue;
      if (dot(s.dir, ng) <= 0.0) continue;  // light below the surface
      const BrdfCosSplit f = brdf_cos_split(mat.specular, mat.shininess, n, v, s.dir);
      if ((black || f.diffuse <= 0.0) && f.specular <= 0.0) continue;  // adds nothing
      ++counts.shadow;
      if (fc.accel->occluded(origin, s.dir, 0.0, s.distance)) continue;
      acc.diffuse += s.weight * f.diffuse;
      acc.specular += s.weight * f.specular;
    }
    sum.diffuse += acc.diffuse * (1.0 / (na * na));
    sum.specular += acc.specular * (1.0 / (na * na));
  }
  return sum;
}

// The thin-lens ray of pixel position `pos` through aperture sample `lens_u` in [0, 1)^2
// (CameraEffects::depth_of_field); *tnear clips it at the near plane as the pinhole ray is.
Ray thin_lens_ray(const FrameContext& fc, Vec2d pos, Vec2d lens_u, double* tnear) {
  const Ray pin = camera_ray(fc.inv_vp, pos, fc.width, fc.height);
  const Vec3d d = fc.view.transform_dir(pin.dir);  // view space, looking down -z
  const Vec3d focus = d * (fc.lens.focus_distance / -d.z);
  const Vec2d a = aperture_sample(fc.lens, lens_u) * fc.lens_radius;
  const Vec3d o{a.x, a.y, 0.0};
  const Vec3d dir = normalize(focus - o);
  *tnear = fc.near_plane / -dir.z;
  return {fc.inv_view.transform_point(o), normalize(fc.inv_view.transform_dir(dir))};
}

Surface surface_at_hit(const FrameContext& fc, const Vec3d& origin, const Vec3d& dir,
                       const Hit& h) {
  const Object& obj = fc.scene->objects[h.object];
  const ObjectFrame& of = fc.objects[h.object];
  const Mesh& mesh = fc.scene->meshes[size_t(obj.mesh)];
  const uint32_t i0 = mesh.indices[3 * h.prim], i1 = mesh.indices[3 * h.prim + 1],
                 i2 = mesh.indices[3 * h.prim + 2];
  const double b1 = h.u, b2 = h.v, b0 = 1.0 - b1 - b2;
  const Vec3d n_local = to_double(mesh.normals[i0]) * b0 + to_double(mesh.normals[i1]) * b1 +
                        to_double(mesh.normals[i2]) * b2;
  const Vec3d ng_local = cross(to_double(mesh.positions[i1] - mesh.positions[i0]),
                               to_double(mesh.positions[i2] - mesh.positions[i0]));
  const Vec2d uv{mesh.uvs[i0].x * b0 + mesh.uvs[i1].x * b1 + mesh.uvs[i2].x * b2,
                 mesh.uvs[i0].y * b0 + mesh.uvs[i1].y * b1 + mesh.uvs[i2].y * b2};

  const Vec3d p = origin + dir * double(h.t);
  Vec3d n = normalize(of.normal_to_world.transform_dir(n_local));
  Vec3d ng = normalize(of.normal_to_world.transform_dir(ng_local));
  // Two-sided surfaces: face both normals toward the viewer (open cylinders, planes).
  if (dot(ng, dir) > 0.0) ng = -ng;
  if (dot(n, ng) < 0.0) n = -n;
  if (obj.material.bump != Bump::None) {
    // dp/du, dp/dv of the triangle (PBRT-v3 3.6.2), in world space.
    const Vec3d e1 = to_double(mesh.positions[i1] - mesh.positions[i0]);
    const Vec3d e2 = to_double(mesh.positions[i2] - mesh.positions[i0]);
    const double du1 = mesh.uvs[i1].x - mesh.uvs[i0].x, dv1 = mesh.uvs[i1].y - mesh.uvs[i0].y;
    const double du2 = mesh.uvs[i2].x - mesh.uvs[i0].x, dv2 = mesh.uvs[i2].y - mesh.uvs[i0].y;
    const double det = du1 * dv2 - dv1 * du2;
    Vec3d dpdu(0.0), dpdv(0.0);
    if (std::abs(det) > 1e-20) {
      dpdu = of.to_world.transform_dir((e1 * dv2 - e2 * dv1) / det);
      dpdv = of.to_world.transform_dir((e2 * du1 - e1 * du2) / det);
    }
    n = perturb_normal(n, dpdu, dpdv, bump_slope(obj.material, uv));
  }

  const Vec3d albedo = to_double(material_albedo(obj.material, uv));
  const Vec3d emission = of.emits ? to_double(obj.material.emission) : Vec3d(0.0);
  Surface surf;
  surf.hit = true;
  surf.material = &obj.material;
  surf.p = p;
  surf.n = n;
  surf.ng = ng;
  surf.v = -dir;
  surf.albedo = albedo;
  surf.emission = emission;
  surf.base = emission + albedo * to_double(fc.scene->ambient);
  return surf;
}

// The surface a camera ray hits (surf.hit false and the sky as its base on a miss).
Hit primary_surface(const FrameContext& fc, const Ray& ray, double tnear, RayCounts& counts,
                    Surface& surf) {
  ++counts.primary;
  const Hit h = fc.accel->intersect(ray.origin, ray.dir, tnear, 1e30);
  surf = Surface{};
  if (!h.hit)
    surf.base = to_double(sky_radiance(fc.scene->sky, ray.dir));
  else
    surf = surface_at_hit(fc, ray.origin, ray.dir, h);
  return h;
}

// The primary hit of a camera ray (frame_context.h).
Sample trace_surface_ray(const FrameContext& fc, const Ray& ray, double tnear, RayCounts& counts,
                         Surface& surf) {
  const Hit h = primary_surface(fc, ray, tnear, counts, surf);
  Sample s;
  if (!h.hit) {
    // Motion stays exactly zero when nothing moved (static scenes, frame 0): two projections
    // of one point can differ in the last bit once the compiler contracts them into FMAs.
    if (fc.camera_moved && !fc.orthographic) {
      s.motion = direction_motion(fc.vp_prev, fc.vp, ray.dir, fc.width, fc.height);
    } else if (fc.camera_moved) {  // parallel rays have no direction at infinity: far point
      const Vec3d pf = ray.origin + ray.dir * fc.far_plane;
      s.motion = surface_motion(fc.vp_prev, fc.vp, pf, pf, fc.width, fc.height);
    }
    if (fc.motion_next && fc.camera_moves_next && !fc.orthographic) {
      s.motion_next = direction_motion(fc.vp_next, fc.vp, ray.dir, fc.width, fc.height);
    } else if (fc.motion_next && fc.camera_moves_next) {
      const Vec3d pf = ray.origin + ray.dir * fc.far_plane;
      s.motion_next = surface_motion(fc.vp_next, fc.vp, pf, pf, fc.width, fc.height);
    }
    return s;
  }
  const ObjectFrame& of = fc.objects[h.object];
  const Vec3d p = surf.p;
  s.depth = float(-(fc.view.transform_point(p)).z);
  s.normal = to_float(surf.n);
  s.albedo = to_float(surf.albedo);
  s.id = h.object + 1;
  if (fc.camera_moved || of.moved)  // else exactly zero, as for the sky
    s.motion =
        surface_motion(fc.vp_prev, fc.vp, of.to_prev.transform_point(p), p, fc.width, fc.height);
  if (fc.motion_next && (fc.camera_moves_next || of.moves_next))
    s.motion_next =
        surface_motion(fc.vp_next, fc.vp, of.to_next.transform_point(p), p, fc.width, fc.height);
  return s;
}

// The pinhole camera sample at pixel position `pos`.
Sample trace_surface(const FrameContext& fc, Vec2d pos, RayCounts& counts, Surface& surf) {
  return trace_surface_ray(fc, camera_ray(fc.inv_vp, pos, fc.width, fc.height), 0.0, counts, surf);
}

DirectLight shade_direct(const FrameContext& fc, const Surface& surf, Rng& rng, RayCounts& counts) {
  if (!surf.hit) return {};
  return direct_light(fc, *surf.material, surf.albedo, surf.p, surf.n, surf.ng, surf.v, rng,
                      counts);
}

// A fully shaded camera sample.
Sample trace_sample(const FrameContext& fc, Vec2d pos, Rng& rng, RayCounts& counts) {
  Surface surf;
  Sample s = trace_surface(fc, pos, counts, surf);
  const DirectLight d = shade_direct(fc, surf, rng, counts);
  s.color = compose_shading(surf.base, surf.albedo, d.diffuse, d.specular);
  return s;
}

// Color of one camera ray (lens samples), fully shaded: trace_sample's color without the
// G-buffer values (depth, motion) a reference's samples do not keep (their transforms and
// projections: about -5% wall clock on a 320x180 thin reference render).
Vec3d trace_ray_color(const FrameContext& fc, const Ray& ray, double tnear, Rng& rng,
                      RayCounts& counts) {
  Surface surf;
  primary_surface(fc, ray, tnear, counts, surf);
  const DirectLight d = shade_direct(fc, surf, rng, counts);
  return compose_shading(surf.base, surf.albedo, d.diffuse, d.specular);
}
// The pinhole camera's color at pixel position `pos` (trace_sample's color).
Vec3d trace_color(const FrameContext& fc, Vec2d pos, Rng& rng, RayCounts& counts) {
  return trace_ray_color(fc, camera_ray(fc.inv_vp, pos, fc.width, fc.height), 0.0, rng, counts);
}

void store(Frame& f, int x, int y, const Sample& s, Vec3d color) {
  // Float values of the float channels the renderer produces, by key (planes beyond the
  // channel's count are unused); stored through the table's generic access.
  const std::pair<Channel, std::array<float, 3>> values[] = {
      {Channel::color, {float(color[0]), float(color[1]), float(color[2])}},
      {Channel::depth, {s.depth}},
      {Channel::normal, {s.normal.x, s.normal.y, s.normal.z}},
      {Channel::albedo, {s.albedo.x, s.albedo.y, s.albedo.z}},
      {Channel::motion, {float(s.motion.x), float(s.motion.y)}},
  };
  for (const auto& [key, v] : values) {
    ImageF& img = *f.plane_set(key);
    for (int c = 0; c < channel_info(key).planes; ++c) img.at(x, y, c) = v[size_t(c)];
  }
  f.plane_set_u32(Channel::id)->at(x, y, 0) = s.id;
  if (f.has(Channel::motion_next)) {
    f.motion_next.at(x, y, 0) = float(s.motion_next.x);
    f.motion_next.at(x, y, 1) = float(s.motion_next.y);
  }
}

std::vector<Mat4> object_matrices(const Scene& sc, double t) {
  std::vector<Mat4> m;
  m.reserve(sc.objects.size());
  for (const Object& o : sc.objects) m.push_back(o.animation.matrix(t));
  return m;
}

// Builds the BVH at the frame's time and the per-frame matrices; fills the frame's camera.
// What every context of a scene and settings shares, before the frame's time is known.
FrameContext base_context(const Scene& sc, Accel& accel, const RenderSettings& rs) {
  FrameContext fc;
  fc.scene = &sc;
  fc.accel = &accel;
  fc.width = rs.width;
  fc.height = rs.height;
  fc.soft_shadows = rs.soft_shadows;
  fc.light_axis = samples_per_axis(rs.light_samples, "light_samples");
  fc.orthographic = sc.camera.type == ProjectionType::Orthographic;
  fc.far_plane = sc.camera.far_plane;
  return fc;
}

FrameContext setup_frame(const Scene& sc, Accel& accel, int frame_index, const RenderSettings& rs,
                         Frame& f) {
  rs.validate();
  sc.validate();
  if (frame_index < 0) throw SettingsError(fmt::format("frame index {} < 0", frame_index));
  FrameContext fc = base_context(sc, accel, rs);

  const double t = sc.eval_time(frame_index);
  // The "previous" frame of frame 0 and of the first frame after a camera cut is the frame
  // itself, so their motion is zero (DESIGN.md §3 Motion vectors).
  const bool cut = sc.camera_cut_at(frame_index);
  const int prev_index = cut ? frame_index : std::max(0, frame_index - 1);
  const double t_prev = sc.eval_time(prev_index);
  const FrameCamera cam = frame_camera(sc, frame_index, rs.width, rs.height);
  const FrameCamera cam_prev = frame_camera(sc, prev_index, rs.width, rs.height);
  // The next frame: motion_next is zero when it starts a camera cut (its history is not
  // this frame), like motion at a cut.
  fc.motion_next = rs.motion_next && !sc.camera_cut_at(frame_index + 1);
  const int next_index = fc.motion_next ? frame_index + 1 : frame_index;
  const double t_next = sc.eval_time(next_index);
  const FrameCamera cam_next = frame_camera(sc, next_index, rs.width, rs.height);
  fc.vp_next = cam_next.projection * cam_next.view;
  fc.camera_moves_next = !(fc.vp_next == fc.vp);
  fc.view = cam.view;
  fc.vp = cam.projection * cam.view;
  fc.inv_vp = fc.vp.inverse();
  fc.vp_prev = cam_prev.projection * cam_prev.view;
  fc.camera_moved = !(fc.vp_prev == fc.vp);

  const std::vector<Mat4> now = object_matrices(sc, t), prev = object_matrices(sc, t_prev),
                          next = object_matrices(sc, t_next);
  for (size_t k = 0; k < now.size(); ++k) {
    ObjectFrame of;
    of.to_world = now[k];
    of.emits = sc.objects[k].material.emission_blink.on(t);
    const Mat4 inv = now[k].inverse();
    of.normal_to_world = inv.transposed();
    // Exact identity for objects that did not move, so their motion is camera motion only
    // (and exactly 0 in static scenes).
    of.moved = !(prev[k] == now[k]);
    of.to_prev = of.moved ? prev[k] * inv : Mat4::identity();
    of.moves_next = !(next[k] == now[k]);
    of.to_next = of.moves_next ? next[k] * inv : Mat4::identity();
    fc.objects.push_back(of);
  }
  accel.set_transforms(now);
  for (const Light& l : sc.lights)
    if (l.blink.on(t)) fc.lights.push_back(light_at(l, t));

  f = Frame::allocate(rs.width, rs.height);
  if (rs.motion_next) f.allocate_channel(Channel::motion_next);
  f.view = cam.view;
  f.projection = cam.projection;
  f.index = frame_index;
  f.time = frame_index / sc.fps;
  f.lens = frame_lens(sc.camera, rs.width, rs.height);
  f.camera_cut = cut;
  return fc;
}

// Color-only context of a reference sub-frame at scene time t (CameraEffects): camera, objects,
// lights and the BVH at t; no motion (the frame's G-buffer channels come from setup_frame).
FrameContext setup_subframe(const Scene& sc, Accel& accel, double t, const RenderSettings& rs) {
  FrameContext fc = base_context(sc, accel, rs);
  fc.view = sc.view_at(t);
  fc.vp = sc.camera.projection(rs.width, rs.height) * fc.view;
  fc.inv_vp = fc.vp.inverse();
  fc.vp_prev = fc.vp;
  fc.vp_next = fc.vp;
  const std::vector<Mat4> now = object_matrices(sc, t);
  for (size_t k = 0; k < now.size(); ++k) {
    ObjectFrame of;
    of.to_world = now[k];
    of.emits = sc.objects[k].material.emission_blink.on(t);
    of.normal_to_world = now[k].inverse().transposed();
    fc.objects.push_back(of);
  }
  accel.set_transforms(now);
  for (const Light& l : sc.lights)
    if (l.blink.on(t)) fc.lights.push_back(light_at(l, t));
  if (rs.effects.depth_of_field) {
    fc.thin_lens = true;
    fc.inv_view = fc.view.inverse();
    fc.lens = frame_lens(sc.camera, rs.width, rs.height);
    fc.lens_radius = thin_lens_ray_radius(fc.lens);
    fc.near_plane = sc.camera.near_plane;
  }
  return fc;
}

// Time of sub-frame i of `strata` for frame `frame_index`: the shutter offset around the frame
// time, clipped to the frame's shot (not before the cut that starts it, not past the last frame
// time before the next cut: the camera's keys jump between those). Static scenes: 0.
double subframe_time(const Scene& sc, int frame_index, const CameraEffects& fx, int i, int strata) {
  const double t = sc.eval_time(frame_index);
  if (sc.is_static || !fx.motion_blur()) return t;
  double lo = -1e300, hi = 1e300;
  for (double c : sc.camera_cuts) {
    if (c <= t)
      lo = std::max(lo, c);
    else
      hi = std::min(hi, c - 1.0 / sc.fps);
  }
  return std::clamp(t + shutter_time_offset(fx, sc.fps, i, strata), lo, std::max(lo, hi));
}

// Random-number stream of a frame: static scenes use one stream for every frame, so their
// references are identical frame to frame (a reference must not flicker where the scene
// does not change); animated frames get independent streams.
int sample_stream(const Scene& sc, int frame_index, const RenderSettings& rs) {
  return sc.is_static && !rs.per_frame_light_samples ? 0 : frame_index;
}

}  // namespace detail

using namespace detail;

SceneRenderer::SceneRenderer(const Scene& scene, const RenderSettings& settings, const Exec& exec)
    : scene_(scene), settings_(settings), exec_(exec) {
  settings_.validate();
  scene_.validate();
  accel_ = std::make_unique<Accel>(scene_);
}

SceneRenderer::~SceneRenderer() = default;

void compose_frame_shading(Frame& f, const Exec& exec) {
  AI_CHECK(f.has(Channel::diffuse) && f.has(Channel::specular) && f.has(Channel::albedo));
  parallel_rows(exec, f.height, [&](int y) {
    for (int x = 0; x < f.width; ++x) {
      const Vec3f col = compose_shading(
          f.color_at(x, y), Vec3f{f.albedo.at(x, y, 0), f.albedo.at(x, y, 1), f.albedo.at(x, y, 2)},
          Vec3f{f.diffuse.at(x, y, 0), f.diffuse.at(x, y, 1), f.diffuse.at(x, y, 2)},
          Vec3f{f.specular.at(x, y, 0), f.specular.at(x, y, 1), f.specular.at(x, y, 2)});
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = col[c];
    }
  });
  f.diffuse = {};
  f.specular = {};
}

void SceneRenderer::set_effects(const CameraEffects& effects) {
  effects.validate();
  settings_.effects = effects;
}

void SceneRenderer::set_size(int width, int height) {
  RenderSettings s = settings_;
  s.width = width;
  s.height = height;
  s.validate();
  settings_ = s;
}

Frame SceneRenderer::gbuffer(int frame_index, RenderStats* stats) {
  if (settings_.path_trace)
    return settings_.gradients ? path_traced_gradients(frame_index, stats)
                               : path_traced(frame_index, stats);
  if (settings_.shading_cache) {
    if (!cache_)
      cache_ = std::make_unique<reproject::ShadingCache>(*settings_.shading_cache, exec_);
    RenderStats st;
    Frame f = gbuffer_masked(
        frame_index, [&](const Frame& g, std::vector<uint8_t>& mask) { cache_->plan(g, mask); },
        &st);
    const auto t0 = std::chrono::steady_clock::now();
    CacheFrameStats cs;
    cs.frame = frame_index;
    cs.counters = cache_->resolve(f);
    compose_frame_shading(f, exec_);
    cs.shadow_rays = st.shadow_rays;
    cs.seconds =
        st.seconds + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    st.seconds = cs.seconds;
    st.cache_frames.push_back(cs);
    if (stats) *stats += st;
    return f;
  }
  const auto t0 = std::chrono::steady_clock::now();
  Frame f;
  const FrameContext fc = setup_frame(scene_, *accel_, frame_index, settings_, f);
  f.jitter = settings_.jitter.at(frame_index);
  const Vec2d j = f.jitter;
  const int stream = sample_stream(scene_, frame_index, settings_);
  const RenderSettings& rs = settings_;
  RenderStats st = run_rows(exec_, rs.height, rs.progress, [&](int y, RayCounts& c) {
    for (int x = 0; x < rs.width; ++x) {
      Rng rng(pixel_key(rs.seed, stream, x, y, 0));
      const Sample s = trace_sample(fc, {x + 0.5 + j.x, y + 0.5 + j.y}, rng, c);
      store(f, x, y, s, s.color);
    }
  });
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (stats) *stats += st;
  return f;
}

Frame SceneRenderer::reference(int frame_index, int spp, RenderStats* stats) {
  if (settings_.path_trace) return path_reference(frame_index, spp, stats);
  const int n = samples_per_axis(spp, "reference samples per pixel");
  if (settings_.effects.any()) return reference_effects(frame_index, n, stats);
  const auto t0 = std::chrono::steady_clock::now();
  Frame f;
  const FrameContext fc = setup_frame(scene_, *accel_, frame_index, settings_, f);
  f.jitter = {0.0, 0.0};
  const int stream = sample_stream(scene_, frame_index, settings_);
  const RenderSettings& rs = settings_;
  RenderStats st = run_rows(exec_, rs.height, rs.progress, [&](int y, RayCounts& c) {
    for (int x = 0; x < rs.width; ++x) {
      Rng rng(pixel_key(rs.seed, stream, x, y, 1));
      // Box filter over the pixel footprint = plain mean of the stratified samples.
      Vec3d sum(0.0);
      for (int k = 0; k < n * n; ++k)
        sum += trace_color(fc, stratified_sample(x, y, n, k, rng), rng, c);
      const Sample center = trace_sample(fc, {x + 0.5, y + 0.5}, rng, c);
      store(f, x, y, center, sum * (1.0 / (n * n)));
    }
  });
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (stats) *stats += st;
  return f;
}

// Reference with camera effects: the accumulation buffer. The frame is rendered as `strata`
// sub-frames (the scene, camera and BVH at one shutter time each; 1 without motion blur); slot
// j of a pixel's n * n samples belongs to sub-frame j % strata and takes pixel stratum P[j] and
// lens stratum L[j], two per-pixel random permutations, so pixel position, lens position and
// time are each stratified and decorrelated (PBRT's shuffled stratified dimensions). Every slot
// has its own random numbers (pixel, slot): the result does not depend on threads.
Frame SceneRenderer::reference_effects(int frame_index, int n, RenderStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  const CameraEffects& fx = settings_.effects;
  const RenderSettings& rs = settings_;
  const int spp = n * n;
  if (fx.depth_of_field) {
    if (scene_.camera.type != ProjectionType::Perspective)
      throw SettingsError("depth of field reference: needs a perspective camera");
    if (!(scene_.camera.lens.f_number > 0.0))
      throw SettingsError("depth of field reference: the lens is a pinhole (f-number 0)");
    validate_lens(frame_lens(scene_.camera, rs.width, rs.height));  // the lens of the frames
  }
  int strata = 1;
  if (fx.motion_blur()) {
    strata = fx.shutter_samples;
    if (strata == 0)
      for (int d = std::min(spp, 64); d >= 1; --d)
        if (spp % d == 0) {
          strata = d;
          break;
        }
    if (strata > spp || spp % strata != 0)
      throw SettingsError(fmt::format(
          "shutter samples {}: must divide the reference's samples per pixel ({})", strata, spp));
  }
  const int stream = sample_stream(scene_, frame_index, rs);
  const size_t w = size_t(rs.width);
  std::vector<Vec3d> sum(w * size_t(rs.height), Vec3d(0.0));
  RenderStats st;
  for (int i = 0; i < strata; ++i) {
    const FrameContext fc =
        setup_subframe(scene_, *accel_, subframe_time(scene_, frame_index, fx, i, strata), rs);
    ProgressFn progress;
    if (rs.progress) progress = [&rs, i, strata](double f) { rs.progress((i + f) / (strata + 1)); };
    st += run_rows(exec_, rs.height, progress, [&](int y, RayCounts& c) {
      std::vector<int> pix(static_cast<size_t>(spp)), lens(static_cast<size_t>(spp));
      for (int x = 0; x < rs.width; ++x) {
        // The pixel's permutations (Fisher-Yates), the same in every sub-frame.
        Rng prng(pixel_key(rs.seed, stream, x, y, 2));
        for (int k = 0; k < spp; ++k) pix[size_t(k)] = lens[size_t(k)] = k;
        for (int k = spp - 1; k > 0; --k) {
          std::swap(pix[size_t(k)], pix[size_t(prng.next() % uint64_t(k + 1))]);
          std::swap(lens[size_t(k)], lens[size_t(prng.next() % uint64_t(k + 1))]);
        }
        Vec3d& acc = sum[size_t(y) * w + size_t(x)];
        for (int j = i; j < spp; j += strata) {
          Rng rng(pixel_key(rs.seed, stream, x, y, 16 + j));
          const Vec2d pos = stratified_sample(x, y, n, pix[size_t(j)], rng);
          if (fc.thin_lens) {
            const int q = lens[size_t(j)];
            const double u = (q % n + rng.uniform()) / n, v = (q / n + rng.uniform()) / n;
            double tnear = 0.0;
            const Ray ray = thin_lens_ray(fc, pos, {u, v}, &tnear);
            acc += trace_ray_color(fc, ray, tnear, rng, c);
          } else {
            acc += trace_color(fc, pos, rng, c);
          }
        }
      }
    });
  }
  // The G-buffer channels: the pinhole pixel-center sample at the frame time.
  Frame f;
  const FrameContext fc = setup_frame(scene_, *accel_, frame_index, settings_, f);
  f.jitter = {0.0, 0.0};
  ProgressFn progress;
  if (rs.progress) progress = [&rs, strata](double p) { rs.progress((strata + p) / (strata + 1)); };
  st += run_rows(exec_, rs.height, progress, [&](int y, RayCounts& c) {
    for (int x = 0; x < rs.width; ++x) {
      Rng rng(pixel_key(rs.seed, stream, x, y, 1));
      const Sample center = trace_sample(fc, {x + 0.5, y + 0.5}, rng, c);
      store(f, x, y, center, sum[size_t(y) * w + size_t(x)] * (1.0 / spp));
    }
  });
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (stats) *stats += st;
  return f;
}

Frame SceneRenderer::gbuffer_masked(int frame_index, const ShadeMaskFn& choose,
                                    RenderStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  Frame f;
  const FrameContext fc = setup_frame(scene_, *accel_, frame_index, settings_, f);
  f.jitter = settings_.jitter.at(frame_index);
  const Vec2d j = f.jitter;
  const int stream = sample_stream(scene_, frame_index, settings_);
  const RenderSettings& rs = settings_;
  const size_t w = size_t(rs.width);
  std::vector<Surface> surfaces(w * size_t(rs.height));
  // Primary rays only: progress covers the shading pass, which dominates.
  RenderStats st = run_rows(exec_, rs.height, {}, [&](int y, RayCounts& c) {
    for (int x = 0; x < rs.width; ++x) {
      Surface& surf = surfaces[size_t(y) * w + size_t(x)];
      Sample s = trace_surface(fc, {x + 0.5 + j.x, y + 0.5 + j.y}, c, surf);
      store(f, x, y, s, surf.base);
    }
  });
  std::vector<uint8_t> mask(surfaces.size(), 0);
  choose(f, mask);
  AI_CHECK(mask.size() == surfaces.size());
  f.allocate_channel(Channel::diffuse);
  f.allocate_channel(Channel::specular);
  st += run_rows(exec_, rs.height, rs.progress, [&](int y, RayCounts& c) {
    for (int x = 0; x < rs.width; ++x) {
      const size_t i = size_t(y) * w + size_t(x);
      if (!mask[i]) continue;
      // The key of gbuffer(): trace_surface draws no random numbers, so a shaded pixel gets
      // the light samples gbuffer() would give it.
      Rng rng(pixel_key(rs.seed, stream, x, y, 0));
      const DirectLight d = shade_direct(fc, surfaces[i], rng, c);
      for (int k = 0; k < 3; ++k) {
        f.diffuse.at(x, y, k) = float(d.diffuse[k]);
        f.specular.at(x, y, k) = float(d.specular[k]);
      }
    }
  });
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (stats) *stats += st;
  return f;
}

std::vector<SceneRenderer::SurfaceAt> SceneRenderer::surfaces_at(
    int frame_index, const std::vector<Vec2d>& positions) {
  Frame f;
  RenderSettings rs = settings_;
  rs.motion_next = false;
  const FrameContext fc = setup_frame(scene_, *accel_, frame_index, rs, f);
  std::vector<SurfaceAt> out(positions.size());
  RayCounts c;
  for (size_t i = 0; i < positions.size(); ++i) {
    Surface surf;
    const Sample s = trace_surface(fc, positions[i], c, surf);
    out[i] = {s.id, s.depth};
  }
  return out;
}

Frame render_gbuffer(const Scene& scene, int frame_index, const RenderSettings& settings,
                     const Exec& exec, RenderStats* stats) {
  return SceneRenderer(scene, settings, exec).gbuffer(frame_index, stats);
}

Frame render_reference(const Scene& scene, int frame_index, int spp, const RenderSettings& settings,
                       const Exec& exec, RenderStats* stats) {
  return SceneRenderer(scene, settings, exec).reference(frame_index, spp, stats);
}

void render_sequence(const Scene& scene, int frames, const std::vector<RenderPass>& passes,
                     const RenderSettings& settings, const Exec& exec,
                     const std::function<void(int, size_t, Frame&&)>& sink, RenderStats* stats,
                     const SequenceRenderProgress& progress) {
  if (frames < 1) throw SettingsError(fmt::format("frames {}: must be >= 1", frames));
  for (const RenderPass& p : passes) {
    if (p.spp < 0) throw SettingsError(fmt::format("{}: spp {} < 0", p.label, p.spp));
    if (p.spp != 0 && !settings.path_trace) samples_per_axis(p.spp, p.label);
    if (p.early_frames > 0 && (p.spp == 0) != (p.early_spp == 0))
      throw SettingsError(
          fmt::format("{}: early spp {} and spp {} must both be 0 (G-buffer) or not", p.label,
                      p.early_spp, p.spp));
    if (p.early_frames > 0 && p.early_spp != 0 && !settings.path_trace)
      samples_per_axis(p.early_spp, p.label);
    if (p.first_frame < 0)
      throw SettingsError(fmt::format("{}: first frame {} < 0", p.label, p.first_frame));
  }
  SceneRenderer r(scene, settings, exec);
  for (int k = 0; k < frames; ++k)
    for (size_t i = 0; i < passes.size(); ++i) {
      const RenderPass& p = passes[i];
      if (k < p.first_frame) continue;
      r.set_size(p.width > 0 ? p.width : settings.width, p.height > 0 ? p.height : settings.height);
      r.set_effects(p.effects);
      const uint64_t seed = p.seed.value_or(settings.seed);
      r.set_seed(k < p.early_frames ? p.early_seed.value_or(seed) : seed);
      if (progress)
        r.set_progress([&progress, k, i](double fraction) { progress(k, i, fraction); });
      const int spp = p.spp_at(k);
      sink(k, i, spp == 0 ? r.gbuffer(k, stats) : r.reference(k, spp, stats));
    }
}

}  // namespace afterimage::render
