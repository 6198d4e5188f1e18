// Tests of the camera-effect references (issue 12): the shared circle-of-confusion function,
// the FOV / focal-length rule, aperture sampling, thin-lens depth of field and shutter motion
// blur in the ray tracer's reference, determinism, and the plain reference left unchanged.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "camera/aperture.h"
#include "camera/camera.h"
#include "core/error.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "test_util.h"

namespace afterimage::render {
namespace {

RenderSettings settings(int w, int h) {
  RenderSettings rs;
  rs.width = w;
  rs.height = h;
  return rs;
}

// An empty scene with a black sky and no ambient light, camera at the origin looking down -z.
Scene dark_scene(double vfov) {
  Scene sc;
  sc.name = "lens-test";
  sc.camera.vfov_degrees = vfov;
  sc.sky.zenith = sc.sky.horizon = sc.sky.ground = {0.0f, 0.0f, 0.0f};
  sc.ambient = {0.0f, 0.0f, 0.0f};
  sc.camera_motion.keys = {camera_keyframe(0.0, {0, 0, 0}, {0, 0, -1})};
  return sc;
}

// A plane facing the camera (+z normal), size sx by sy, centered at `center`.
uint32_t add_facing_plane(Scene& sc, Vec3d center, double sx, double sy, const Material& m,
                          Animation anim = {}) {
  const int mesh = sc.add_mesh(make_plane(sx, sy));
  if (anim.is_identity())
    anim = Animation::fixed({center, Quat::from_axis_angle({1, 0, 0}, kPi / 2), {1, 1, 1}});
  return sc.add_object("plane", mesh, m, anim);
}

Material emissive(float e) {
  Material m;
  m.albedo = {0, 0, 0};
  m.emission = {e, e, e};
  return m;
}

double luminance_at(const Frame& f, int x, int y) {
  const Vec3f c = f.color_at(x, y);
  return (c.x + c.y + c.z) / 3.0;
}

double mean_abs_diff(const Frame& a, const Frame& b) {
  double s = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) s += std::abs(luminance_at(a, x, y) - luminance_at(b, x, y));
  return s / (double(a.width) * a.height);
}

bool colors_identical(const Frame& a, const Frame& b) {
  return a.color.data() == b.color.data();
}

// ---- circle of confusion, FOV rule -------------------------------------------------------

TEST(CircleOfConfusion, MatchesHandComputedValues) {
  // f = 50 mm, N = 2 (A = 25 mm), s = 2 m, 36 mm sensor, 1000 px wide:
  // c = A (d - s) / d * f / (s - f) = 25 mm * (d - 2) / d * 0.05 / 1.95, times 1000 / 36 px/mm.
  ThinLens l{50.0, 2.0, 2.0, 36.0};
  // d = 2 (focus plane): 0.
  EXPECT_DOUBLE_EQ(circle_of_confusion_px(l, 2.0, 1000), 0.0);
  // d = 4: 25 * 0.5 * 0.0256410 = 0.320513 mm = 8.903134 px (far field: positive).
  EXPECT_NEAR(circle_of_confusion_px(l, 4.0, 1000), 8.903134, 1e-5);
  // d = 1: 25 * -1 * 0.0256410 = -0.641026 mm = -17.806268 px (near field: negative).
  EXPECT_NEAR(circle_of_confusion_px(l, 1.0, 1000), -17.806268, 1e-5);
  // d = 1.5: 25 * (-1/3) * 0.0256410 = -0.213675 mm = -5.935423 px.
  EXPECT_NEAR(circle_of_confusion_px(l, 1.5, 1000), -5.935423, 1e-5);
  // Background depth: the far limit A f / (s - f) = 17.806268 px.
  EXPECT_NEAR(circle_of_confusion_px(l, 1e10, 1000), 17.806268, 1e-5);
  // Linear in the image width; a pinhole has none.
  EXPECT_NEAR(circle_of_confusion_px(l, 4.0, 500), 8.903134 / 2, 1e-5);
  l.f_number = 0.0;
  EXPECT_EQ(circle_of_confusion_px(l, 4.0, 1000), 0.0);
}

TEST(CircleOfConfusion, FocalLengthFollowsTheFieldOfView) {
  // 36 mm sensor, 16:9, vertical FOV 20 deg: tan(hfov/2) = 16/9 tan(10 deg) = 0.3134702,
  // f = 36 / (2 * 0.3134702) = 57.421728 mm.
  EXPECT_NEAR(focal_length_for_fov_mm(20.0, 36.0, 16.0 / 9.0), 57.421728, 1e-5);
  EXPECT_NEAR(fov_for_focal_length_deg(57.421728, 36.0, 16.0 / 9.0), 20.0, 1e-4);
  EXPECT_NEAR(fov_for_focal_length_deg(focal_length_for_fov_mm(47.0, 24.0, 1.5), 24.0, 1.5), 47.0,
              1e-9);
  // The frame's lens agrees with its projection: a view-space point at tan t off axis lands
  // W f / sensor_width * t pixels right of the image center.
  Camera cam;
  cam.vfov_degrees = 33.0;
  const int w = 320, h = 180;
  const ThinLens l = frame_lens(cam, w, h);
  const double t = 0.21;
  const Vec2d p = project_to_pixel(cam.projection(w, h), {t * 3.0, 0.0, -3.0}, w, h);
  EXPECT_NEAR(p.x - 0.5 * w, w * l.focal_length_mm / l.sensor_width_mm * t, 1e-9);
  // The renderer writes that lens into its frames.
  Scene sc = dark_scene(33.0);
  sc.camera.lens.f_number = 2.8;
  const Frame f = render_gbuffer(sc, 0, settings(w, h), test::with_threads(1));
  EXPECT_DOUBLE_EQ(f.lens.focal_length_mm, l.focal_length_mm);
  EXPECT_EQ(f.lens.f_number, 2.8);
}

TEST(CircleOfConfusion, LensValidation) {
  EXPECT_NO_THROW(validate_lens(ThinLens{}));
  ThinLens l;
  l.blades = 2;
  EXPECT_THROW(validate_lens(l), SettingsError);
  l.blades = 6;
  EXPECT_NO_THROW(validate_lens(l));
  l.f_number = -1;
  EXPECT_THROW(validate_lens(l), SettingsError);
  l.f_number = 2;
  l.focus_distance = 0.01;  // inside the focal length
  EXPECT_THROW(validate_lens(l), SettingsError);
}

// ---- aperture sampling --------------------------------------------------------------------

void check_aperture_uniform(const ThinLens& lens) {
  // Uniform in the shape: the scaled-down copy of half the area (factor 1/sqrt 2) holds half
  // the samples, each of 8 angular sectors holds its share of the area, the mean is the center.
  const int n = 256;  // n x n stratified samples
  std::mt19937 gen(7);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  int inner = 0;
  std::vector<int> sector(8, 0);
  Vec2d mean{0, 0};
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Vec2d p = aperture_sample(lens, {(i + u01(gen)) / n, (j + u01(gen)) / n});
      ASSERT_TRUE(inside_aperture(lens, p, 1e-9)) << p.x << " " << p.y;
      if (inside_aperture(lens, p * std::sqrt(2.0), 0.0)) ++inner;
      double a = std::atan2(p.y, p.x) - lens.blade_rotation_deg * kPi / 180.0;
      a = a - 2 * kPi * std::floor(a / (2 * kPi));
      ++sector[size_t(std::min(7, int(a / (2 * kPi) * 8)))];
      mean = mean + p;
    }
  const double total = double(n) * n;
  EXPECT_NEAR(inner / total, 0.5, 0.01);
  // Each sector's share of the shape's area: 1/8 for the disc, by quadrature of r(a)^2 / 2
  // for a polygon.
  for (int k = 0; k < 8; ++k) {
    double share = 1.0 / 8;
    if (lens.blades >= 3) {  // exact area of the sector of the polygon, by fine quadrature
      const double rot = lens.blade_rotation_deg * kPi / 180.0, half = kPi / lens.blades;
      double area = 0, all = 0;
      const int steps = 4000;
      for (int s = 0; s < 8 * steps; ++s) {
        const double a = rot + (s + 0.5) / (8 * steps) * 2 * kPi;
        // Polygon radius in direction a: apothem / cos(angle to the nearest edge normal).
        double rel = std::fmod(a - rot - half, 2 * half);  // from the last edge normal
        if (rel < 0) rel += 2 * half;
        const double r = std::cos(half) / std::cos(std::min(rel, 2 * half - rel));
        all += r * r;
        if (s / steps == k) area += r * r;
      }
      share = area / all;
    }
    EXPECT_NEAR(sector[size_t(k)] / total, share, 0.004) << "sector " << k;
  }
  EXPECT_NEAR(mean.x / total, 0.0, 2e-3);
  EXPECT_NEAR(mean.y / total, 0.0, 2e-3);
}

