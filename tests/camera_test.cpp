#include <gtest/gtest.h>

#include <random>

#include "camera/camera.h"
#include "core/error.h"

using namespace afterimage;

TEST(Halton, Base2And3Values) {
  const double b2[] = {0.5, 0.25, 0.75, 0.125, 0.625, 0.375, 0.875};
  const double b3[] = {1.0 / 3, 2.0 / 3, 1.0 / 9, 4.0 / 9, 7.0 / 9, 2.0 / 9, 5.0 / 9};
  for (int i = 0; i < 7; ++i) {
    EXPECT_DOUBLE_EQ(halton(i + 1, 2), b2[i]);
    EXPECT_NEAR(halton(i + 1, 3), b3[i], 1e-15);
  }
  EXPECT_EQ(halton(0, 2), 0.0);
}

TEST(Halton, JitterSequenceSkipsZeroAndCycles) {
  JitterSequence s = parse_jitter("halton16");
  EXPECT_EQ(s.length, 16);
  EXPECT_DOUBLE_EQ(s.at(0).x, 0.0);  // halton(1,2) - 0.5
  EXPECT_NEAR(s.at(0).y, 1.0 / 3 - 0.5, 1e-15);
  EXPECT_DOUBLE_EQ(s.at(1).x, -0.25);
  EXPECT_EQ(s.at(16), s.at(0));
  for (int k = 0; k < 16; ++k) {
    EXPECT_LE(std::abs(s.at(k).x), 0.5);
    EXPECT_LE(std::abs(s.at(k).y), 0.5);
  }
  EXPECT_EQ(parse_jitter("halton8").length, 8);
  EXPECT_EQ(parse_jitter("none").at(3), Vec2d(0, 0));
  EXPECT_THROW(parse_jitter("sobol"), SettingsError);
  EXPECT_THROW(parse_jitter("halton0"), SettingsError);
}

namespace {
void check_jitter_property(const Camera& cam, int w, int h) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-0.5, 0.5), xy(-3, 3), z(-20, -1);
  const Mat4 p = cam.projection(w, h);
  double worst = 0;
  for (int i = 0; i < 500; ++i) {
    Vec2d j(u(rng), u(rng));
    const Mat4 pj = jittered_projection(p, j, w, h);
    Vec3d pt(xy(rng), xy(rng), z(rng));
    Vec3d world = cam.view.inverse().transform_point(pt);
    Vec2d a = project_to_pixel(p * cam.view, world, w, h);
    Vec2d b = project_to_pixel(pj * cam.view, world, w, h);
    // Points move by -jitter: the pixel center then shows the unjittered position
    // center + jitter, the ray tracer's sample (DESIGN.md §3).
    worst = std::max({worst, std::abs(b.x - a.x + j.x), std::abs(b.y - a.y + j.y)});
  }
  EXPECT_LT(worst, 1e-4);
}

// The ray tracer's sample for pixel (i, j) and a rasteriser with jittered_projection agree:
// the world point hit through (i + 0.5 + jitter) unjittered lands on the pixel center.
void check_rasteriser_matches_ray_tracer(const Camera& cam, int w, int h) {
  const Mat4 p = cam.projection(w, h), vp = p * cam.view;
  const Mat4 inv = vp.inverse();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  double worst = 0;
  for (int k = 0; k < 200; ++k) {
    const Vec2d j(u(rng), u(rng)), center(double(k % w) + 0.5, double(k % h) + 0.5);
    const Vec2d sample = center + j;
    const double nx = 2.0 * sample.x / w - 1.0, ny = 1.0 - 2.0 * sample.y / h;
    const Vec4d q = inv * Vec4d(nx, ny, 0.3, 1.0);  // a point on the sample's ray
    const Vec2d seen =
        project_to_pixel(jittered_projection(p, j, w, h) * cam.view, q.xyz() / q.w, w, h);
    worst = std::max({worst, std::abs(seen.x - center.x), std::abs(seen.y - center.y)});
  }
  EXPECT_LT(worst, 1e-6);
}
}  // namespace

TEST(Jitter, PerspectiveMovesEveryPointByMinusJitterPixels) {
  Camera cam;
  cam.view = look_at({1, 2, 6}, {0, 0, 0}, {0, 1, 0});
  check_jitter_property(cam, 257, 89);
  check_rasteriser_matches_ray_tracer(cam, 257, 89);
}

TEST(Jitter, OrthographicMovesEveryPointByMinusJitterPixels) {
  Camera cam;
  cam.type = ProjectionType::Orthographic;
  cam.ortho_height = 5;
  cam.view = look_at({1, 2, 6}, {0, 0, 0}, {0, 1, 0});
  check_jitter_property(cam, 257, 89);
  check_rasteriser_matches_ray_tracer(cam, 257, 89);
}

TEST(Camera, ProjectionConventions) {
  // A point straight ahead projects to the image center; +Y view up is pixel y smaller.
  Camera cam;
  const int w = 200, h = 100;
  Mat4 vp = cam.projection(w, h) * cam.view;
  Vec2d c = project_to_pixel(vp, {0, 0, -5}, w, h);
  EXPECT_NEAR(c.x, 100, 1e-9);
  EXPECT_NEAR(c.y, 50, 1e-9);
  Vec2d up = project_to_pixel(vp, {0, 1, -5}, w, h);
  EXPECT_LT(up.y, 50);
  Vec2d right = project_to_pixel(vp, {1, 0, -5}, w, h);
  EXPECT_GT(right.x, 100);
  // Vertical fov: a point at the top edge of the frustum lands on y = 0.
  double t = std::tan(0.5 * cam.vfov_degrees * kPi / 180.0);
  EXPECT_NEAR(project_to_pixel(vp, {0, 5 * t, -5}, w, h).y, 0.0, 1e-9);
}
