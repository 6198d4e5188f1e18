// Each motion and depth convention against a known moving point: the point is projected with
// our camera at two times, its motion written the way each tool defines it (independently of
// the converter), converted back and compared with ours (DESIGN.md §3).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "camera/camera.h"
#include "core/error.h"
#include "frame/conventions.h"

using namespace afterimage;

namespace {

constexpr int W = 257, H = 89;

struct Moving {
  Vec2d prev, curr, next;  // pixel positions, y down
  Vec2d ndc_prev, ndc_curr;
};

Vec2d ndc_of(const Mat4& vp, Vec3d p) {
  const Vec4d c = vp * Vec4d(p, 1.0);
  return {c.x / c.w, c.y / c.w};
}

// A point moving along a line while the camera moves and turns.
Moving known_point() {
  Camera cam;
  cam.vfov_degrees = 50;
  auto cam_at = [&](double t) {
    Camera c = cam;
    c.view = look_at({0.3 * t, 1.0 + 0.1 * t, 6.0}, {0.2 * t, 0.0, 0.0}, {0, 1, 0});
    return c.projection(W, H) * c.view;
  };
  auto point_at = [](double t) { return Vec3d(-0.7 + 0.45 * t, 0.2 - 0.3 * t, 0.5 * t); };
  Moving m;
  m.prev = project_to_pixel(cam_at(0), point_at(0), W, H);
  m.curr = project_to_pixel(cam_at(1), point_at(1), W, H);
  m.next = project_to_pixel(cam_at(2), point_at(2), W, H);
  m.ndc_prev = ndc_of(cam_at(0), point_at(0));
  m.ndc_curr = ndc_of(cam_at(1), point_at(1));
  return m;
}

void expect_near(Vec2d a, Vec2d b, double tol = 1e-9) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
}

}  // namespace

TEST(MotionConventions, EachConvertsAKnownMovingPointToOurs) {
  const Moving m = known_point();
  const Vec2d ours = m.prev - m.curr;                   // p_prev - p_curr, pixels, y down
  const Vec2d ours_next = m.next - m.curr;              // p_next - p_curr
  ASSERT_GT(std::abs(ours.x) + std::abs(ours.y), 5.0);  // the point really moves

  auto to_ours = [&](const char* name, Vec2d file) {
    return motion_to_afterimage(file, parse_motion_convention(name), W, H);
  };
  expect_near(to_ours("afterimage", ours), ours);
  // Blender Vector.XY: previous - current, +y up. Vector.ZW: current - next, +y up.
  expect_near(to_ours("blender", {m.prev.x - m.curr.x, -(m.prev.y - m.curr.y)}), ours);
  expect_near(to_ours("blender-next", {m.curr.x - m.next.x, -(m.curr.y - m.next.y)}), ours_next);
  // Unity: current UV - previous UV, UV origin bottom-left.
  auto uv = [](Vec2d p) { return Vec2d(p.x / W, 1.0 - p.y / H); };
  expect_near(to_ours("unity", uv(m.curr) - uv(m.prev)), ours);
  // Unreal: NDC current - previous, encoded V * 0.2495 + 32767/65535.
  const Vec2d v = m.ndc_curr - m.ndc_prev;
  const double bias = 32767.0 / 65535.0;
  expect_near(to_ours("unreal", {v.x * 0.2495 + bias, v.y * 0.2495 + bias}), ours);
  // FSR2: pixels, current to previous, y down; with motionVectorScale (2, 3) the file holds
  // vectors that the scale brings to pixels.
  expect_near(to_ours("fsr2", ours), ours);
  expect_near(to_ours("fsr2:2:3", {ours.x / 2.0, ours.y / 3.0}), ours);
}

TEST(MotionConventions, RoundTripAndErrors) {
  for (const MotionConvention& c : motion_conventions()) {
    const Vec2d v{3.25, -1.5};
    expect_near(motion_to_afterimage(motion_from_afterimage(v, c, W, H), c, W, H), v, 1e-12);
  }
  EXPECT_THROW(parse_motion_convention("optical-flow"), SettingsError);
  EXPECT_THROW(parse_motion_convention("fsr2:2"), SettingsError);
  EXPECT_THROW(parse_motion_convention("fsr2:x:1"), SettingsError);
}