TEST(Aperture, DiscSamplesUniformInside) {
  EXPECT_EQ(concentric_disc({0.5, 0.5}), Vec2d(0, 0));
  EXPECT_NEAR(length(Vec3d(concentric_disc({1.0, 0.5}).x, concentric_disc({1.0, 0.5}).y, 0)), 1.0,
              1e-12);
  check_aperture_uniform(ThinLens{});
}

TEST(Aperture, PolygonSamplesUniformInside) {
  ThinLens l;
  l.blades = 6;
  l.blade_rotation_deg = 15.0;
  check_aperture_uniform(l);
  l.blades = 5;
  l.blade_rotation_deg = 90.0;
  check_aperture_uniform(l);
  // Vertices on the unit circle at the rotation; the edge midpoint at the apothem is inside,
  // just beyond it is not.
  const Vec2d v0 = polygon_vertex(5, kPi / 2, 0);
  EXPECT_NEAR(v0.x, 0.0, 1e-12);
  EXPECT_NEAR(v0.y, 1.0, 1e-12);
  const Vec2d mid = (polygon_vertex(5, kPi / 2, 0) + polygon_vertex(5, kPi / 2, 1)) * 0.5;
  EXPECT_TRUE(inside_aperture(l, mid, 1e-9));
  EXPECT_FALSE(inside_aperture(l, mid * 1.01));
}

