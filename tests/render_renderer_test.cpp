// Tests of render/ renderers: G-buffer conventions (DESIGN.md §3), motion vectors,
// reference convergence and determinism. Sizes are small and odd (tails, borders).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "camera/camera.h"
#include "core/color.h"
#include "core/error.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "test_util.h"

namespace afterimage::render {
namespace {

RenderSettings small_settings(int w, int h, const char* jitter = "halton16") {
  RenderSettings rs;
  rs.width = w;
  rs.height = h;
  rs.jitter = parse_jitter(jitter);
  return rs;
}

// View-space point seen at pixel-space position `s` (x right, y down) at linear depth d,
// from the *unjittered* projection alone: unproject the far-plane point at the sample's NDC
// and scale it to z = -d. Written independently of the renderer's ray generation.
Vec3d view_point_from_depth(const Mat4& projection, Vec2d s, double d, int w, int h) {
  const double nx = 2.0 * s.x / w - 1.0, ny = 1.0 - 2.0 * s.y / h;
  const Vec4d q = projection.inverse() * Vec4d(nx, ny, 1.0, 1.0);
  const Vec3d far = q.xyz() / q.w;
  return far * (d / -far.z);
}

Vec2d to_pixel(const Mat4& vp, Vec4d p, int w, int h) {
  const Vec4d c = vp * p;
  return {(c.x / c.w + 1.0) * 0.5 * w, (1.0 - c.y / c.w) * 0.5 * h};
}

// Every built-in scene (animated and static) renders with surfaces and sky (the closed rooms:
// no sky), finite values, positive depth and unit normals; frame metadata follows the
// conventions.
TEST(RenderScenes, BuiltinsRenderSurfacesAndSky) {
  for (const std::string& name : builtin_scene_names()) {
    for (bool is_static : {false, true}) {
      const Scene sc = make_builtin_scene(name, is_static);
      const RenderSettings rs = small_settings(97, 55);
      const Frame f = render_gbuffer(sc, 7, rs, Exec{});
      ASSERT_NO_THROW(validate_frame(f, sc.name));
      EXPECT_EQ(f.index, 7);
      EXPECT_DOUBLE_EQ(f.time, 7.0 / 30.0);
      EXPECT_EQ(f.jitter, rs.jitter.at(7));
      EXPECT_EQ(f.projection, sc.camera.projection(97, 55));
      int bg = 0, fg = 0;
      for (int y = 0; y < f.height; ++y)
        for (int x = 0; x < f.width; ++x) {
          const Vec3f c = f.color_at(x, y);
          ASSERT_TRUE(std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z));
          ASSERT_TRUE(std::isfinite(f.motion.at(x, y, 0)) && std::isfinite(f.motion.at(x, y, 1)));
          ASSERT_GE(std::min({c.x, c.y, c.z}), 0.0f);
          if (f.id.at(x, y, 0) == 0) {
            ++bg;
            ASSERT_EQ(f.depth.at(x, y, 0), kBackgroundDepth);
            ASSERT_EQ(f.normal.at(x, y, 0), 0.0f);
          } else {
            ++fg;
            ASSERT_GT(f.depth.at(x, y, 0), 0.0f);
            ASSERT_LT(f.depth.at(x, y, 0), 1000.0f);
            const Vec3d n{f.normal.at(x, y, 0), f.normal.at(x, y, 1), f.normal.at(x, y, 2)};
            ASSERT_NEAR(length(n), 1.0, 1e-4);
          }
        }
      if (name != "room" && name != "room_light") {  // closed rooms have no background
        EXPECT_GT(bg, 0) << sc.name;
      }
      EXPECT_GT(fg, 0) << sc.name;
    }
  }
}

// The sample for pixel (i, j) is taken at (i + 0.5 + jitter.x, j + 0.5 + jitter.y): the
// ground plane (y = 0) depth at that position, computed analytically from the frame's
// matrices, matches the rendered depth; the unjittered position does not.
TEST(RenderGBuffer, SamplesAtJitteredPosition) {
  const Scene sc = make_builtin_scene("orbit", false);
  const RenderSettings rs = small_settings(81, 47);
  const Frame f = render_gbuffer(sc, 3, rs, Exec{});
  ASSERT_GT(std::hypot(f.jitter.x, f.jitter.y), 0.1);
  const Mat4 cam_to_world = f.view.inverse();
  const Vec3d eye = cam_to_world.transform_point({0, 0, 0});
  auto ground_depth = [&](Vec2d s) {
    const Vec3d pv = view_point_from_depth(f.projection, s, 1.0, f.width, f.height);
    const Vec3d dir = cam_to_world.transform_dir(pv);  // view depth 1 along this ray
    return -eye.y / dir.y;                             // plane y = 0 at depth t * 1
  };
  double err_jittered = 0, err_center = 0;
  int n = 0;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      if (f.id.at(x, y, 0) != 1) continue;  // the ground is object 1
      const double d = f.depth.at(x, y, 0);
      const double dj = ground_depth({x + 0.5 + f.jitter.x, y + 0.5 + f.jitter.y});
      const double dc = ground_depth({x + 0.5, y + 0.5});
      err_jittered = std::max(err_jittered, std::abs(d - dj) / dj);
      err_center = std::max(err_center, std::abs(d - dc) / dc);
      ++n;
    }
  ASSERT_GT(n, 100);
  std::printf("ground depth max relative error: jittered %.3g, pixel center %.3g\n", err_jittered,
              err_center);
  EXPECT_LT(err_jittered, 1e-5);
  EXPECT_GT(err_center, 1e-3);
}

