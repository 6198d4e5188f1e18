// Tests of render/ scene description: animation, camera keyframes, mesh builders, errors.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/error.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "render/shading.h"

namespace afterimage::render {
namespace {

TEST(RenderScene, AnimationInterpolatesAndClamps) {
  Animation a;
  a.keys = {{1.0, {{0, 0, 0}, Quat{}, {1, 1, 1}}},
            {3.0, {{2, 4, 6}, Quat::from_axis_angle({0, 1, 0}, kPi / 2), {3, 3, 3}}}};
  const Transform mid = a.at(2.0);
  EXPECT_NEAR(mid.translation.y, 2.0, 1e-12);
  EXPECT_NEAR(mid.scale.x, 2.0, 1e-12);
  // Half of a 90-degree turn about y maps +x to (cos 45, 0, -sin 45).
  const Vec3d x = mid.rotation.to_matrix().transform_dir({1, 0, 0});
  EXPECT_NEAR(x.x, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(x.z, -std::sqrt(0.5), 1e-12);
  EXPECT_EQ(a.at(-5.0).translation, Vec3d(0, 0, 0));
  EXPECT_EQ(a.at(10.0).translation, Vec3d(2, 4, 6));
}

TEST(RenderScene, CameraKeyframeReproducesLookAt) {
  const Vec3d eye{3, 2, 5}, target{0, 1, -1};
  Scene sc;
  sc.camera_motion.keys = {camera_keyframe(0.0, eye, target)};
  const Mat4 v = sc.view_at(0.0), ref = look_at(eye, target, {0, 1, 0});
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(v.m[i][j], ref.m[i][j], 1e-9) << i << "," << j;
}

TEST(RenderScene, MeshBuildersHaveUnitNormalsAndValidIndices) {
  for (const Mesh& m : {make_box({1, 2, 3}), make_sphere(2.0, 16, 8), make_plane(4, 2, 3, 2),
                        make_cylinder(0.5, 2.0, 6)}) {
    ASSERT_EQ(m.normals.size(), m.positions.size());
    ASSERT_EQ(m.uvs.size(), m.positions.size());
    ASSERT_GT(m.triangle_count(), 0u);
    for (Vec3f n : m.normals) EXPECT_NEAR(length(to_double(n)), 1.0, 1e-6);
    for (uint32_t i : m.indices) EXPECT_LT(i, m.positions.size());
    // Counter-clockwise winding: geometric normals agree with the vertex normals.
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      const uint32_t a = m.indices[3 * t], b = m.indices[3 * t + 1], c = m.indices[3 * t + 2];
      const Vec3d ng = cross(to_double(m.positions[b] - m.positions[a]),
                             to_double(m.positions[c] - m.positions[a]));
      EXPECT_GT(dot(ng, to_double(m.normals[a] + m.normals[b] + m.normals[c])), 0.0);
    }
  }
}

// On for the first on_fraction of each period; a half-frame phase keeps frame times off the
// switches (4 frames on, 4 off at 30 fps).
TEST(RenderScene, BlinkSchedule) {
  const Blink b{8.0 / 30.0, 0.5, 0.5 / 30.0};
  for (int k = 0; k < 40; ++k) EXPECT_EQ(b.on(k / 30.0), k % 8 < 4) << "frame " << k;
  const Blink always;
  for (double t : {-1.0, 0.0, 0.37, 1e6}) EXPECT_TRUE(always.on(t));
  const Blink short_on{1.0, 0.1, 0.0};
  EXPECT_TRUE(short_on.on(2.05));
  EXPECT_FALSE(short_on.on(2.15));
}

TEST(RenderScene, ProceduralAnimationIsEvaluatedExactly) {
  const Animation a = Animation::procedural([](double t) {
    return Transform{{std::sin(t), 0, 0}, Quat::from_axis_angle({0, 0, 1}, t), {1, 1, 1}};
  });
  EXPECT_FALSE(a.is_identity());
  EXPECT_TRUE(Animation{}.is_identity());
  EXPECT_FALSE(Animation::fixed({}).is_identity());
  for (double t : {0.0, 0.1234, 2.5}) {
    EXPECT_EQ(a.at(t).translation.x, std::sin(t));
    const Vec3d x = a.matrix(t).transform_dir({1, 0, 0});
    EXPECT_NEAR(x.x, std::cos(t), 1e-12);
    EXPECT_NEAR(x.y, std::sin(t), 1e-12);
  }
}

TEST(RenderScene, LightAtMovesAndSwitchesLights) {
  Light still;
  still.type = LightType::Point;
  still.position = {0.1, 2.3, -0.7};
  still.color = {3, 2, 1};
  const Light s = light_at(still, 1.7);
  EXPECT_EQ(s.position, still.position);  // no animation: unchanged bit for bit
  EXPECT_EQ(s.color, still.color);

  Light moving = still;
  moving.animation.keys = {{0.0, {{0, 0, 0}, Quat{}, {1, 1, 1}}},
                           {1.0, {{2, 0, 0}, Quat{}, {1, 1, 1}}}};
  EXPECT_NEAR(light_at(moving, 0.5).position.x, 1.1, 1e-12);
  EXPECT_NEAR(light_at(moving, 0.5).position.y, 2.3, 1e-12);

  Light sun;
  sun.type = LightType::Directional;
  sun.position = {1, 0, 0};
  sun.animation =
      Animation::fixed({{5, 5, 5}, Quat::from_axis_angle({0, 0, 1}, kPi / 2), {1, 1, 1}});
  const Vec3d d = light_at(sun, 0.0).position;  // turned, not translated
  EXPECT_NEAR(d.x, 0.0, 1e-12);
  EXPECT_NEAR(d.y, 1.0, 1e-12);

  Light blinking = still;
  blinking.blink = {1.0, 0.5, 0.0};
  EXPECT_EQ(light_at(blinking, 0.25).color, still.color);
  EXPECT_EQ(light_at(blinking, 0.75).color, Vec3f(0, 0, 0));
}

TEST(RenderScene, CameraCutFrames) {
  Scene sc;
  sc.name = "cuts";
  sc.camera_cuts = {8.0 / 30.0, 20.5 / 30.0};
  ASSERT_NO_THROW(sc.validate());
  for (int k = 0; k < 30; ++k) EXPECT_EQ(sc.camera_cut_at(k), k == 8 || k == 21) << k;
  sc.is_static = true;
  for (int k = 0; k < 30; ++k) EXPECT_FALSE(sc.camera_cut_at(k));
  sc.camera_cuts = {0.5, 0.5};
  EXPECT_THROW(sc.validate(), SettingsError);
  sc.camera_cuts = {0.0};
  EXPECT_THROW(sc.validate(), SettingsError);
}

TEST(RenderScene, BumpSlopes) {
  Material m;
  EXPECT_EQ(bump_slope(m, {0.3, 0.7}), Vec2d(0, 0));
  m.bump = Bump::Sine;
  m.bump_frequency = 4.0;
  m.bump_slope = 0.5;
  double max_sine = 0;
  for (int i = 0; i < 64; ++i)
    for (int j = 0; j < 64; ++j) {
      const Vec2d s = bump_slope(m, {i / 64.0, j / 64.0});
      max_sine = std::max(max_sine, std::hypot(s.x, s.y));
    }
  EXPECT_LE(max_sine, 0.5 + 1e-12);
  EXPECT_GT(max_sine, 0.49);
  // At u = 0, v = 1/16 (a quarter period): slope (s, 0), the gradient of sin a sin b.
  EXPECT_NEAR(bump_slope(m, {0.0, 1.0 / 16.0}).x, 0.5, 1e-12);

  // Flakes: one tilt per cell, within the disc, different across cells, mean near zero.
  m.bump = Bump::Flakes;
  m.bump_frequency = 32.0;
  Vec2d mean{0, 0};
  int differ = 0;
  for (int i = 0; i < 32; ++i)
    for (int j = 0; j < 32; ++j) {
      const Vec2d a = bump_slope(m, {(i + 0.1) / 32, (j + 0.2) / 32});
      const Vec2d b = bump_slope(m, {(i + 0.9) / 32, (j + 0.7) / 32});
      ASSERT_EQ(a, b) << "cell " << i << "," << j;
      EXPECT_LE(std::hypot(a.x, a.y), 0.5);
      mean = mean + a * (1.0 / 1024);
      if (!(a == bump_slope(m, {(i + 1.5) / 32, (j + 0.2) / 32}))) ++differ;
    }
  EXPECT_GT(differ, 1000);
  EXPECT_LT(std::hypot(mean.x, mean.y), 0.05);
}

TEST(RenderScene, PerturbNormalTiltsInTheTangentFrame) {
  const Vec3d n{0, 1, 0}, dpdu{2, 0, 0}, dpdv{0, 0, -3};  // a ground plane (make_plane UVs)
  EXPECT_EQ(perturb_normal(n, dpdu, dpdv, {0, 0}), n);
  // Slope 0.5 along u tilts the normal away from +u by atan(0.5).
  const Vec3d a = perturb_normal(n, dpdu, dpdv, {0.5, 0});
  EXPECT_NEAR(length(a), 1.0, 1e-12);
  EXPECT_NEAR(a.x, -0.5 / std::sqrt(1.25), 1e-12);
  EXPECT_NEAR(a.z, 0.0, 1e-12);
  // Along v: away from dp/dv (-z), i.e. toward +z.
  const Vec3d b = perturb_normal(n, dpdu, dpdv, {0, 0.5});
  EXPECT_NEAR(b.z, 0.5 / std::sqrt(1.25), 1e-12);
  // A tangent not orthogonal to n is projected; a degenerate one still gives a unit normal.
  EXPECT_NEAR(dot(perturb_normal(n, {1, 1, 0}, dpdv, {0.5, 0}), a), 1.0, 1e-12);
  EXPECT_NEAR(length(perturb_normal(n, {0, 0, 0}, {0, 0, 0}, {0.3, 0.4})), 1.0, 1e-12);
}

TEST(RenderScene, UnknownSceneAndBadSppAreSettingsErrors) {
  try {
    make_builtin_scene("nope", false);
    FAIL() << "expected SettingsError";
  } catch (const SettingsError& e) {
    EXPECT_NE(std::string(e.what()).find("thin, motion, orbit"), std::string::npos) << e.what();
  }
  EXPECT_THROW(samples_per_axis(63, "spp"), SettingsError);
  EXPECT_THROW(samples_per_axis(0, "spp"), SettingsError);
  EXPECT_EQ(samples_per_axis(64, "spp"), 8);
  EXPECT_EQ(samples_per_axis(1, "spp"), 1);
}

}  // namespace
}  // namespace afterimage::render
