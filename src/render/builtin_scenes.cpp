#include "render/builtin_scenes.h"

#include <cmath>
#include <cstdint>

#include "core/error.h"
#include "render/shading.h"

namespace afterimage::render {

namespace {

constexpr double kDeg = kPi / 180.0;

// Shared unit meshes; objects scale them (instancing keeps one BVH per shape).
struct UnitMeshes {
  int box, sphere, cylinder;
};
UnitMeshes add_unit_meshes(Scene& sc) {
  return {sc.add_mesh(make_box({0.5, 0.5, 0.5})), sc.add_mesh(make_sphere(1.0, 48, 24)),
          sc.add_mesh(make_cylinder(1.0, 1.0, 8))};
}

Transform xf(Vec3d t, Quat r = {}, Vec3d s = {1, 1, 1}) {
  return {t, r, s};
}

Material diffuse(Vec3f albedo) {
  Material m;
  m.albedo = albedo;
  return m;
}

Material textured(Texture tex, double freq, Vec3f a, Vec3f b) {
  Material m;
  m.texture = tex;
  m.frequency = freq;
  m.albedo = a;
  m.albedo2 = b;
  return m;
}

Light light(LightType type, Vec3d position, double radius, Vec3f color) {
  Light l;
  l.type = type;
  l.position = position;
  l.radius = radius;
  l.color = color;
  return l;
}

Light sun(Vec3d toward, Vec3f irradiance) {
  return light(LightType::Directional, normalize(toward), 0.0, irradiance);
}

// A sphere light and the emissive sphere the camera (and the glossy lobes) see.
void add_sphere_light(Scene& sc, const UnitMeshes& um, Vec3d center, double radius,
                      Vec3f radiance) {
  sc.lights.push_back(light(LightType::Sphere, center, radius, radiance));
  Material m = diffuse({0, 0, 0});
  m.emission = radiance;
  sc.add_object("light", um.sphere, m, Animation::fixed(xf(center, {}, Vec3d(radius))));
}

// Thin cylinder from a to b (poles, wires): the unit cylinder's +y axis rotated onto b - a.
Transform segment(Vec3d a, Vec3d b, double radius) {
  const Vec3d d = b - a;
  const double len = length(d);
  const Vec3d y{0, 1, 0}, dir = d / len;
  const Vec3d axis = cross(y, dir);
  const double s = length(axis), c = dot(y, dir);
  const Quat r = s < 1e-12 ? Quat{} : Quat::from_axis_angle(axis, std::atan2(s, c));
  return xf(a, r, {radius, len, radius});
}

// Keyframes of a constant-rate spin about `axis` (one key per quarter turn so slerp never
// takes the short way round the wrong side).
Animation spin(Vec3d position, Vec3d scale, Vec3d axis, double deg_per_s, double duration) {
  Animation a;
  const double step = 90.0 / std::abs(deg_per_s);
  for (double t = 0; t <= duration + 1e-9; t += step)
    a.keys.push_back({t, xf(position, Quat::from_axis_angle(axis, deg_per_s * t * kDeg), scale)});
  return a;
}

// thin: sub-pixel geometry, aliasing textures and a tiny specular highlight.
Scene thin_scene() {
  Scene sc;
  sc.name = "thin";
  sc.camera.vfov_degrees = 40.0;
  const UnitMeshes um = add_unit_meshes(sc);
  const int ground = sc.add_mesh(make_plane(60.0, 60.0));
  const int panel = sc.add_mesh(make_plane(10.0, 2.5));

  // 12.5 cm checker: ~6 px near the camera, far below a pixel toward the horizon (moire).
  sc.add_object("ground", ground,
                textured(Texture::Checker, 480.0, {0.75f, 0.74f, 0.7f}, {0.06f, 0.06f, 0.07f}),
                Animation::fixed(xf({0, 0, -20})));
  // Vertical panel with 2.5 cm stripes (~0.8 px at 18 m): shading aliasing on a flat surface.
  sc.add_object("stripes", panel,
                textured(Texture::Stripes, 400.0, {0.9f, 0.85f, 0.6f}, {0.1f, 0.12f, 0.2f}),
                Animation::fixed(xf({0, 1.25, -16}, Quat::from_axis_angle({1, 0, 0}, 90 * kDeg))));

  // Poles: front row 1.2 cm wide at ~10 m (~0.6 px), back row 1.6 cm at ~16 m (~0.5 px).
  const Material metal = diffuse({0.55f, 0.55f, 0.58f});
  for (int k = 0; k < 9; ++k) {
    const double x = -6.0 + 1.5 * k;
    sc.add_object("pole", um.cylinder, metal,
                  Animation::fixed(segment({x, 0, -8}, {x, 4, -8}, 0.006)));
    sc.add_object("pole", um.cylinder, metal,
                  Animation::fixed(segment({x + 0.75, 0, -14}, {x + 0.75, 5, -14}, 0.008)));
  }
  // Wires: 5 mm (~0.25 px), slightly sloped so they cross pixel rows (staircase crawl).
  const Material wire = diffuse({0.08f, 0.08f, 0.08f});
  for (int k = 0; k < 3; ++k) {
    const double h = 3.3 + 0.25 * k;
    sc.add_object("wire", um.cylinder, wire,
                  Animation::fixed(segment({-7, h, -8}, {7, h + 0.3, -8}, 0.0025)));
  }
  sc.add_object("guy wire", um.cylinder, wire,
                Animation::fixed(segment({-3, 3.9, -8}, {-1.2, 0, -6.5}, 0.0025)));

  // Glossy sphere and a small, very bright sphere light: a ~1 px highlight.
  Material gloss = diffuse({0.04f, 0.06f, 0.25f});
  gloss.specular = 0.8f;
  gloss.shininess = 800.0f;
  sc.add_object("glossy sphere", um.sphere, gloss,
                Animation::fixed(xf({1.2, 0.6, -3}, {}, Vec3d(0.6))));
  add_sphere_light(sc, um, {0.2, 2.0, -1.0}, 0.03, {4000.0f, 3800.0f, 3400.0f});
  sc.lights.push_back(sun({0.5, 0.8, 0.35}, {2.6f, 2.45f, 2.2f}));

  // Slow pan: 0.2 m/s sideways (~0.3 px/frame on the poles) with a slight turn.
  sc.camera_motion.keys = {camera_keyframe(0.0, {-1.0, 1.7, 2.0}, {-0.6, 1.5, -8.0}),
                           camera_keyframe(10.0, {1.0, 1.7, 2.0}, {0.6, 1.5, -8.0})};
  return sc;
}

// motion: fast foreground box (disocclusion), spinning objects, camera dolly.
Scene motion_scene() {
  Scene sc;
  sc.name = "motion";
  sc.camera.vfov_degrees = 40.0;
  const UnitMeshes um = add_unit_meshes(sc);
  const int ground = sc.add_mesh(make_plane(40.0, 40.0));
  const int wall = sc.add_mesh(make_plane(10.0, 3.6));

  sc.add_object("ground", ground,
                textured(Texture::Checker, 40.0, {0.55f, 0.55f, 0.5f}, {0.35f, 0.35f, 0.32f}),
                Animation::fixed(xf({0, 0, -10})));
  // Wall with 25 x 12 cm tiles behind the box: what the box uncovers must not ghost. Sky
  // stays visible above and beside it.
  sc.add_object("wall", wall,
                textured(Texture::Checker, 40.0, {0.8f, 0.45f, 0.3f}, {0.9f, 0.85f, 0.75f}),
                Animation::fixed(xf({0, 1.8, -6}, Quat::from_axis_angle({1, 0, 0}, 90 * kDeg))));

  // Box crossing the foreground: 4 m/s at ~6 m from the camera, ~11 px/frame at 640x360;
  // back and forth every 2 s, turning as it goes.
  Material box = textured(Texture::Stripes, 4.0, {0.1f, 0.5f, 0.85f}, {0.9f, 0.9f, 0.9f});
  box.specular = 0.2f;
  box.shininess = 40.0f;
  Animation crossing;
  for (int k = 0; k <= 5; ++k) {
    const double x = (k % 2 == 0) ? -4.0 : 4.0;
    crossing.keys.push_back(
        {2.0 * k,
         xf({x, 0.6, -1.0}, Quat::from_axis_angle({0, 1, 0}, 80 * kDeg * k), {1.0, 1.2, 1.0})});
  }
  sc.add_object("crossing box", um.box, box, crossing);

  // Spinning checker sphere (texture moves while the silhouette does not) and a tumbling box.
  sc.add_object("spinning sphere", um.sphere,
                textured(Texture::Checker, 12.0, {0.9f, 0.9f, 0.85f}, {0.7f, 0.1f, 0.1f}),
                spin({-2.2, 0.8, -3.5}, Vec3d(0.8), normalize(Vec3d{0.3, 1, 0.2}), 120.0, 12.0));
  Material tumble = diffuse({0.3f, 0.75f, 0.3f});
  tumble.specular = 0.3f;
  tumble.shininess = 60.0f;
  sc.add_object("tumbling box", um.box, tumble,
                spin({2.4, 1.0, -3.8}, Vec3d(0.9), normalize(Vec3d{1, 1, 0.3}), 90.0, 12.0));

  sc.lights.push_back(sun({-0.4, 0.75, 0.5}, {2.8f, 2.7f, 2.5f}));
  sc.lights.push_back(light(LightType::Point, {1.5, 2.5, 0.5}, 0.0, {3.0f, 2.6f, 2.0f}));

  // Dolly in: 0.3 m/s toward the wall.
  sc.camera_motion.keys = {camera_keyframe(0.0, {0.0, 1.6, 6.0}, {0.0, 1.1, -4.0}),
                           camera_keyframe(10.0, {0.0, 1.4, 3.0}, {0.0, 1.1, -4.0})};
  return sc;
}

// orbit: every pixel moves; the sky only by rotation.
Scene orbit_scene() {
  Scene sc;
  sc.name = "orbit";
  sc.camera.vfov_degrees = 45.0;
  const UnitMeshes um = add_unit_meshes(sc);
  const int ground = sc.add_mesh(make_plane(80.0, 80.0));

  sc.add_object("ground", ground,
                textured(Texture::Checker, 80.0, {0.5f, 0.52f, 0.45f}, {0.3f, 0.33f, 0.28f}),
                Animation::fixed(xf({0, 0, 0})));
  sc.add_object("pedestal", um.box, diffuse({0.6f, 0.58f, 0.55f}),
                Animation::fixed(xf({0, 0.3, 0}, {}, {2.4, 0.6, 2.4})));
  Material gloss = diffuse({0.6f, 0.15f, 0.1f});
  gloss.specular = 0.5f;
  gloss.shininess = 200.0f;
  sc.add_object("sphere", um.sphere, gloss, Animation::fixed(xf({0, 1.3, 0}, {}, Vec3d(0.7))));
  sc.add_object("striped sphere", um.sphere,
                textured(Texture::Stripes, 16.0, {0.9f, 0.9f, 0.9f}, {0.1f, 0.2f, 0.6f}),
                Animation::fixed(xf({2.2, 0.5, 1.5}, {}, Vec3d(0.5))));
  sc.add_object("box", um.box, diffuse({0.2f, 0.5f, 0.8f}),
                Animation::fixed(
                    xf({-2.0, 0.5, 1.2}, Quat::from_axis_angle({0, 1, 0}, 30 * kDeg), Vec3d(1.0))));
  sc.add_object("tall box", um.box,
                textured(Texture::Checker, 6.0, {0.85f, 0.8f, 0.3f}, {0.2f, 0.2f, 0.2f}),
                Animation::fixed(xf({-1.0, 1.0, -2.3}, Quat::from_axis_angle({0, 1, 0}, -20 * kDeg),
                                    {0.6, 2.0, 0.6})));
  sc.add_object("column", um.cylinder, diffuse({0.8f, 0.8f, 0.8f}),
                Animation::fixed(segment({2.0, 0, -1.8}, {2.0, 2.5, -1.8}, 0.25)));
  for (int k = 0; k < 4; ++k) {
    const double a = (45.0 + 90.0 * k) * kDeg;
    sc.add_object("post", um.cylinder, diffuse({0.15f, 0.15f, 0.15f}),
                  Animation::fixed(segment({3.6 * std::cos(a), 0, 3.6 * std::sin(a)},
                                           {3.6 * std::cos(a), 1.2, 3.6 * std::sin(a)}, 0.02)));
  }
  sc.lights.push_back(sun({0.3, 0.7, 0.6}, {3.0f, 2.8f, 2.5f}));

  // Orbit of radius 7 at 24 deg/s (a turn in 15 s); one key per frame for 20 s so the
  // piecewise-linear path stays within 0.2 mm of the circle.
  const double radius = 7.0, height = 1.7, rate = 24.0 * kDeg;
  for (int k = 0; k <= 600; ++k) {
    const double t = k / 30.0, a = rate * t;
    sc.camera_motion.keys.push_back(
        camera_keyframe(t, {radius * std::sin(a), height, radius * std::cos(a)}, {0, 1.2, 0}));
  }
  return sc;
}

// ---- Scenes of the failure modes TAA users hit (issue 10) ----------------------------------

// Deterministic scene-building randomness in [0, 1) (placement of blades): a hash of the
// indices, so scenes do not depend on any global generator.
double hash01(uint64_t a, uint64_t b) {
  return double(mix64(mix64(a ^ 0x2545f4914f6cdd1dULL) ^ b) >> 11) * 0x1.0p-53;
}

// light: lighting changes while nothing moves. A point light sweeps a sharp shadow of a
// plate on a post across a still floor, and a panel (with a light in front of it) blinks
// 4 frames on, 4 off. Camera and geometry are still, so motion is exactly zero everywhere.
Scene light_scene() {
  Scene sc;
  sc.name = "light";
  sc.camera.vfov_degrees = 45.0;
  const UnitMeshes um = add_unit_meshes(sc);
  const int floor = sc.add_mesh(make_plane(14.0, 14.0));
  const int quad = sc.add_mesh(make_plane(1.0, 1.0));

  sc.add_object("floor", floor,
                textured(Texture::Checker, 28.0, {0.72f, 0.71f, 0.68f}, {0.56f, 0.56f, 0.54f}),
                Animation::fixed(xf({0, 0, 0})));
  sc.add_object("post", um.cylinder, diffuse({0.2f, 0.2f, 0.22f}),
                Animation::fixed(segment({0, 0, 0}, {0, 1.32, 0}, 0.04)));
  sc.add_object("plate", um.box, diffuse({0.8f, 0.3f, 0.15f}),
                Animation::fixed(xf({0, 1.35, 0}, Quat::from_axis_angle({0, 1, 0}, 20 * kDeg),
                                    {0.9, 0.06, 0.6})));

  // The sweeping light: 2 m/s along x at 2.6 m, back and forth every 4 s; its shadow of the
  // plate moves ~2.2 m/s over the floor (~1 px/frame at 128x72, ~2.5 at 320x180).
  Light sweep = light(LightType::Point, {0, 2.6, 0.6}, 0.0, {30.0f, 29.0f, 27.0f});
  for (int k = 0; k <= 10; ++k)
    sweep.animation.keys.push_back({2.0 * k, xf({k % 2 == 0 ? -2.0 : 2.0, 0, 0})});
  sc.lights.push_back(sweep);

  // The blinking panel (emission only) and the light it casts on the floor in front of it:
  // on for frames 0-3 of every 8 (the half-frame phase keeps frame times off the switches).
  const Blink blink{8.0 / 30.0, 0.5, 0.5 / 30.0};
  Material panel = diffuse({0, 0, 0});
  panel.emission = {6.0f, 5.0f, 3.5f};
  panel.emission_blink = blink;
  sc.add_object("blinking panel", quad, panel,
                Animation::fixed(xf({2.4, 0.9, -2.6}, Quat::from_axis_angle({1, 0, 0}, 90 * kDeg),
                                    {1.2, 1.0, 0.8})));
  Light glow = light(LightType::Point, {2.4, 0.9, -2.3}, 0.0, {1.5f, 1.25f, 0.9f});
  glow.blink = blink;
  sc.lights.push_back(glow);

  sc.camera_motion.keys = {camera_keyframe(0.0, {0.0, 3.2, 5.5}, {0.0, 0.4, -0.5})};
  return sc;
}

// sparkle: a glossy floor whose normals tilt per 1.2 cm flake (sub-pixel glints), a glossy
// sphere with smooth bumps, a small bright light, a weak back light, a sub-pixel emitter of
// very high radiance (fireflies) and a slow sideways camera move.
Scene sparkle_scene() {
  Scene sc;
  sc.name = "sparkle";
  sc.camera.vfov_degrees = 40.0;
  const UnitMeshes um = add_unit_meshes(sc);
  const int floor = sc.add_mesh(make_plane(10.0, 10.0));

  Material flakes = diffuse({0.05f, 0.05f, 0.06f});
  flakes.specular = 0.7f;
  flakes.shininess = 1500.0f;
  flakes.bump = Bump::Flakes;
  flakes.bump_frequency = 10.0 / 0.012;  // 1.2 cm flakes on the 10 m floor
  flakes.bump_slope = 0.25;
  sc.add_object("flake floor", floor, flakes, Animation::fixed(xf({0, 0, -1})));

  Material bumpy = diffuse({0.35f, 0.08f, 0.06f});
  bumpy.specular = 0.8f;
  bumpy.shininess = 600.0f;
  bumpy.bump = Bump::Sine;
  bumpy.bump_frequency = 40.0;  // ~9 cm bumps around the sphere
  bumpy.bump_slope = 0.3;
  sc.add_object("bumpy sphere", um.sphere, bumpy,
                Animation::fixed(xf({0.9, 0.6, -1.2}, {}, Vec3d(0.6))));

  add_sphere_light(sc, um, {-0.5, 1.8, -0.6}, 0.02, {6000.0f, 5800.0f, 5200.0f});
  sc.lights.push_back(sun({0.3, 0.5, -0.8}, {0.8f, 0.8f, 0.75f}));  // behind the scene: glints
  // Firefly: 3 cm across at ~7 m (about half a pixel at 128x72), 50000 times white.
  Material firefly = diffuse({0, 0, 0});
  firefly.emission = {50000.0f, 45000.0f, 40000.0f};
  sc.add_object("firefly", um.sphere, firefly,
                Animation::fixed(xf({-1.5, 0.9, -2.5}, {}, Vec3d(0.015))));

  // 0.2 m/s sideways (~0.1 px/frame at 128x72), always looking at the same point.
  sc.camera_motion.keys = {camera_keyframe(0.0, {-1.0, 1.6, 4.0}, {0.0, 0.2, -1.0}),
                           camera_keyframe(10.0, {1.0, 1.6, 4.0}, {0.0, 0.2, -1.0})};
  return sc;
}

// moire: a 25 cm checker ground to the horizon and a wall of 12.5 cm stripes along the view,
// both seen at grazing angles from 1.2 m high, under a slow forward move.
Scene moire_scene() {
  Scene sc;
  sc.name = "moire";
  sc.camera.vfov_degrees = 40.0;
  sc.camera.far_plane = 2000.0;
  const int ground = sc.add_mesh(make_plane(600.0, 600.0));
  const int wall = sc.add_mesh(make_plane(200.0, 3.0));
  // Checker cells 600 m / 2400 = 25 cm: a cell per pixel (Nyquist) ~6 m away at 128x72,
  // ~9 m at 320x180, many cells per pixel toward the horizon.
  sc.add_object("ground", ground,
                textured(Texture::Checker, 2400.0, {0.8f, 0.78f, 0.72f}, {0.08f, 0.08f, 0.09f}),
                Animation::fixed(xf({0, 0, -290})));
  // Stripes along u = along the wall's 200 m: 1600 stripes of 12.5 cm.
  sc.add_object("striped wall", wall,
                textured(Texture::Stripes, 1600.0, {0.85f, 0.3f, 0.2f}, {0.9f, 0.9f, 0.85f}),
                Animation::fixed(
                    xf({-4.0, 1.5, -100.0}, Quat::from_matrix(rotate_axis({0, 1, 0}, -90 * kDeg) *
                                                              rotate_axis({1, 0, 0}, 90 * kDeg)))));
  sc.lights.push_back(sun({0.4, 0.6, 0.3}, {2.8f, 2.7f, 2.5f}));
  // 0.5 m/s forward with a slow turn.
  sc.camera_motion.keys = {camera_keyframe(0.0, {0.0, 1.2, 0.0}, {-2.0, 0.0, -20.0}),
                           camera_keyframe(20.0, {0.0, 1.2, -10.0}, {2.0, 0.0, -30.0})};
  return sc;
}

// One grass blade: a tapered quad strip in the local xy plane, 1 wide at y = 0 narrowing
// linearly to a point at y = 1 (normal +z, two-sided in the renderer).
Mesh make_blade(int segments = 4) {
  Mesh m;
  for (int k = 0; k <= segments; ++k) {
    const double v = double(k) / segments, half = 0.5 * (1.0 - v);
    for (double side : {-1.0, 1.0}) {
      m.positions.push_back({float(side * half), float(v), 0.0f});
      m.normals.push_back({0, 0, 1});
      m.uvs.push_back({float(0.5 + 0.5 * side), float(v)});
    }
  }
  for (int k = 0; k < segments; ++k) {
    const uint32_t a = uint32_t(2 * k);
    m.indices.insert(m.indices.end(), {a, a + 1, a + 3, a, a + 3, a + 2});
  }
  return m;
}

// blades: thin swaying grass. 120 blades 1.5 cm wide at the base (sub-pixel at 128x72,
// tapering to a point), turned roughly toward the camera and the sun behind it, each swaying
// about its base with its own amplitude, rate and phase (object motion only: the camera is
// still).
Scene blades_scene() {
  Scene sc;
  sc.name = "blades";
  sc.camera.vfov_degrees = 40.0;
  const int ground = sc.add_mesh(make_plane(20.0, 20.0));
  const int blade = sc.add_mesh(make_blade());
  sc.add_object("ground", ground,
                textured(Texture::Checker, 40.0, {0.32f, 0.26f, 0.18f}, {0.26f, 0.21f, 0.15f}),
                Animation::fixed(xf({0, 0, -4})));
  const int rows = 10, cols = 12;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const uint64_t k = uint64_t(r * cols + c);
      const Vec3d base{-1.6 + 3.2 * (c + hash01(k, 1)) / cols, 0.0,
                       -2.5 + 3.0 * (r + hash01(k, 2)) / rows};
      const double height = 0.4 + 0.4 * hash01(k, 3);
      const Quat yaw = Quat::from_axis_angle({0, 1, 0}, (hash01(k, 4) - 0.5) * 80 * kDeg);
      const double amplitude = (10.0 + 10.0 * hash01(k, 5)) * kDeg;
      const double rate = 2 * kPi * (0.8 + 0.8 * hash01(k, 6)), phase = 2 * kPi * hash01(k, 7);
      // Sway in the wind (about z: the tip moves along x), a little about x too.
      const Animation sway = Animation::procedural([=](double t) {
        const double a = amplitude * std::sin(rate * t + phase);
        const Mat4 r = Quat::from_axis_angle({0, 0, 1}, a).to_matrix() *
                       Quat::from_axis_angle({1, 0, 0}, 0.3 * a).to_matrix() * yaw.to_matrix();
        return xf(base, Quat::from_matrix(r), {0.015, height, 1.0});
      });
      Material m = diffuse({0.18f + 0.1f * float(hash01(k, 8)), 0.5f, 0.12f});
      sc.add_object("blade", blade, m, sway);
    }
  sc.lights.push_back(sun({-0.3, 0.7, 0.8}, {2.8f, 2.7f, 2.4f}));
  sc.camera_motion.keys = {camera_keyframe(0.0, {0.0, 0.5, 2.2}, {0.0, 0.3, -1.0})};
  return sc;
}

// cut: a small set seen in two shots that alternate with a hard cut every 16 frames, the
// first at frame 8: a wide view panning slowly, then a close view from the other side
// dollying in. Each shot starts again from its first pose.
constexpr int kCutFirst = 8, kCutEvery = 16;
Scene cut_scene() {
  Scene sc;
  sc.name = "cut";
  sc.camera.vfov_degrees = 45.0;
  const UnitMeshes um = add_unit_meshes(sc);
  const int ground = sc.add_mesh(make_plane(40.0, 40.0));
  sc.add_object("ground", ground,
                textured(Texture::Checker, 80.0, {0.55f, 0.55f, 0.5f}, {0.32f, 0.33f, 0.3f}),
                Animation::fixed(xf({0, 0, 0})));
  sc.add_object("box", um.box,
                textured(Texture::Checker, 4.0, {0.85f, 0.8f, 0.3f}, {0.2f, 0.2f, 0.25f}),
                Animation::fixed(xf({-1.2, 0.6, 0.2}, Quat::from_axis_angle({0, 1, 0}, 25 * kDeg),
                                    {1.2, 1.2, 1.2})));
  sc.add_object("striped sphere", um.sphere,
                textured(Texture::Stripes, 16.0, {0.9f, 0.9f, 0.9f}, {0.1f, 0.2f, 0.6f}),
                Animation::fixed(xf({1.2, 0.7, 0.4}, {}, Vec3d(0.7))));
  Material gloss = diffuse({0.6f, 0.12f, 0.1f});
  gloss.specular = 0.5f;
  gloss.shininess = 200.0f;
  sc.add_object("glossy sphere", um.sphere, gloss,
                Animation::fixed(xf({0.1, 0.45, -1.4}, {}, Vec3d(0.45))));
  sc.add_object("column", um.cylinder, diffuse({0.85f, 0.85f, 0.82f}),
                Animation::fixed(segment({-0.2, 0, -2.6}, {-0.2, 2.4, -2.6}, 0.2)));
  sc.lights.push_back(sun({0.4, 0.7, 0.5}, {3.0f, 2.8f, 2.5f}));

  // Shot k covers frames [start_k, start_{k+1}); shot 0 is the wide one and they alternate.
  // Keys at a shot's first and last frame only, so no frame sees the jump between shots.
  const double fps = sc.fps, seconds = 20.0;
  auto pose = [](int shot, double s) {  // s: seconds into the shot
    return shot % 2 == 0
               ? std::pair{Vec3d{-4.0 + 0.3 * s, 2.2, 6.0}, Vec3d{0.3 * s, 0.8, 0.0}}
               : std::pair{Vec3d{3.0 - 0.2 * s, 1.2, -3.5 + 0.25 * s}, Vec3d{0.0, 0.9, 0.0}};
  };
  int start = 0;
  for (int shot = 0; start < seconds * fps; ++shot) {
    const int end = shot == 0 ? kCutFirst : start + kCutEvery;
    for (int f : {start, end - 1}) {
      const auto [eye, target] = pose(shot, (f - start) / fps);
      sc.camera_motion.keys.push_back(camera_keyframe(f / fps, eye, target));
    }
    sc.camera_cuts.push_back(end / fps);
    start = end;
  }
  return sc;
}

// penumbra: the shading cache's scene (issue 13). A large sphere light over a checker floor
// casts wide soft shadows (rendered with soft_shadows: many shadow rays per pixel, the
// expensive term the cache amortises); a box slides through its light, a sphere bobs, a
// pillar stands still, and the camera circles slowly.
Scene penumbra_scene() {
  Scene sc;
  sc.name = "penumbra";
  sc.camera.vfov_degrees = 45.0;
  const UnitMeshes um = add_unit_meshes(sc);
  const int floor = sc.add_mesh(make_plane(16.0, 16.0));
  sc.add_object("floor", floor,
                textured(Texture::Checker, 16.0, {0.75f, 0.74f, 0.7f}, {0.5f, 0.5f, 0.48f}),
                Animation::fixed(xf({0, 0, 0})));
  sc.add_object("pillar", um.box, diffuse({0.7f, 0.68f, 0.62f}),
                Animation::fixed(xf({-1.3, 0.9, -0.8}, Quat::from_axis_angle({0, 1, 0}, 30 * kDeg),
                                    {0.35, 1.8, 0.35})));
  // Box sliding 1.5 m/s back and forth under the light (~1.5 px/frame at 320x180).
  Material box = diffuse({0.2f, 0.45f, 0.8f});
  box.specular = 0.25f;
  box.shininess = 30.0f;
  Animation slide;
  for (int k = 0; k <= 5; ++k)
    slide.keys.push_back(
        {2.0 * k, xf({k % 2 == 0 ? -1.5 : 1.5, 0.35, 0.6},
                     Quat::from_axis_angle({0, 1, 0}, 25 * kDeg * k), {0.7, 0.7, 0.7})});
  sc.add_object("sliding box", um.box, box, slide);
  Animation bob;
  for (int k = 0; k <= 10; ++k)
    bob.keys.push_back({1.0 * k, xf({1.4, k % 2 == 0 ? 0.45 : 1.2, -1.0}, {}, Vec3d(0.45))});
  sc.add_object("bobbing sphere", um.sphere, diffuse({0.8f, 0.3f, 0.2f}), bob);
  // The area light: 0.5 m radius at 3 m, about 19 degrees across from the floor.
  add_sphere_light(sc, um, {0.3, 3.0, 0.2}, 0.5, {14.0f, 13.5f, 12.5f});

  // A slow quarter circle around the set in 10 s.
  for (int k = 0; k <= 4; ++k) {
    const double a = (-20.0 + 22.5 * k) * kDeg;
    sc.camera_motion.keys.push_back(
        camera_keyframe(2.5 * k, {6.0 * std::sin(a), 3.0, 6.0 * std::cos(a)}, {0.0, 0.5, -0.2}));
  }
  return sc;
}

// focus: the depth-of-field scene (issue 12). A long lens (vertical FOV 20 degrees: 57 mm on
// a 36 mm sensor at 16:9) at f/1.4 focused at 3 m on a checker box; a striped sphere at
// 1.5 m (near field, CoC about -14 px at 640 wide), small bright emitters at 9 m and a tiled
// wall at 12 m (far field, CoC about +9.5 and +10.6 px: bokeh discs), sky above and beside the
// wall. The camera drifts slowly sideways (0.1 m/s), keeping the focus distance.
Scene focus_scene() {
  Scene sc;
  sc.name = "focus";
  sc.camera.vfov_degrees = 20.0;
  sc.camera.lens.f_number = 1.4;
  sc.camera.lens.focus_distance = 3.0;
  sc.camera.lens.focal_length_mm = 57.4;  // informative: frames carry the FOV's focal length
  const UnitMeshes um = add_unit_meshes(sc);
  const int ground = sc.add_mesh(make_plane(30.0, 30.0));
  const int wall = sc.add_mesh(make_plane(6.0, 2.0));
  sc.add_object("ground", ground,
                textured(Texture::Checker, 60.0, {0.6f, 0.6f, 0.55f}, {0.3f, 0.3f, 0.28f}),
                Animation::fixed(xf({0, 0, -8})));
  sc.add_object("wall", wall,
                textured(Texture::Checker, 12.0, {0.8f, 0.5f, 0.3f}, {0.9f, 0.88f, 0.8f}),
                Animation::fixed(xf({0, 1.0, -9}, Quat::from_axis_angle({1, 0, 0}, 90 * kDeg))));
  // In focus: a checker box 0.5 m wide whose front lies at view depth about 2.8 to 3 m.
  sc.add_object("focus box", um.box,
                textured(Texture::Checker, 6.0, {0.9f, 0.9f, 0.85f}, {0.1f, 0.15f, 0.5f}),
                Animation::fixed(xf({0.2, 0.25, -0.1}, Quat::from_axis_angle({0, 1, 0}, 20 * kDeg),
                                    {0.5, 0.5, 0.5})));
  // Near field: a striped sphere at 1.5 m, left of center.
  sc.add_object("near sphere", um.sphere,
                textured(Texture::Stripes, 10.0, {0.9f, 0.9f, 0.9f}, {0.7f, 0.1f, 0.1f}),
                Animation::fixed(xf({-0.28, 0.82, 1.5}, {}, Vec3d(0.1))));
  // Far field: small emitters (bokeh) in front of the wall.
  Material glow = diffuse({0, 0, 0});
  glow.emission = {12.0f, 10.0f, 6.0f};
  for (int k = 0; k < 4; ++k)
    sc.add_object(
        "emitter", um.sphere, glow,
        Animation::fixed(xf({-1.2 + 0.8 * k, 0.9 + 0.2 * (k % 2), -6.0}, {}, Vec3d(0.03))));
  sc.lights.push_back(sun({0.4, 0.8, 0.5}, {2.8f, 2.7f, 2.5f}));

  sc.camera_motion.keys = {camera_keyframe(0.0, {0.0, 1.0, 3.0}, {0.0, 0.75, 0.0}),
                           camera_keyframe(10.0, {1.0, 1.0, 3.0}, {1.0, 0.75, 0.0})};
  return sc;
}

// bokeh: the bladed lens's scene (issue 12's N-blade bokeh). A 57 mm lens wide open (f/1) with
// a five-blade aperture, a vertex up, focused at 2 m on a small checker box; small emitters
// far behind the focus (10 m, in front of a dark wall: CoC diameter about 12 px at 320 wide)
// and two near it (1.2 m: about -10 px), so the highlights spread into the aperture's
// pentagon, upright behind the focus plane and point-reflected in front of it (an odd blade
// count tells the two apart). The camera drifts slowly sideways (0.1 m/s).
Scene bokeh_scene() {
  Scene sc;
  sc.name = "bokeh";
  sc.camera.vfov_degrees = 20.0;
  sc.camera.lens.f_number = 1.0;
  sc.camera.lens.focus_distance = 2.0;
  sc.camera.lens.focal_length_mm = 57.4;  // informative: frames carry the FOV's focal length
  sc.camera.lens.blades = 5;
  sc.camera.lens.blade_rotation_deg = 90.0;
  const UnitMeshes um = add_unit_meshes(sc);
  const int ground = sc.add_mesh(make_plane(30.0, 30.0));
  const int wall = sc.add_mesh(make_plane(8.0, 2.2));  // the sky shows above it
  sc.add_object("ground", ground,
                textured(Texture::Checker, 60.0, {0.35f, 0.35f, 0.33f}, {0.18f, 0.18f, 0.17f}),
                Animation::fixed(xf({0, 0, -8})));
  sc.add_object("wall", wall, diffuse({0.06f, 0.06f, 0.08f}),
                Animation::fixed(xf({0, 1.1, -8}, Quat::from_axis_angle({1, 0, 0}, 90 * kDeg))));
  // In focus: a checker box 0.2 m wide at view depth about 2 m.
  sc.add_object("focus box", um.box,
                textured(Texture::Checker, 4.0, {0.9f, 0.9f, 0.85f}, {0.1f, 0.15f, 0.5f}),
                Animation::fixed(xf({0.3, 0.78, 1.0}, Quat::from_axis_angle({0, 1, 0}, 25 * kDeg),
                                    {0.2, 0.2, 0.2})));
  // Far field: a row of small emitters 10 m away in two colours.
  Material warm = diffuse({0, 0, 0}), cool = diffuse({0, 0, 0});
  warm.emission = {40.0f, 30.0f, 14.0f};
  cool.emission = {14.0f, 24.0f, 40.0f};
  for (int k = 0; k < 7; ++k)
    sc.add_object(
        "far emitter", um.sphere, k % 2 ? cool : warm,
        Animation::fixed(xf({-1.35 + 0.45 * k, 1.1 + 0.35 * (k % 3), -7.0}, {}, Vec3d(0.025))));
  // Near field: two tiny emitters at 1.2 m, left of the box.
  Material near_warm = warm, near_cool = cool;
  near_warm.emission = {90.0f, 68.0f, 32.0f};
  near_cool.emission = {32.0f, 54.0f, 90.0f};
  for (int k = 0; k < 2; ++k)
    sc.add_object("near emitter", um.sphere, k ? near_cool : near_warm,
                  Animation::fixed(xf({-0.22 + 0.14 * k, 0.97 - 0.1 * k, 1.8}, {}, Vec3d(0.002))));
  sc.lights.push_back(sun({0.4, 0.8, 0.5}, {1.6f, 1.55f, 1.45f}));
  sc.camera_motion.keys = {camera_keyframe(0.0, {0.0, 1.0, 3.0}, {0.0, 0.85, 0.0}),
                           camera_keyframe(10.0, {1.0, 1.0, 3.0}, {1.0, 0.85, 0.0})};
  return sc;
}

// room / room_light: the path tracer's scenes (issue 11). A closed room 4 m wide, 2.8 m high
// and 5.6 m deep (red left and green right walls, checker floor with a faint gloss), lit only
// by a 1 x 0.8 m quad area light just below the ceiling, so every surface but those under the
// light sees mostly indirect light. A matte tall box, a glossy blue sphere and a box sliding
// back and forth across the floor (1.2 m/s, ~1.7 px/frame at 160x90) with a slow camera dolly
// (0.06 m/s). No sky is visible: light never leaves the room.
Scene room_base(const char* name, UnitMeshes* meshes) {
  Scene sc;
  sc.name = name;
  sc.camera.vfov_degrees = 50.0;
  sc.ambient = {0.03f, 0.03f, 0.03f};  // G-buffer rendering only; path tracing ignores it
  const UnitMeshes um = add_unit_meshes(sc);
  *meshes = um;
  // Walls overlap by 2 cm at the seams so no ray slips between two of them.
  constexpr double w = 4.0, h = 2.8, z0 = -4.0, z1 = 1.6, e = 0.04;
  const double d = z1 - z0, zc = 0.5 * (z0 + z1);
  const int floor_mesh = sc.add_mesh(make_plane(w + e, d + e));
  const int side_mesh = sc.add_mesh(make_plane(h + e, d + e));  // rotated: x -> height
  const int end_mesh = sc.add_mesh(make_plane(w + e, h + e));   // rotated: z -> height
  const Quat to_side = Quat::from_axis_angle({0, 0, 1}, 90 * kDeg);
  const Quat to_end = Quat::from_axis_angle({1, 0, 0}, 90 * kDeg);
  Material floor = textured(Texture::Checker, 10.0, {0.62f, 0.55f, 0.45f}, {0.32f, 0.28f, 0.24f});
  floor.specular = 0.08f;
  floor.shininess = 40.0f;
  sc.add_object("floor", floor_mesh, floor, Animation::fixed(xf({0, 0, zc})));
  sc.add_object("ceiling", floor_mesh, diffuse({0.8f, 0.8f, 0.78f}),
                Animation::fixed(xf({0, h, zc})));
  sc.add_object("left wall", side_mesh, diffuse({0.7f, 0.16f, 0.12f}),
                Animation::fixed(xf({-0.5 * w, 0.5 * h, zc}, to_side)));
  sc.add_object("right wall", side_mesh, diffuse({0.16f, 0.55f, 0.2f}),
                Animation::fixed(xf({0.5 * w, 0.5 * h, zc}, to_side)));
  sc.add_object("back wall", end_mesh, diffuse({0.75f, 0.73f, 0.7f}),
                Animation::fixed(xf({0, 0.5 * h, z0}, to_end)));
  sc.add_object("front wall", end_mesh, diffuse({0.7f, 0.7f, 0.7f}),
                Animation::fixed(xf({0, 0.5 * h, z1}, to_end)));

  sc.add_object("tall box", um.box, diffuse({0.72f, 0.7f, 0.66f}),
                Animation::fixed(xf({-1.0, 0.8, -2.9}, Quat::from_axis_angle({0, 1, 0}, 20 * kDeg),
                                    {0.7, 1.6, 0.7})));
  Material gloss = diffuse({0.08f, 0.12f, 0.45f});
  gloss.specular = 0.6f;
  gloss.shininess = 300.0f;
  sc.add_object("glossy sphere", um.sphere, gloss,
                Animation::fixed(xf({0.95, 0.5, -2.6}, {}, Vec3d(0.5))));
  Material slider = diffuse({0.85f, 0.55f, 0.12f});
  slider.specular = 0.15f;
  slider.shininess = 30.0f;
  Animation slide;
  for (int k = 0; k <= 5; ++k)
    slide.keys.push_back(
        {2.0 * k, xf({k % 2 == 0 ? -1.2 : 1.2, 0.25, -1.1},
                     Quat::from_axis_angle({0, 1, 0}, 30 * kDeg * k), {0.5, 0.5, 0.5})});
  sc.add_object("sliding box", um.box, slider, slide);

  // The ceiling light: a quad 1 cm below the ceiling facing down (cross(edge_u, edge_v) =
  // -y), and the emissive mesh the camera and glossy reflections see, on the same rectangle.
  const Vec3d light_center{0.0, h - 0.01, -2.9};
  const Vec3f radiance{14.0f, 13.0f, 11.5f};
  Light ceiling = light(LightType::Quad, light_center, 0.0, radiance);
  ceiling.edge_u = {1.0, 0.0, 0.0};
  ceiling.edge_v = {0.0, 0.0, 0.8};
  sc.lights.push_back(ceiling);
  Material panel = diffuse({0, 0, 0});
  panel.emission = radiance;
  sc.add_object("ceiling light", sc.add_mesh(make_plane(1.0, 0.8)), panel,
                Animation::fixed(xf(light_center)));

  sc.camera_motion.keys = {camera_keyframe(0.0, {0.0, 1.3, 1.2}, {0.0, 1.1, -4.0}),
                           camera_keyframe(10.0, {0.0, 1.3, 0.6}, {0.0, 1.1, -4.0})};
  return sc;
}

Scene room_scene() {
  UnitMeshes um;
  return room_base("room", &um);
}

// room_light: the room plus a warm sphere lamp high in the back left corner (above the tall
// box, about as powerful as the ceiling light) that switches on at frame 6 and off at frame 22
// (a 32-frame period, switches half a frame away from frame times): the lighting changes with
// no motion, where temporal filters lag.
Scene room_light_scene() {
  UnitMeshes um;
  Scene sc = room_base("room_light", &um);
  const Blink blink{32.0 / 30.0, 0.5, 26.5 / 30.0};
  const Vec3d center{-1.4, 2.1, -3.5};
  const double radius = 0.18;
  const Vec3f radiance{30.0f, 22.0f, 13.0f};
  Light lamp = light(LightType::Sphere, center, radius, radiance);
  lamp.blink = blink;
  sc.lights.push_back(lamp);
  Material m = diffuse({0, 0, 0});
  m.emission = radiance;
  m.emission_blink = blink;
  sc.add_object("lamp", um.sphere, m, Animation::fixed(xf(center, {}, Vec3d(radius))));
  return sc;
}

// A registry entry's make(): the scene, frozen at t = 0 when static, checked.
template <Scene (*Build)()>
Scene finish(bool is_static) {
  Scene sc = Build();
  sc.is_static = is_static;
  if (is_static) sc.name += "-static";
  sc.validate();
  return sc;
}

}  // namespace