// (a) Camera-only motion: the renderer's motion equals the seed-003 reconstruction
// (depth + inverse current projection at the jittered sample -> world -> previous and
// current *unjittered* view-projections) within 0.01 px on every pixel.
TEST(RenderMotion, CameraMotionMatchesDepthReprojection) {
  const Scene sc = make_builtin_scene("orbit", false);
  const RenderSettings rs = small_settings(161, 91);
  const Frame prev = render_gbuffer(sc, 4, rs, Exec{});
  const Frame cur = render_gbuffer(sc, 5, rs, Exec{});
  const int w = cur.width, h = cur.height;
  const Mat4 vp = cur.projection * cur.view, vp_prev = prev.projection * prev.view;
  const Mat4 view_to_world = cur.view.inverse();
  double max_err = 0, max_err_bg = 0, max_motion = 0;
  int n = 0, n_bg = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Vec2d s{x + 0.5 + cur.jitter.x, y + 0.5 + cur.jitter.y};
      const Vec2d m{cur.motion.at(x, y, 0), cur.motion.at(x, y, 1)};
      Vec2d expect;
      if (cur.id.at(x, y, 0) != 0) {
        const Vec3d pv = view_point_from_depth(cur.projection, s, cur.depth.at(x, y, 0), w, h);
        const Vec4d pw(view_to_world.transform_point(pv), 1.0);
        expect = to_pixel(vp_prev, pw, w, h) - to_pixel(vp, pw, w, h);
        max_err = std::max(max_err, std::hypot(m.x - expect.x, m.y - expect.y));
        ++n;
      } else {  // a direction at infinity: w = 0, rotation only
        const Vec3d pv = view_point_from_depth(cur.projection, s, 1.0, w, h);
        const Vec4d dw(view_to_world.transform_dir(pv), 0.0);
        expect = to_pixel(vp_prev, dw, w, h) - to_pixel(vp, dw, w, h);
        max_err_bg = std::max(max_err_bg, std::hypot(m.x - expect.x, m.y - expect.y));
        ++n_bg;
      }
      max_motion = std::max(max_motion, std::hypot(expect.x, expect.y));
    }
  std::printf(
      "camera motion: max |motion| %.3f px; max error %.2e px (%d surface px), "
      "%.2e px (%d sky px)\n",
      max_motion, max_err, n, max_err_bg, n_bg);
  ASSERT_GT(n, 1000);
  ASSERT_GT(n_bg, 100);
  EXPECT_GT(max_motion, 1.0);  // the camera really moves
  EXPECT_LT(max_err, 0.01);
  EXPECT_LT(max_err_bg, 0.01);
}

