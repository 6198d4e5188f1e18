// Scene description for the built-in ray tracer: instanced triangle meshes, procedural
// materials, analytic lights, keyframed transforms (DESIGN.md §2 `render/`).
//
// Everything here is plain data plus small pure functions; Embree is only used by the
// renderer (accel.cpp), so scenes can be built and inspected without it.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "camera/camera.h"
#include "core/math.h"

namespace afterimage::render {

// Indexed triangle mesh in its local space. normals / uvs are per vertex (same count as
// positions); indices hold 3 vertex indices per triangle, counter-clockwise = front.
struct Mesh {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;
  std::vector<Vec2f> uvs;
  std::vector<uint32_t> indices;
  size_t triangle_count() const { return indices.size() / 3; }
};

// Mesh builders. UVs span [0, 1] over each surface, so a material's texture frequency is
// "cells per surface"; normals are smooth where the surface is (sphere, cylinder side).
Mesh make_box(Vec3d half_extent);  // centered at the origin, flat-shaded faces
// UV sphere: `segments` around the y axis, `rings` from pole to pole.
Mesh make_sphere(double radius, int segments = 48, int rings = 24);
// Quad in the local xz plane (normal +y), size_x by size_z, split into nx by nz cells.
Mesh make_plane(double size_x, double size_z, int nx = 1, int nz = 1);
// Open cylinder along the local y axis from y = 0 to y = height (poles and, rotated, wires).
Mesh make_cylinder(double radius, double height, int segments = 8);

// Procedural albedo, evaluated once at the hit point's UV: point sampled on purpose, so
// high frequencies alias exactly as an unfiltered texture fetch in a rasteriser would.
enum class Texture {
  None,     // albedo only
  Checker,  // alternates albedo / albedo2 over frequency x frequency cells
  Stripes,  // alternates along u, `frequency` stripe pairs
  Sine,     // smooth: lerp(albedo, albedo2, 0.5 + 0.5 sin(2 pi f u) sin(2 pi f v)); for tests
};

// Procedural normal perturbation (bump mapping), evaluated at the hit point's UV like the
// albedo and just as unfiltered: sub-pixel bumps make highlights sparkle under jitter.
enum class Bump {
  None,    // the interpolated normal
  Sine,    // smooth bumps: the slope of sin(2 pi f u) sin(2 pi f v), scaled to bump_slope
  Flakes,  // one random tilt per f x f cell (|slope| <= bump_slope): glitter, metal flakes
};

// A periodic on/off schedule (time-varying emission, blinking lights). period <= 0: always
// on; else on while fract((t + phase) / period) < on_fraction. Pick `phase` so that frame
// times do not fall on a switch (e.g. half a frame), so rounding cannot decide a frame.
struct Blink {
  double period = 0.0;  // seconds
  double on_fraction = 0.5;
  double phase = 0.0;  // seconds
  bool on(double t) const;
};

struct Material {
  Vec3f albedo{0.7f, 0.7f, 0.7f};  // linear RGB diffuse reflectance
  Texture texture = Texture::None;
  Vec3f albedo2{0.1f, 0.1f, 0.1f};  // second texture color
  double frequency = 8.0;           // texture cells per unit UV
  // Normalised Blinn-Phong lobe ks (s + 8) / (8 pi) (n.h)^s added to the Lambert term;
  // ks = 0 disables it. A high exponent gives the small highlights that flicker under jitter.
  float specular = 0.0f;
  float shininess = 64.0f;
  Vec3f emission{0.0f, 0.0f, 0.0f};  // radiance emitted toward the camera (lights' meshes)
  Blink emission_blink;              // emission is there only while emission_blink.on(t)
  // Shading-normal perturbation in the surface's tangent frame (u, v directions): the normal
  // tilts by the slope vector s as n' = normalize(n - s.u T - s.v B); bump_slope is |s|max,
  // independent of the surface's UV scale. The G-buffer normal is the perturbed one.
  Bump bump = Bump::None;
  double bump_frequency = 64.0;  // bump cells per unit UV
  double bump_slope = 0.3;
};

// Albedo at a surface UV (pure: used by the renderer and by tests).
Vec3f material_albedo(const Material& m, Vec2d uv);

// Translation + rotation + scale; matrix() = T * R * S (column vectors).
struct Transform {
  Vec3d translation{0, 0, 0};
  Quat rotation{};
  Vec3d scale{1, 1, 1};
  Mat4 matrix() const;
};

struct Keyframe {
  double time = 0.0;  // seconds
  Transform transform;
};

// Keyframed transform: linear translation / scale and slerped rotation between the two
// keyframes around t, clamped to the first / last keyframe outside their range.
// Keyframes must be sorted by time; an empty animation is the identity. A procedural
// animation (`function` set: swaying, oscillating) is evaluated exactly at every time
// instead, with no keys needed; it must be a pure function of t.
struct Animation {
  std::vector<Keyframe> keys;
  std::function<Transform(double t)> function;  // if set, replaces the keys
  Transform at(double t) const;
  Mat4 matrix(double t) const { return at(t).matrix(); }
  // Neither keys nor a function: the identity at every time.
  bool is_identity() const { return keys.empty() && !function; }
  static Animation fixed(const Transform& t) { return Animation{{Keyframe{0.0, t}}, {}}; }
  static Animation procedural(std::function<Transform(double t)> f) { return {{}, std::move(f)}; }
};

// An instance of a mesh. Object id = index in Scene::objects + 1 (0 is the background).
struct Object {
  std::string name;
  int mesh = 0;  // index into Scene::meshes
  Material material;
  Animation animation;  // object -> world
};

enum class LightType { Directional, Point, Sphere, Quad };

struct Light {
  LightType type = LightType::Point;
  // Directional: unit direction *toward* the light; point / sphere: world position; quad:
  // world position of its center.
  Vec3d position{0, 1, 0};
  double radius = 0.0;  // sphere lights only
  // Quad lights only: the parallelogram's edges. Corners are position +- edge_u / 2 +-
  // edge_v / 2; it emits on one side, toward cross(edge_u, edge_v).
  Vec3d edge_u{0, 0, 0}, edge_v{0, 0, 0};
  // Directional: irradiance on a perpendicular surface; point: intensity (irradiance at
  // 1 unit is color / d^2); sphere / quad: radiance of the emitting surface.
  Vec3f color{1, 1, 1};
  // Light -> world (lights that move without any geometry moving): point / sphere lights
  // sit at animation(t) applied to `position`, directional ones turn with its rotation, quad
  // edges turn and scale with it. Identity by default. A sphere or quad light's visible mesh
  // is a separate object.
  Animation animation;
  Blink blink;  // the light is off (contributes nothing) while !blink.on(t)
};

// The light as it is at time t: position / direction moved by its animation, color zero
// while it is off. Lights without animation or blink are returned unchanged (bit for bit).
Light light_at(const Light& light, double t);

// Gradient sky seen by rays that miss all geometry (pure function of the direction).
struct Sky {
  Vec3f zenith{0.25f, 0.45f, 0.9f};
  Vec3f horizon{0.85f, 0.9f, 1.0f};
  Vec3f ground{0.3f, 0.27f, 0.25f};
  // Relative amplitude of a 3-lobe azimuthal variation, so that camera rotation visibly moves
  // the sky (a purely vertical gradient would hide rotation about the vertical axis).
  float azimuth_variation = 0.15f;
};
Vec3f sky_radiance(const Sky& sky, Vec3d direction);

struct Scene {
  std::string name;
  std::vector<Mesh> meshes;
  std::vector<Object> objects;
  std::vector<Light> lights;
  Sky sky;
  // Constant ambient irradiance / pi times albedo (no occlusion): a cheap stand-in for sky
  // light so that shadows are not black.
  Vec3f ambient{0.08f, 0.09f, 0.1f};
  Camera camera;            // intrinsics (fov, near, far); its `view` is ignored
  Animation camera_motion;  // camera -> world (rigid: no scale)
  double fps = 30.0;        // frame k is at time k / fps
  bool is_static = false;   // every animation evaluated at t = 0 (only jitter changes)
  // Camera cuts: times (s, strictly increasing, > 0) at which a new shot starts (the camera
  // jumps; camera_motion holds the poses, e.g. a key just before and one at the cut). The
  // first frame at or after a cut is a cut frame (Frame::camera_cut).
  std::vector<double> camera_cuts;

  // Time at which frame k's scene is evaluated (0 for static scenes).
  double eval_time(int frame) const { return is_static ? 0.0 : frame / fps; }
  // Frame k (> 0) is the first frame of a new shot: a cut lies in (time of k - 1, time of k].
  // Never for frame 0 (it has no previous frame anyway) nor in static scenes.
  bool camera_cut_at(int frame) const;
  // World -> view matrix of the camera at time t.
  Mat4 view_at(double t) const;
  // Appends a mesh and returns its index.
  int add_mesh(Mesh m);
  // Appends an object (returns its id = index + 1).
  uint32_t add_object(const std::string& name, int mesh, const Material& mat,
                      const Animation& anim);
  // Checks indices, normals and keyframe order; throws SettingsError naming the problem.
  void validate() const;
};

// Camera keyframe from eye / target (camera -> world transform of look_at).
Keyframe camera_keyframe(double time, Vec3d eye, Vec3d target, Vec3d up = {0, 1, 0});

}  // namespace afterimage::render