// ---- depth of field -----------------------------------------------------------------------

// A smoothly textured, lit plane filling the view at view depth `depth`.
Scene textured_plane_scene(double depth, double focus) {
  Scene sc = dark_scene(30.0);
  Material m;
  m.texture = Texture::Sine;
  m.frequency = 22.0;
  m.albedo = {0.8f, 0.7f, 0.6f};
  m.albedo2 = {0.1f, 0.15f, 0.2f};
  const double size = 3.0 * depth / 2.0;
  add_facing_plane(sc, {0, 0, -depth}, size, size, m);
  Light sun;
  sun.type = LightType::Directional;
  sun.position = normalize(Vec3d{0.2, 0.3, 1.0});
  sun.color = {3.0f, 3.0f, 3.0f};
  sc.lights.push_back(sun);
  sc.camera.lens.f_number = 1.4;
  sc.camera.lens.focus_distance = focus;
  return sc;
}

TEST(DepthOfField, FocusPlaneStaysSharp) {
  const int w = 64, h = 64, spp = 64;
  RenderSettings rs = settings(w, h);
  RenderSettings dof = rs;
  dof.effects.depth_of_field = true;
  // On the focus plane every lens ray meets the pinhole ray's point: equal up to the pixel
  // integration noise (measured against a second seed of the plain reference).
  const Scene in = textured_plane_scene(0.6, 0.6);
  const Frame pin = render_reference(in, 0, spp, rs, test::with_threads(2));
  RenderSettings rs2 = rs;
  rs2.seed = 99;
  const double noise = mean_abs_diff(pin, render_reference(in, 0, spp, rs2, test::with_threads(2)));
  const double focused =
      mean_abs_diff(pin, render_reference(in, 0, spp, dof, test::with_threads(2)));
  // The same plane (same texture scale on screen) three times as far blurs (CoC ~ 7 px here).
  const Scene out = textured_plane_scene(1.8, 0.6);
  const double defocused = mean_abs_diff(render_reference(out, 0, spp, rs, test::with_threads(2)),
                                         render_reference(out, 0, spp, dof, test::with_threads(2)));
  std::printf(
      "focus plane: |dof - pinhole| %.5f, seed noise %.5f; plane behind focus %.5f "
      "(CoC %.1f px)\n",
      focused, noise, defocused, circle_of_confusion_px(frame_lens(out.camera, w, h), 1.8, w));
  EXPECT_LT(focused, 2.0 * noise + 1e-6);
  EXPECT_GT(defocused, 10.0 * noise);
  // G-buffer channels are the pinhole, frame-time ones.
  const Frame d = render_reference(in, 0, spp, dof, test::with_threads(2));
  EXPECT_EQ(d.depth.data(), pin.depth.data());
  EXPECT_EQ(d.motion.data(), pin.motion.data());
}