// A diffuse sphere with a smooth texture, lit by ambient light only (so its color is a pure
// function of the surface point), translating, rotating and growing in front of a moving
// camera.
Scene moving_sphere_scene() {
  Scene sc;
  sc.name = "moving sphere";
  sc.lights.clear();
  sc.ambient = {1.0f, 1.0f, 1.0f};
  const int sphere = sc.add_mesh(make_sphere(1.0, 96, 48));
  Material m;
  m.texture = Texture::Sine;
  m.frequency = 3.0;
  m.albedo = {0.9f, 0.6f, 0.2f};
  m.albedo2 = {0.1f, 0.3f, 0.8f};
  Animation a;
  const Vec3d axis = normalize(Vec3d{0.3, 1.0, 0.4});
  a.keys = {{0.0, {{-0.4, 0.0, 0.0}, Quat::from_axis_angle(axis, 0.0), {1, 1, 1}}},
            {0.1, {{0.35, 0.15, -0.3}, Quat::from_axis_angle(axis, 0.5), {1.1, 1.1, 1.1}}}};
  sc.add_object("sphere", sphere, m, a);
  sc.camera_motion.keys = {camera_keyframe(0.0, {0, 0.3, 5}, {0, 0, 0}),
                           camera_keyframe(0.1, {0.3, 0.5, 4.8}, {0, 0, 0})};
  return sc;
}

// (b) Object motion: warping the previous frame by the motion field (bilinear at p + motion)
// reproduces the current frame on pixels of the object visible in both frames.
TEST(RenderMotion, ObjectMotionWarpsPreviousFrameOntoCurrent) {
  const Scene sc = moving_sphere_scene();
  const RenderSettings rs = small_settings(161, 121, "none");
  const Frame prev = render_gbuffer(sc, 1, rs, Exec{});
  const Frame cur = render_gbuffer(sc, 2, rs, Exec{});
  const int w = cur.width, h = cur.height;
  std::vector<double> err, err_static;
  double max_motion = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (cur.id.at(x, y, 0) != 1) continue;
      const Vec2d m{cur.motion.at(x, y, 0), cur.motion.at(x, y, 1)};
      // History for pixel center p is read at p + motion; bilinear between pixel centers.
      auto warp = [&](Vec2d mv, Vec3d* out) {
        const double qx = x + 0.5 + mv.x - 0.5, qy = y + 0.5 + mv.y - 0.5;
        const int x0 = int(std::floor(qx)), y0 = int(std::floor(qy));
        if (x0 < 0 || y0 < 0 || x0 + 1 >= w || y0 + 1 >= h) return false;
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx)
            if (prev.id.at(x0 + dx, y0 + dy, 0) != 1) return false;  // visible in both
        const double fx = qx - x0, fy = qy - y0;
        Vec3d c(0.0);
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx)
            c += to_double(prev.color_at(x0 + dx, y0 + dy)) *
                 ((dx ? fx : 1 - fx) * (dy ? fy : 1 - fy));
        *out = c;
        return true;
      };
      const Vec3d c = to_double(cur.color_at(x, y));
      Vec3d wc, ws;
      if (warp(m, &wc)) {
        const Vec3d d = wc - c;
        err.push_back(std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)}));
        max_motion = std::max(max_motion, std::hypot(m.x, m.y));
      }
      if (warp({0, 0}, &ws)) {
        const Vec3d d = ws - c;
        err_static.push_back(std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)}));
      }
    }
  ASSERT_GT(err.size(), 1000u);
  ASSERT_GT(err_static.size(), 100u);
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const double med = median(err), med_static = median(err_static);
  std::printf(
      "object motion: max |motion| %.2f px; median |warped - current| %.2e "
      "(without motion %.2e) over %zu px\n",
      max_motion, med, med_static, err.size());
  EXPECT_GT(max_motion, 5.0);
  // Colors are in [0.1, 0.9]; the residual is bilinear interpolation of a smooth texture.
  EXPECT_LT(med, 2e-3);
  EXPECT_GT(med_static, 20 * med);
}

// Frame 0's previous frame is itself: zero motion even in an animated scene.
TEST(RenderMotion, FrameZeroHasNoMotion) {
  const Scene sc = make_builtin_scene("motion", false);
  const Frame f = render_gbuffer(sc, 0, small_settings(63, 35), Exec{});
  for (float v : f.motion.data()) ASSERT_EQ(v, 0.0f);
}

// Static variant: only the jitter changes between frames; motion is exactly zero.
TEST(RenderStatic, OnlyJitterChanges) {
  const Scene sc = make_builtin_scene("motion", true);
  const RenderSettings rs = small_settings(71, 41);
  const Frame a = render_gbuffer(sc, 2, rs, Exec{});
  const Frame b = render_gbuffer(sc, 3, rs, Exec{});
  EXPECT_EQ(a.view, b.view);
  EXPECT_EQ(a.projection, b.projection);
  EXPECT_NE(a.jitter, b.jitter);
  for (float v : b.motion.data()) ASSERT_EQ(v, 0.0f);
  EXPECT_NE(a.color, b.color);  // different sample positions
  // References of a static scene do not flicker: same samples every frame.
  EXPECT_EQ(render_reference(sc, 2, 4, rs, Exec{}).color,
            render_reference(sc, 5, 4, rs, Exec{}).color);
  // The animated scene does move at the same frames.
  const Scene anim = make_builtin_scene("motion", false);
  EXPECT_NE(render_gbuffer(anim, 2, rs, Exec{}).view, render_gbuffer(anim, 3, rs, Exec{}).view);
}

