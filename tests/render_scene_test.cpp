// Tests of render/ scene description: animation, camera keyframes, mesh builders, errors.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/error.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "render/scene.h"

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