// Blur of a small emitter far behind the focus plane: its diameter from the energy's second
// moment, E[r^2] = (circumradius R)^2 (1 + 2 cos^2(pi / N)) / 6 for a regular N-gon (R^2 / 2
// for a disc), after removing the variance of the pixel box (1/6 px^2) and of the emitter's
// own image (a disc of radius r_img: r_img^2 / 2).
double measured_blur_diameter(const ThinLens& lens_in, double* expected) {
  const int w = 96, h = 96, spp = 256;
  Scene sc = dark_scene(30.0);
  sc.camera.lens = lens_in;
  const double depth = 10.0, radius = 0.045;
  const int sphere = sc.add_mesh(make_sphere(1.0, 32, 16));
  sc.add_object("emitter", sphere, emissive(1.0f),
                Animation::fixed({{0, 0, -depth}, {}, {radius, radius, radius}}));
  RenderSettings rs = settings(w, h);
  rs.effects.depth_of_field = true;
  const Frame f = render_reference(sc, 0, spp, rs, test::with_threads(2));
  double sum = 0, sx = 0, sy = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double v = luminance_at(f, x, y);
      sum += v;
      sx += v * (x + 0.5);
      sy += v * (y + 0.5);
    }
  const double cx = sx / sum, cy = sy / sum;
  double m2 = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double dx = x + 0.5 - cx, dy = y + 0.5 - cy;
      m2 += luminance_at(f, x, y) * (dx * dx + dy * dy);
    }
  m2 /= sum;
  const ThinLens l = frame_lens(sc.camera, w, h);
  const double px_per_tan = w * l.focal_length_mm / l.sensor_width_mm;
  const double r_img = radius / std::sqrt(depth * depth - radius * radius) * px_per_tan;
  const double shape =
      lens_in.blades >= 3 ? (1.0 + 2.0 * std::pow(std::cos(kPi / lens_in.blades), 2)) / 6.0 : 0.5;
  const double r2 = (m2 - 1.0 / 6.0 - 0.5 * r_img * r_img) / shape;
  *expected = circle_of_confusion_px(l, depth, w);
  std::printf(
      "blur of a point at %.0f m (blades %d): centroid (%.2f, %.2f), diameter %.3f px, "
      "CoC %.3f px\n",
      depth, lens_in.blades, cx, cy, 2.0 * std::sqrt(r2), *expected);
  EXPECT_NEAR(cx, 0.5 * w, 0.5);
  EXPECT_NEAR(cy, 0.5 * h, 0.5);
  return 2.0 * std::sqrt(r2);
}

TEST(DepthOfField, OutOfFocusPointSpreadsToTheCircleOfConfusion) {
  ThinLens lens;
  lens.f_number = 1.4;
  lens.focus_distance = 0.5;
  double expected = 0;
  const double disc = measured_blur_diameter(lens, &expected);
  EXPECT_GT(expected, 15.0);
  EXPECT_NEAR(disc, expected, 1.0);
  lens.blades = 6;
  lens.blade_rotation_deg = 10.0;
  const double hexagon = measured_blur_diameter(lens, &expected);
  EXPECT_NEAR(hexagon, expected, 1.0);
}

TEST(DepthOfField, NeedsALens) {
  Scene sc = textured_plane_scene(2.0, 2.0);
  sc.camera.lens.f_number = 0.0;
  RenderSettings rs = settings(8, 8);
  rs.effects.depth_of_field = true;
  EXPECT_THROW(render_reference(sc, 0, 4, rs, test::with_threads(1)), SettingsError);
}

// ---- motion blur --------------------------------------------------------------------------

// An emissive quad 8 m wide at depth 4 whose left edge crosses the image center at frame 5
// (its right edge is off screen): it moves right at `speed` m/s (object motion) or the camera
// moves left at that speed (camera motion).
Scene moving_edge_scene(double speed, bool camera_moves) {
  Scene sc = dark_scene(40.0);
  const Quat face = Quat::from_axis_angle({1, 0, 0}, kPi / 2);
  const double x5 = 5.0 / 30.0 * speed;  // distance moved by frame 5
  Animation a;
  if (camera_moves) {
    a = Animation::fixed({{3.5 - x5, 0, -4}, face, {1, 1, 1}});
    sc.camera_motion.keys = {camera_keyframe(0.0, {0, 0, 0}, {0, 0, -1}),
                             camera_keyframe(10.0, {-10 * speed, 0, 0}, {-10 * speed, 0, -1})};
  } else {
    a.keys = {{0.0, {{3.5 - x5, 0, -4}, face, {1, 1, 1}}},
              {10.0, {{3.5 - x5 + 10 * speed, 0, -4}, face, {1, 1, 1}}}};
  }
  add_facing_plane(sc, {}, 8.0, 4.0, emissive(1.0f), a);
  return sc;
}