// A still camera over a ground plane with an emissive quad standing on it: the test bed of
// time-varying lighting, bump mapping and cuts.
Scene lighting_test_scene() {
  Scene sc;
  sc.name = "lighting test";
  const int plane = sc.add_mesh(make_plane(8.0, 8.0));
  sc.add_object("ground", plane, Material{}, Animation::fixed({}));
  Material panel;
  panel.albedo = {0, 0, 0};
  panel.emission = {5, 5, 5};
  sc.add_object(
      "panel", plane, panel,
      Animation::fixed({{0, 1, -2}, Quat::from_axis_angle({1, 0, 0}, kPi / 2), {0.25, 1, 0.25}}));
  Light l;
  l.type = LightType::Point;
  l.position = {0, 2, 0};
  l.color = {4, 4, 4};
  sc.lights.push_back(l);
  sc.camera_motion.keys = {camera_keyframe(0.0, {0, 2, 3}, {0, 0, -1})};
  return sc;
}

// A light that moves and an emission that blinks change the color while nothing moves:
// motion stays exactly zero. Each alone is checked against the unanimated scene.
TEST(RenderLighting, MovingLightAndBlinkingEmissionChangeColorNotMotion) {
  const RenderSettings rs = small_settings(61, 37, "none");
  const Scene base = lighting_test_scene();
  Scene moving = base;
  moving.lights[0].animation.keys = {{0.0, {}}, {1.0, {{3, 0, 0}, Quat{}, {1, 1, 1}}}};
  Scene blinking = base;
  blinking.objects[1].material.emission_blink = {2.0 / 30.0, 0.5, 0.5 / 30.0};  // 1 on, 1 off

  const Frame b0 = render_gbuffer(base, 0, rs, Exec{}), b1 = render_gbuffer(base, 1, rs, Exec{});
  EXPECT_EQ(b0.color, b1.color);
  const Frame m0 = render_gbuffer(moving, 0, rs, Exec{}),
              m1 = render_gbuffer(moving, 1, rs, Exec{});
  EXPECT_EQ(m0.color, b0.color);  // the light starts where the still one is
  EXPECT_NE(m1.color, b1.color);
  const Frame k0 = render_gbuffer(blinking, 0, rs, Exec{}),
              k1 = render_gbuffer(blinking, 1, rs, Exec{});
  int panel = 0;
  for (int y = 0; y < rs.height; ++y)
    for (int x = 0; x < rs.width; ++x) {
      ASSERT_EQ(m1.motion.at(x, y, 0), 0.0f);
      ASSERT_EQ(k1.motion.at(x, y, 1), 0.0f);
      if (k1.id.at(x, y, 0) != 2) continue;
      ++panel;
      EXPECT_EQ(k0.color.at(x, y, 0), 5.0f);  // on: the emission (black albedo)
      EXPECT_EQ(k1.color.at(x, y, 0), 0.0f);  // off
    }
  EXPECT_GT(panel, 20);
  EXPECT_EQ(m1.id, b1.id);
  EXPECT_EQ(m1.depth, b1.depth);
}

