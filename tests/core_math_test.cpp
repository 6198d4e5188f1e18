#include <gtest/gtest.h>

#include <random>

#include "core/color.h"
#include "core/math.h"

using namespace afterimage;

TEST(Math, InverseTimesMatrixIsIdentity) {
  Mat4 m = translate({1, 2, 3}) * rotate_axis({0.3, 1, 0.2}, 0.7) * scale({2, 0.5, 3});
  Mat4 r = m * m.inverse();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(r.m[i][j], i == j ? 1.0 : 0.0, 1e-12);
}

TEST(Math, LookAtMapsTargetOntoMinusZ) {
  Mat4 v = look_at({3, 2, 5}, {0, 1, 0}, {0, 1, 0});
  Vec3d t = v.transform_point({0, 1, 0});
  EXPECT_NEAR(t.x, 0, 1e-12);
  EXPECT_NEAR(t.y, 0, 1e-12);
  EXPECT_LT(t.z, 0);
  EXPECT_NEAR(-t.z, std::sqrt(9.0 + 1.0 + 25.0), 1e-12);
}

TEST(Math, SlerpHalfwayIsHalfAngle) {
  Quat a = Quat::from_axis_angle({0, 1, 0}, 0.0), b = Quat::from_axis_angle({0, 1, 0}, 1.2);
  Mat4 m = slerp(a, b, 0.5).to_matrix();
  Mat4 e = rotate_axis({0, 1, 0}, 0.6);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(m.m[i][j], e.m[i][j], 1e-12);
  Quat back = Quat::from_matrix(e);
  Mat4 m2 = back.to_matrix();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(m2.m[i][j], e.m[i][j], 1e-12);
}

TEST(Color, YCoCgRoundTripIsExactForDyadicValues) {
  // The transform uses only /2 and /4, so dyadic inputs round-trip bit-exactly.
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> u(-4096, 4096);
  for (int i = 0; i < 1000; ++i) {
    Vec3f c(u(rng) / 64.0f, u(rng) / 64.0f, u(rng) / 64.0f);
    EXPECT_EQ(ycocg_to_rgb(rgb_to_ycocg(c)), c);
  }
  // And within float rounding for arbitrary values.
  std::uniform_real_distribution<float> r(0.0f, 100.0f);
  for (int i = 0; i < 1000; ++i) {
    Vec3f c(r(rng), r(rng), r(rng));
    Vec3f b = ycocg_to_rgb(rgb_to_ycocg(c));
    EXPECT_NEAR(b.x, c.x, 1e-5f * 100);
    EXPECT_NEAR(b.y, c.y, 1e-5f * 100);
    EXPECT_NEAR(b.z, c.z, 1e-5f * 100);
  }
  // Y is luma-like: white maps to (1, 0, 0).
  EXPECT_EQ(rgb_to_ycocg({1, 1, 1}), Vec3f(1, 0, 0));
}

TEST(Color, SrgbRoundTripAndKnownValues) {
  EXPECT_NEAR(srgb_encode(0.5f), 0.735357f, 1e-5f);
  EXPECT_NEAR(srgb_decode(0.5f), 0.214041f, 1e-5f);
  for (float v = 0; v <= 1.0f; v += 0.01f) EXPECT_NEAR(srgb_decode(srgb_encode(v)), v, 1e-5f);
  EXPECT_FLOAT_EQ(luminance({1, 1, 1}), 1.0f);
}
