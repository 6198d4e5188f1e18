// Motion blur (issue 12): a still scene is unchanged, a uniformly moving textured plane
// matches the box filter along its motion, a moving foreground over a still background does
// not take the background's color inside it nor smear the still background, per-pixel weights
// against McGuire et al. 2012, and determinism.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "core/error.h"
#include "post/motion_blur.h"

namespace afterimage {
namespace {

using post::MotionBlurSettings;

// Vertical stripes of period 12 px (smooth, so a box filter of it is well defined).
float stripes(double x) {
  return 0.5f + 0.4f * float(std::sin(2.0 * kPi * x / 12.0));
}

Frame plane_frame(int w, int h, float motion_x) {
  Frame f = Frame::allocate(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = stripes(x + 0.5);
      f.depth.at(x, y, 0) = 5.0f;
      f.motion.at(x, y, 0) = motion_x;
    }
  return f;
}

TEST(PostMotionBlur, SettingsAndClosedFormWeights) {
  EXPECT_EQ(aggregate_member_count<MotionBlurSettings>(), MotionBlurSettings::params().size());
  MotionBlurSettings s;
  s.samples = 8;
  EXPECT_THROW(s.validate(), SettingsError);
  s = {};
  EXPECT_THROW(s.set_assignment("shutter=2"), SettingsError);
  EXPECT_DOUBLE_EQ(post::cone_weight(1.0, 4.0), 0.75);
  EXPECT_DOUBLE_EQ(post::cone_weight(5.0, 4.0), 0.0);
  EXPECT_DOUBLE_EQ(post::cylinder_weight(3.0, 4.0), 1.0);
  EXPECT_DOUBLE_EQ(post::cylinder_weight(4.0, 4.0), 0.5);
  EXPECT_DOUBLE_EQ(post::cylinder_weight(4.3, 4.0), 0.0);
  EXPECT_DOUBLE_EQ(post::soft_depth_compare(1.0, 2.0, 0.1), 1.0);  // a in front
  EXPECT_DOUBLE_EQ(post::soft_depth_compare(2.0, 1.0, 0.1), 0.0);  // a far behind
  // motion = p_prev - p_curr = -8 px: travel +8 px; a 180-degree shutter sweeps 4 px, half 2.
  const Vec2d v = post::blur_half_vector(-8.0f, 0.0f, 0.5f, 20);
  EXPECT_DOUBLE_EQ(v.x, 2.0);
  EXPECT_DOUBLE_EQ(post::blur_half_vector(-100.0f, 0.0f, 1.0f, 20).x, 20.0);
  EXPECT_DOUBLE_EQ(post::blur_half_vector(std::nanf(""), 0.0f, 1.0f, 20).x, 0.0);
}

TEST(PostMotionBlur, StillSceneIsUnchanged) {
  Frame f = plane_frame(64, 32, 0.0f);
  f.motion.at(10, 10, 0) = 0.4f;  // below half a pixel of blur: still
  EXPECT_EQ(post::motion_blur(f, f.color, {}), f.color);
}

// A plane moving 16 px per frame with the shutter open the whole frame: each pixel averages
// the texture over the 16 px it swept (box filter), checked away from the image borders.
TEST(PostMotionBlur, UniformMotionMatchesTheBoxFilter) {
  const int w = 160, h = 16;
  const Frame f = plane_frame(w, h, -16.0f);
  MotionBlurSettings s;
  s.shutter = 1.0f;
  s.samples = 31;
  const ImageF out = post::motion_blur(f, f.color, s);
  double se = 0, se_none = 0;
  int n = 0;
  for (int x = 32; x < w - 32; ++x) {
    // Box of the swept interval [x + 0.5 - 8, x + 0.5 + 8], integrated in closed form.
    const double a = x + 0.5 - 8.0, b = x + 0.5 + 8.0, k = 2.0 * kPi / 12.0;
    const double box = 0.5 + 0.4 * (std::cos(k * a) - std::cos(k * b)) / (k * (b - a));
    const double e = out.at(x, 8, 0) - box, e0 = f.color.at(x, 8, 0) - box;
    se += e * e;
    se_none += e0 * e0;
    ++n;
  }
  const double psnr = 10 * std::log10(1.0 / (se / n)),
               psnr_none = 10 * std::log10(1.0 / (se_none / n));
  std::printf("uniform 16 px/frame, shutter 1: PSNR vs box filter %.2f dB (unblurred %.2f dB)\n",
              psnr, psnr_none);
  // Measured 33.3 dB: McGuire's weights add cone (triangle) terms to the cylinder (box) ones
  // when both pixels move alike, so the kernel is a little peakier than the box.
  EXPECT_GT(psnr, 31.0);
  EXPECT_GT(psnr, psnr_none + 15.0);
}

// A flat red square moving 12 px/frame right at depth 2 over a still striped background at
// depth 10: the square's interior keeps its color, the still background far from the square
// keeps its own, and the square's color spreads onto the background only along its motion.
TEST(PostMotionBlur, MovingForegroundOverStillBackground) {
  const int w = 128, h = 64;
  Frame f = plane_frame(w, h, 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) f.depth.at(x, y, 0) = 10.0f;
  for (int y = 16; y < 48; ++y)
    for (int x = 40; x < 88; ++x) {
      f.color.at(x, y, 0) = 1.0f;
      f.color.at(x, y, 1) = f.color.at(x, y, 2) = 0.0f;
      f.depth.at(x, y, 0) = 2.0f;
      f.motion.at(x, y, 0) = -12.0f;
    }
  const ImageF out = post::motion_blur(f, f.color, {});  // half-length 3 px
  for (int y = 20; y < 44; ++y)
    for (int x = 40 + 4; x < 88 - 4; ++x) {
      EXPECT_NEAR(out.at(x, y, 0), 1.0f, 1e-5f) << x << "," << y;
      EXPECT_NEAR(out.at(x, y, 1), 0.0f, 1e-5f) << x << "," << y;
    }
  // Background above and below the square (no motion along y): untouched.
  for (int x = 40; x < 88; ++x) {
    EXPECT_EQ(out.at(x, 10, 1), f.color.at(x, 10, 1));
    EXPECT_EQ(out.at(x, 54, 1), f.color.at(x, 54, 1));
  }
  // Beside it along the motion, within the 3 px it sweeps: the square's color (no green)
  // covers part of the background.
  EXPECT_LT(out.at(89, 30, 1), f.color.at(89, 30, 1) - 0.1f);
  EXPECT_LT(out.at(38, 30, 1), f.color.at(38, 30, 1) - 0.1f);
  EXPECT_EQ(out.at(100, 30, 0), f.color.at(100, 30, 0));
}

TEST(PostMotionBlur, DeterministicAcrossThreadsAndRefusesMissingChannels) {
  Frame f = plane_frame(97, 41, -9.0f);
  for (int y = 0; y < 41; ++y) f.motion.at(50, y, 1) = 3.0f;
  EXPECT_EQ(post::motion_blur(f, f.color, {}, Exec{1}), post::motion_blur(f, f.color, {}, Exec{2}));
  Frame g = Frame::allocate(8, 8, ChannelSet{Channel::color});
  EXPECT_THROW(post::motion_blur(g, g.color, {}), InputError);
}

}  // namespace
}  // namespace afterimage