// Bump mapping perturbs the shading (and G-buffer) normal, keeps it unit length, and changes
// nothing else of the geometry.
TEST(RenderBump, PerturbsShadingNormalsOnly) {
  const RenderSettings rs = small_settings(59, 33, "none");
  Scene sc = lighting_test_scene();
  const Frame flat = render_gbuffer(sc, 0, rs, Exec{});
  sc.objects[0].material.bump = Bump::Sine;
  sc.objects[0].material.bump_frequency = 6.0;
  sc.objects[0].material.bump_slope = 0.4;
  const Frame bumped = render_gbuffer(sc, 0, rs, Exec{});
  EXPECT_EQ(flat.depth, bumped.depth);
  EXPECT_EQ(flat.id, bumped.id);
  double max_tilt = 0;
  for (int y = 0; y < rs.height; ++y)
    for (int x = 0; x < rs.width; ++x) {
      if (bumped.id.at(x, y, 0) != 1) continue;
      const Vec3d n{bumped.normal.at(x, y, 0), bumped.normal.at(x, y, 1),
                    bumped.normal.at(x, y, 2)};
      ASSERT_NEAR(length(n), 1.0, 1e-5);
      ASSERT_EQ(flat.normal.at(x, y, 1), 1.0f);
      max_tilt = std::max(max_tilt, std::acos(std::min(1.0, n.y)));
    }
  // The largest slope 0.4 is a tilt of atan(0.4) = 21.8 degrees.
  EXPECT_GT(max_tilt, 0.8 * std::atan(0.4));
  EXPECT_LT(max_tilt, std::atan(0.4) + 1e-4);
  EXPECT_NE(flat.color, bumped.color);
}

// The first frame after a camera cut is flagged, and its motion refers to itself (zero),
// as frame 0's does; the frames around it are not flagged and keep their motion.
TEST(RenderCut, CutFrameIsFlaggedAndHasNoMotion) {
  Scene sc = lighting_test_scene();
  sc.camera_motion.keys = {camera_keyframe(0.0, {0, 2, 3}, {0, 0, -1}),
                           camera_keyframe(2.9 / 30, {0.2, 2, 3}, {0, 0, -1}),
                           camera_keyframe(3.0 / 30, {2, 1, 2}, {0, 0, -1}),
                           camera_keyframe(1.0, {3, 1, 2}, {0, 0, -1})};
  sc.camera_cuts = {3.0 / 30};
  const RenderSettings rs = small_settings(41, 23);
  for (int k = 0; k < 5; ++k) {
    const Frame f = render_gbuffer(sc, k, rs, Exec{});
    EXPECT_EQ(f.camera_cut, k == 3) << k;
    float max_motion = 0;
    for (float v : f.motion.data()) max_motion = std::max(max_motion, std::abs(v));
    if (k == 0 || k == 3)
      EXPECT_EQ(max_motion, 0.0f) << k;
    else
      EXPECT_GT(max_motion, 0.1f) << k;
    EXPECT_EQ(render_reference(sc, k, 1, rs, Exec{}).camera_cut, k == 3);
  }
}

void expect_frames_identical(const Frame& a, const Frame& b) {
  EXPECT_EQ(a.color, b.color);
  EXPECT_EQ(a.depth, b.depth);
  EXPECT_EQ(a.normal, b.normal);
  EXPECT_EQ(a.albedo, b.albedo);
  EXPECT_EQ(a.motion, b.motion);
  EXPECT_EQ(a.id, b.id);
}

TEST(RenderDeterminism, IdenticalForOneAndTwoThreads) {
  const Scene sc = make_builtin_scene("motion", false);
  RenderSettings rs = small_settings(67, 39);
  expect_frames_identical(render_gbuffer(sc, 9, rs, test::with_threads(1)),
                          render_gbuffer(sc, 9, rs, test::with_threads(2)));
  expect_frames_identical(render_reference(sc, 9, 4, rs, test::with_threads(1)),
                          render_reference(sc, 9, 4, rs, test::with_threads(2)));
  rs.soft_shadows = true;
  rs.light_samples = 4;
  const Scene thin = make_builtin_scene("thin", false);
  expect_frames_identical(render_reference(thin, 9, 4, rs, test::with_threads(1)),
                          render_reference(thin, 9, 4, rs, test::with_threads(2)));
}

// Mean absolute difference after the shared Reinhard tonemap (HDR highlights would otherwise
// dominate the mean).
double tonemapped_mad(const Frame& a, const Frame& b) {
  double s = 0;
  for (size_t i = 0; i < a.color.data().size(); ++i)
    s += std::abs(tonemap_reinhard(a.color.data()[i]) - tonemap_reinhard(b.color.data()[i]));
  return s / double(a.color.data().size());
}