const std::vector<SceneInfo>& builtin_scenes() {
  // Immutable, so one shared copy is not state. The descriptions are the demo report's. The
  // default TAA preset was tuned on thin, motion and orbit (src/taa/presets.cpp) and its
  // history confidence designed on those and on light, blades, room and room_light (their
  // failures read pixel by pixel): those are the tuning set. sparkle, moire, cut, penumbra and
  // focus were only ever scored, never studied: the validation set. The demo runs both
  // (room and room_light only with --scenes: they are the path tracer's scenes).
  static const std::vector<SceneInfo> kScenes{
      {"thin",
       "Slow camera pan over sub-pixel poles and wires, a point-sampled high-frequency ground "
       "texture and a glossy sphere under a small bright light: geometric, shading and "
       "specular aliasing.",
       finish<thin_scene>, true, TaaSplit::Tuning},
      {"motion",
       "A box crossing the foreground fast in front of a textured wall, a rotating object and "
       "a camera dolly: disocclusion and ghosting.",
       finish<motion_scene>, true, TaaSplit::Tuning},
      {"orbit",
       "The camera orbits a group of objects under a gradient sky: every pixel moves, the sky "
       "by rotation only.",
       finish<orbit_scene>, true, TaaSplit::Tuning},
      {"light",
       "A light sweeps a sharp shadow over a still floor and an emissive panel blinks (4 frames "
       "on, 4 off); camera and geometry are still, so motion is zero and only rectification "
       "can react to the lighting change.",
       finish<light_scene>, true, TaaSplit::Tuning},
      {"sparkle",
       "A glossy floor of sub-pixel normal-mapped flakes and a bumpy glossy sphere under a "
       "small bright light, plus a sub-pixel emitter of very high radiance, under a slow "
       "camera move: specular sparkle and firefly flicker.",
       finish<sparkle_scene>, true, TaaSplit::Validation},
      {"moire",
       "A fine checker ground to the horizon and a finely striped wall seen at grazing angles "
       "under a slow forward move: texture frequencies far above Nyquist (moire).",
       finish<moire_scene>, true, TaaSplit::Validation},
      {"blades",
       "Thin grass blades, sub-pixel at the base and tapering to a point, each swaying with "
       "its own motion in front of a still camera: thin geometry with object motion.",
       finish<blades_scene>, true, TaaSplit::Tuning},
      {"cut",
       "Two views of one small set that alternate with a hard camera cut every 16 frames, the "
       "first at frame 8: history must be dropped on the first frame of each shot.",
       finish<cut_scene>, true, TaaSplit::Validation},
      {"penumbra",
       "A large sphere light casts wide soft shadows over a checker floor while a box slides "
       "and a sphere bobs through them under a slowly circling camera: the scene of the "
       "reprojection shading cache (render --soft-shadows, many light samples).",
       finish<penumbra_scene>, true, TaaSplit::Validation},
      {"focus",
       "A long lens at f/1.4 focused at 3 m on a checker box, with a striped sphere in the near "
       "field and a tiled wall and small bright emitters in the far field, under a slow "
       "sideways drift: the depth-of-field scene (render --reference-dof).",
       finish<focus_scene>, true, TaaSplit::Validation},
      {"bokeh",
       "A wide-open lens (f/1) with a five-blade aperture focused at 2 m on a checker box, "
       "with small bright emitters far behind the focus and two in front of it: highlights "
       "blur into the aperture's pentagon, upright behind the focus plane and point-reflected "
       "in front (render --reference-dof; the demo's bladed-lens DoF section).",
       finish<bokeh_scene>, false, TaaSplit::None},
      {"room",
       "A closed room lit only by a quad area light in the ceiling (mostly indirect light), "
       "with a matte box, a glossy sphere and a box sliding across a faintly glossy checker "
       "floor under a slow camera dolly: the path tracer's scene (render --path-trace), "
       "noisy input for SVGF.",
       finish<room_scene>, false, TaaSplit::Tuning},
      {"room_light",
       "The room with a bright sphere lamp that switches on at frame 6 and off at frame 22: "
       "lighting changes without motion (temporal lag of denoisers; render --path-trace).",
       finish<room_light_scene>, false, TaaSplit::Tuning},
  };
  return kScenes;
}

std::vector<std::string> builtin_scene_names() {
  std::vector<std::string> names;
  for (const auto& s : builtin_scenes()) names.emplace_back(s.name);
  return names;
}

std::vector<std::string> default_demo_scene_names() {
  std::vector<std::string> names;
  for (const auto& s : builtin_scenes())
    if (s.in_default_demo) names.emplace_back(s.name);
  return names;
}

TaaSplit taa_split_of(const std::string& name) {
  for (const auto& s : builtin_scenes())
    if (name == s.name) return s.taa_split;
  return TaaSplit::None;
}

Scene make_builtin_scene(const std::string& name, bool is_static) {
  for (const auto& s : builtin_scenes())
    if (name == s.name) return s.make(is_static);
  std::string valid;
  for (const auto& n : builtin_scene_names()) {
    if (!valid.empty()) valid += ", ";
    valid += n;
  }
  throw SettingsError("unknown scene '" + name + "' (expected one of: " + valid + ")");
}

}  // namespace afterimage::render