TEST(MotionConventions, ConvertMotionImageUsesTheImageSize) {
  ImageF img(W, H, 2);
  img.at(3, 4, 0) = 0.5f;  // half the width in UV
  img.at(3, 4, 1) = 0.25f;
  convert_motion(img, parse_motion_convention("unity"));
  EXPECT_FLOAT_EQ(img.at(3, 4, 0), -0.5f * W);  // current - previous -> previous - current
  EXPECT_FLOAT_EQ(img.at(3, 4, 1), 0.25f * H);  // y up -> y down, negated
}

namespace {

// A frame whose pixel (x, y) sees a point at view depth d: the sample position (pixel centre
// plus jitter) unprojected with the inverse projection (independent of the converter).
struct DepthCase {
  Frame f;
  int x = 37, y = 61;
  double d = 7.25;
  Vec3d view_point;
};

DepthCase depth_case(const Camera& cam, Vec2d jitter) {
  DepthCase c;
  c.f = Frame::allocate(W, H, {Channel::color, Channel::depth});
  c.f.projection = cam.projection(W, H);
  c.f.jitter = jitter;
  const double sx = c.x + 0.5 + jitter.x, sy = c.y + 0.5 + jitter.y;
  const Vec4d ndc{2.0 * sx / W - 1.0, 1.0 - 2.0 * sy / H, 0.0, 1.0};
  Vec4d v = c.f.projection.inverse() * ndc;
  Vec3d dir{v.x / v.w, v.y / v.w, v.z / v.w};
  if (cam.type == ProjectionType::Orthographic) dir = {dir.x, dir.y, -1.0};  // parallel rays
  c.view_point =
      cam.type == ProjectionType::Orthographic ? Vec3d(dir.x, dir.y, -c.d) : dir * (c.d / -dir.z);
  return c;
}

double window_depth(const Mat4& p, Vec3d view_point) {
  const Vec4d clip = p * Vec4d(view_point, 1.0);
  return 0.5 * clip.z / clip.w + 0.5;  // GL glDepthRange(0, 1)
}

}  // namespace

TEST(DepthConventions, RayDistanceOfAKnownPoint) {
  Camera cam;
  cam.vfov_degrees = 70;
  DepthCase c = depth_case(cam, {0.31, -0.27});
  const double ray = std::sqrt(c.view_point.x * c.view_point.x + c.view_point.y * c.view_point.y +
                               c.view_point.z * c.view_point.z);
  ASSERT_GT(ray - c.d, 0.05);  // off-axis: the two really differ
  c.f.depth.at(c.x, c.y, 0) = float(ray);
  convert_depth(c.f, parse_depth_convention("ray"), true, "test");
  EXPECT_NEAR(c.f.depth.at(c.x, c.y, 0), c.d, 1e-5);
  EXPECT_EQ(c.f.depth.at(0, 0, 0), kBackgroundDepth);  // sky stays sky
  Frame g = Frame::allocate(W, H);
  EXPECT_THROW(convert_depth(g, parse_depth_convention("ray"), false, "x"), InputError);
}

TEST(DepthConventions, HardwareDepthFromPlanesOrProjection) {
  Camera cam;
  cam.near_plane = 0.1;
  cam.far_plane = 200.0;
  for (const char* spec :
       {"hardware", "hardware:0.1:200", "hardware-reversed", "hardware-reversed:0.1:200"}) {
    DepthCase c = depth_case(cam, {0, 0});
    const bool reversed = std::string(spec).find("reversed") != std::string::npos;
    const double z = window_depth(c.f.projection, c.view_point);
    c.f.depth.at(c.x, c.y, 0) = float(reversed ? 1.0 - z : z);
    c.f.depth.at(1, 1, 0) = reversed ? 0.0f : 1.0f;  // cleared: sky
    convert_depth(c.f, parse_depth_convention(spec), true, "test");
    // float storage of z near 1 limits precision: d = n f / (f - z (f - n)).
    EXPECT_NEAR(c.f.depth.at(c.x, c.y, 0), c.d, 2e-3 * c.d) << spec;
    EXPECT_EQ(c.f.depth.at(1, 1, 0), kBackgroundDepth) << spec;
  }
}