TEST(RenderReference, ConvergesWithSampleCount) {
  const Scene sc = make_builtin_scene("thin", false);
  const RenderSettings rs = small_settings(96, 54);
  RenderStats st;
  const Frame r1 = render_reference(sc, 12, 1, rs, Exec{}, &st);
  const Frame r64 = render_reference(sc, 12, 64, rs, Exec{}, &st);
  const Frame r256 = render_reference(sc, 12, 256, rs, Exec{}, &st);
  const double d1 = tonemapped_mad(r1, r64), d64 = tonemapped_mad(r64, r256);
  std::printf(
      "reference convergence: |1 - 64 spp| %.5f, |64 - 256 spp| %.5f, ratio %.3f "
      "(%.1f Mrays/s)\n",
      d1, d64, d64 / d1, st.rays_per_second() * 1e-6);
  EXPECT_GT(d1, 0.0);
  EXPECT_LT(d64, 0.25 * d1);
  EXPECT_EQ(r64.jitter, Vec2d(0.0, 0.0));
  EXPECT_GT(st.primary_rays, uint64_t(96 * 54 * (1 + 64 + 256)));
}

// Reference color is the box-filtered pixel: on a region of constant color it equals the
// G-buffer color, and its G-buffer channels come from the pixel center.
TEST(RenderReference, CenterSampleChannelsMatchUnjitteredGBuffer) {
  const Scene sc = make_builtin_scene("orbit", false);
  const RenderSettings rs = small_settings(53, 31, "none");
  const Frame g = render_gbuffer(sc, 6, rs, Exec{});
  const Frame r = render_reference(sc, 6, 4, rs, Exec{});
  EXPECT_EQ(g.depth, r.depth);
  EXPECT_EQ(g.id, r.id);
  EXPECT_EQ(g.motion, r.motion);
  EXPECT_EQ(g.view, r.view);
}

// A pass's early frames (the demo's warm-up references) render at their own sample count and
// seed, the rest as the pass says; with its own seed an early frame is not the image of another
// pass at the same count (which would score that pass as exact there).
TEST(RenderSequence, EarlyFramesTakeTheirOwnSamplesAndSeed) {
  const Scene sc = make_builtin_scene("thin", false);
  const RenderSettings rs = small_settings(33, 19);
  RenderPass ref{"reference", 16};
  ref.early_frames = 2;
  ref.early_spp = 4;
  ref.early_seed = rs.seed + 1;
  std::vector<std::vector<ImageF>> got(2);
  render_sequence(sc, 3, {ref, {"ssaa 4", 4}}, rs, Exec{},
                  [&](int, size_t pass, Frame&& f) { got[pass].push_back(std::move(f.color)); });
  ASSERT_EQ(got[0].size(), 3u);
  RenderSettings early = rs;
  early.seed = rs.seed + 1;
  for (int t = 0; t < 2; ++t) {
    EXPECT_EQ(got[0][size_t(t)], render_reference(sc, t, 4, early, Exec{}).color) << t;
    EXPECT_FALSE(got[0][size_t(t)] == got[1][size_t(t)]) << t;
    EXPECT_EQ(got[1][size_t(t)], render_reference(sc, t, 4, rs, Exec{}).color) << t;
  }
  EXPECT_EQ(got[0][2], render_reference(sc, 2, 16, rs, Exec{}).color);
  RenderPass bad = ref;
  bad.early_spp = 0;  // a G-buffer's early frames cannot be references, nor the reverse
  EXPECT_THROW(render_sequence(sc, 1, {bad}, rs, Exec{}, [](int, size_t, Frame&&) {}),
               SettingsError);
}

// A pass from its first_frame on: its earlier frames are not rendered (the sink never sees
// them) and its later ones are the frames a full pass renders (no state carried over).
TEST(RenderSequence, PassesStartAtTheirFirstFrame) {
  const Scene sc = make_builtin_scene("motion", false);
  const RenderSettings rs = small_settings(33, 19);
  RenderPass late{"ssaa 4", 4};
  late.first_frame = 2;
  std::vector<std::vector<std::pair<int, ImageF>>> got(2);
  render_sequence(sc, 4, {{"no-AA", 1}, late}, rs, Exec{}, [&](int t, size_t pass, Frame&& f) {
    got[pass].push_back({t, std::move(f.color)});
  });
  ASSERT_EQ(got[0].size(), 4u);
  ASSERT_EQ(got[1].size(), 2u);
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(got[1][size_t(k)].first, 2 + k);
    EXPECT_EQ(got[1][size_t(k)].second, render_reference(sc, 2 + k, 4, rs, Exec{}).color) << k;
  }
  late.first_frame = -1;
  EXPECT_THROW(render_sequence(sc, 1, {late}, rs, Exec{}, [](int, size_t, Frame&&) {}),
               SettingsError);
}

}  // namespace
}  // namespace afterimage::render