// Length of the blur of the quad's left edge, from the variance of the row-averaged profile's
// differences: box(L) for the shutter (L^2 / 12; triangle profile: L^2 / 24), the pixel box
// and the differencing (1/12 each).
double measured_blur_length(const Frame& f, bool triangle) {
  std::vector<double> profile(size_t(f.width), 0.0);
  for (int y = f.height / 4; y < 3 * f.height / 4; ++y)
    for (int x = 0; x < f.width; ++x) profile[size_t(x)] += luminance_at(f, x, y);
  const double top = *std::max_element(profile.begin(), profile.end());
  double s = 0, s1 = 0, s2 = 0;
  for (int x = 1; x < f.width; ++x) {
    const double d = std::max(0.0, (profile[size_t(x)] - profile[size_t(x - 1)]) / top);
    s += d;
    s1 += d * x;
    s2 += d * x * x;
  }
  const double var = s2 / s - (s1 / s) * (s1 / s);
  return std::sqrt(std::max(0.0, (var - 2.0 / 12.0) * (triangle ? 24.0 : 12.0)));
}

TEST(MotionBlur, BlurLengthIsMotionTimesShutterFraction) {
  const int w = 96, h = 48, spp = 64, frame = 5;
  for (bool camera_moves : {false, true})
    for (double angle : {180.0, 360.0})
      for (ShutterProfile profile : {ShutterProfile::Box, ShutterProfile::Triangle}) {
        const Scene sc = moving_edge_scene(15.0, camera_moves);
        RenderSettings rs = settings(w, h);
        const Frame still = render_reference(sc, frame, spp, rs, test::with_threads(2));
        rs.effects.shutter_angle_deg = angle;
        rs.effects.shutter_profile = profile;
        const Frame blurred = render_reference(sc, frame, spp, rs, test::with_threads(2));
        // Motion of the edge from the G-buffer (p_prev - p_curr; the same for the whole quad).
        const double motion = std::abs(still.motion.at(w / 2 + 8, h / 2, 0));
        const double expected = motion * angle / 360.0;
        const double length = measured_blur_length(blurred, profile == ShutterProfile::Triangle);
        std::printf(
            "%s motion %.2f px/frame, shutter %.0f deg %s: blur %.3f px (expected %.3f), "
            "unblurred %.3f px\n",
            camera_moves ? "camera" : "object", motion, angle,
            profile == ShutterProfile::Box ? "box" : "triangle", length, expected,
            measured_blur_length(still, false));
        EXPECT_GT(motion, 5.0);
        EXPECT_NEAR(length, expected, 1.0);
        EXPECT_EQ(blurred.motion.data(), still.motion.data());
      }
}

TEST(MotionBlur, StillSceneEqualsInstantaneousReference) {
  // Animated (not static) scene in which nothing moves, and a static built-in scene.
  const Scene sc = textured_plane_scene(2.0, 2.0);
  const Scene frozen = make_builtin_scene("motion", /*is_static=*/true);
  for (const Scene* s : {&sc, &frozen}) {
    RenderSettings rs = settings(48, 32);
    const Frame plain = render_reference(*s, 3, 16, rs, test::with_threads(2));
    RenderSettings other = rs;
    other.seed = 5;
    const double noise =
        mean_abs_diff(plain, render_reference(*s, 3, 16, other, test::with_threads(2)));
    rs.effects.shutter_angle_deg = 360.0;
    const double diff =
        mean_abs_diff(plain, render_reference(*s, 3, 16, rs, test::with_threads(2)));
    std::printf("%s: still motion blur vs instantaneous %.5f, seed noise %.5f\n", s->name.c_str(),
                diff, noise);
    EXPECT_LT(diff, 1.5 * noise + 1e-6);
  }
}