TEST(DepthConventions, InfiniteReversedAndOrthographic) {
  // Reversed-Z with an infinite far plane stores n / d (clip z = n, w = d).
  const double n = 0.1, d = 42.0;
  EXPECT_NEAR(depth_from_hardware(n / d, n, std::numeric_limits<double>::infinity(), true), d,
              1e-9);
  DepthConvention c = parse_depth_convention("hardware-reversed:0.1:inf");
  EXPECT_TRUE(std::isinf(c.far_plane));
  // Orthographic: window depth is linear in d.
  Camera cam;
  cam.type = ProjectionType::Orthographic;
  cam.near_plane = 0.5;
  cam.far_plane = 50.0;
  DepthCase k = depth_case(cam, {0, 0});
  k.f.depth.at(k.x, k.y, 0) = float(window_depth(k.f.projection, k.view_point));
  convert_depth(k.f, parse_depth_convention("hardware"), true, "test");
  EXPECT_NEAR(k.f.depth.at(k.x, k.y, 0), k.d, 1e-4);
  EXPECT_THROW(parse_depth_convention("w-buffer"), SettingsError);
  EXPECT_THROW(parse_depth_convention("hardware:1:0.5"), SettingsError);
}

TEST(DepthConventions, PlanesOfOurProjection) {
  Camera cam;
  cam.near_plane = 0.25;
  cam.far_plane = 321.0;
  double n = 0, f = 0;
  planes_of_projection(cam.projection(W, H), n, f);
  EXPECT_NEAR(n, 0.25, 1e-9);
  EXPECT_NEAR(f, 321.0, 1e-6);
}

TEST(BackgroundMotion, DirectionAtInfinityFollowsTheCameraRotation) {
  Camera a, b;
  a.view = look_at({0, 0, 0}, {0, 0, -1}, {0, 1, 0});
  b.view = look_at({0.5, 0, 0}, {0.2, 0.05, -1}, {0, 1, 0});  // previous: moved and turned
  Frame f = Frame::allocate(W, H);
  f.view = a.view;
  f.projection = a.projection(W, H);
  f.depth.at(20, 30, 0) = 3.0f;  // a surface: left alone
  FrameHeader prev;
  prev.view = b.view;
  prev.projection = b.projection(W, H);
  ASSERT_TRUE(fill_background_motion(f, prev, f.motion));
  EXPECT_EQ(f.motion.at(20, 30, 0), 0.0f);
  // Truth: a point very far along the pixel's ray, projected by both cameras (the camera's
  // 0.5 translation is negligible at 1e7 units).
  for (auto [x, y] : {std::pair{5, 7}, {200, 80}, {128, 44}}) {
    const Vec4d ndc{2.0 * (x + 0.5) / W - 1.0, 1.0 - 2.0 * (y + 0.5) / H, 0.0, 1.0};
    Vec4d v = f.projection.inverse() * ndc;
    Vec3d dir{v.x / v.w, v.y / v.w, v.z / v.w};
    const Vec3d far = f.view.inverse().transform_point(dir * (1e7 / -dir.z));
    const Vec2d pc = project_to_pixel(f.projection * f.view, far, W, H);
    const Vec2d pp = project_to_pixel(prev.projection * prev.view, far, W, H);
    EXPECT_NEAR(f.motion.at(x, y, 0), pp.x - pc.x, 1e-3);
    EXPECT_NEAR(f.motion.at(x, y, 1), pp.y - pc.y, 1e-3);
    EXPECT_GT(std::abs(pp.x - pc.x), 1.0);  // the rotation really moves the sky
  }
}