TEST(MotionBlur, ShutterTimes) {
  CameraEffects fx;
  fx.shutter_angle_deg = 180.0;
  // Centered: 4 strata of half a frame interval at 30 fps, midpoints.
  for (int i = 0; i < 4; ++i)
    EXPECT_NEAR(shutter_time_offset(fx, 30.0, i, 4), ((i + 0.5) / 4 - 0.5) * 0.5 / 30.0, 1e-15);
  fx.shutter_profile = ShutterProfile::Triangle;
  EXPECT_NEAR(shutter_time_offset(fx, 30.0, 0, 1), 0.0, 1e-15);  // the peak
  EXPECT_NEAR(shutter_time_offset(fx, 30.0, 0, 2), (std::sqrt(0.125) - 0.5) * 0.5 / 30.0, 1e-15);
  EXPECT_EQ(parse_shutter_profile("triangle"), ShutterProfile::Triangle);
  EXPECT_THROW(parse_shutter_profile("gauss"), SettingsError);
  fx.shutter_angle_deg = 400.0;
  EXPECT_THROW(fx.validate(), SettingsError);
  // Strata must divide the samples per pixel.
  RenderSettings rs = settings(8, 8);
  rs.effects.shutter_angle_deg = 180.0;
  rs.effects.shutter_samples = 3;
  EXPECT_THROW(render_reference(moving_edge_scene(1.0, false), 1, 16, rs, test::with_threads(1)),
               SettingsError);
}

// ---- unchanged plain reference, determinism ---------------------------------------------

TEST(CameraEffects, PlainReferenceUnchangedByTheLensAndShutterSettings) {
  // The camera's lens alone (no depth_of_field) and shutter settings with angle 0 leave the
  // reference bit-identical to the pinhole camera's.
  Scene pinhole = make_builtin_scene("focus");
  pinhole.camera.lens.f_number = 0.0;
  const Scene lens = make_builtin_scene("focus");
  RenderSettings rs = settings(64, 36);
  const Frame a = render_reference(pinhole, 4, 4, rs, test::with_threads(2));
  rs.effects.shutter_profile = ShutterProfile::Triangle;
  rs.effects.shutter_samples = 4;
  const Frame b = render_reference(lens, 4, 4, rs, test::with_threads(2));
  EXPECT_TRUE(colors_identical(a, b));
  EXPECT_EQ(a.depth.data(), b.depth.data());
  EXPECT_EQ(a.motion.data(), b.motion.data());
}

TEST(CameraEffects, DeterministicAcrossThreadCounts) {
  const Scene sc = make_builtin_scene("focus");
  RenderSettings rs = settings(48, 27);
  rs.effects.depth_of_field = true;
  rs.effects.shutter_angle_deg = 270.0;
  const Frame one = render_reference(sc, 6, 16, rs, test::with_threads(1));
  const Frame two = render_reference(sc, 6, 16, rs, test::with_threads(2));
  const Frame many = render_reference(sc, 6, 16, rs, test::with_threads(7));
  EXPECT_TRUE(colors_identical(one, two));
  EXPECT_TRUE(colors_identical(one, many));
}

TEST(CameraEffects, FocusSceneShowsDepthOfField) {
  // The built-in focus scene: its DoF reference differs from the pinhole one in the near and
  // far field, and its lens makes both blurs several pixels wide at 640 wide.
  const Scene sc = make_builtin_scene("focus");
  const ThinLens l = frame_lens(sc.camera, 640, 360);
  std::printf(
      "focus scene: f %.1f mm f/%.1f at %.1f m; CoC at 1.5 m %.1f px, 9 m %.1f px, sky "
      "%.1f px\n",
      l.focal_length_mm, l.f_number, l.focus_distance, circle_of_confusion_px(l, 1.5, 640),
      circle_of_confusion_px(l, 9.0, 640), circle_of_confusion_px(l, 1e10, 640));
  EXPECT_LT(circle_of_confusion_px(l, 1.5, 640), -8.0);
  EXPECT_GT(circle_of_confusion_px(l, 9.0, 640), 8.0);
  // Its focus box is in focus: its front face at about the focus distance.
  const Frame g = render_gbuffer(sc, 0, settings(64, 36), test::with_threads(2));
  double best = 1e9;
  for (int y = 0; y < g.height; ++y)
    for (int x = 0; x < g.width; ++x)
      if (sc.objects[g.id.at(x, y, 0) > 0 ? g.id.at(x, y, 0) - 1 : 0].name == "focus box" &&
          g.id.at(x, y, 0) > 0)
        best = std::min(best, std::abs(g.depth.at(x, y, 0) - l.focus_distance));
  EXPECT_LT(best, 0.2);
}

}  // namespace
}  // namespace afterimage::render
