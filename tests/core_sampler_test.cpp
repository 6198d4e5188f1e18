#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/sampler.h"
#include "test_util.h"

using namespace afterimage;

namespace {
// Odd sizes exercise SIMD tails and borders (OIDN habit); random images are one plane of
// values in [0, 4).
ImageF smooth_image(int w, int h) {
  ImageF img(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      img.at(x, y, 0) = std::sin(0.13f * (x + 0.5f)) * std::cos(0.11f * (y + 0.5f)) + 1.5f;
  return img;
}
}  // namespace

TEST(Sampler, BilinearAtPixelCentersReturnsThePixel) {
  ImageF img = test::random_image(37, 23, 1, 3, 0.0f, 4.0f);
  PlaneView v = view(img, 0);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      EXPECT_EQ(sample_bilinear(v, x + 0.5f, y + 0.5f), img.at(x, y, 0));
      EXPECT_EQ(sample_point(v, x + 0.99f, y + 0.01f), img.at(x, y, 0));
    }
}

TEST(Sampler, BilinearHalfwayIsMean) {
  ImageF img = test::random_image(9, 7, 1, 4, 0.0f, 4.0f);
  PlaneView v = view(img, 0);
  EXPECT_NEAR(sample_bilinear(v, 3.0f, 2.5f), 0.5f * (img.at(2, 2, 0) + img.at(3, 2, 0)), 1e-6f);
}

TEST(Sampler, CatmullRomReproducesLinearRamps) {
  // Catmull-Rom (16- and 9-tap) has linear precision: a ramp a*x + b*y + c is reproduced exactly
  // (interior).
  ImageF img = test::ramp_image(41, 29, 0.25f, -0.5f, 3.0f);
  PlaneView v = view(img, 0);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> ux(3.0f, 37.0f), uy(3.0f, 25.0f);
  for (int i = 0; i < 500; ++i) {
    float x = ux(rng), y = uy(rng);
    float truth = 0.25f * x - 0.5f * y + 3;
    EXPECT_NEAR(sample_catmull_rom_16(v, x, y), truth, 2e-5f);
    EXPECT_NEAR(sample_catmull_rom_9(v, x, y), truth, 2e-5f);
    // The 5-tap version drops the corner taps, so it is only approximately linear-precise:
    // the dropped weights are < 0.6% of the total, here worth < 0.005 on a slope of 0.5/px.
    EXPECT_NEAR(sample_catmull_rom_5(v, x, y), truth, 5e-3f);
  }
}

TEST(Sampler, CatmullRomInterpolatesAtCenters) {
  ImageF img = test::random_image(15, 11, 1, 6, 0.0f, 4.0f);
  PlaneView v = view(img, 0);
  for (int y = 2; y < 9; ++y)
    for (int x = 2; x < 13; ++x)
      EXPECT_NEAR(sample_catmull_rom_16(v, x + 0.5f, y + 0.5f), img.at(x, y, 0), 1e-6f);
}

TEST(Sampler, NineTapEqualsSixteenTapInTheInterior) {
  ImageF img = test::random_image(31, 19, 1, 7, 0.0f, 4.0f);
  PlaneView v = view(img, 0);
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> ux(3.0f, 28.0f), uy(3.0f, 16.0f);
  for (int i = 0; i < 500; ++i) {
    float x = ux(rng), y = uy(rng);
    EXPECT_NEAR(sample_catmull_rom_9(v, x, y), sample_catmull_rom_16(v, x, y), 1e-4f);
  }
}

TEST(Sampler, FiveTapStaysWithinBoundOfSixteenTapOnSmoothImages) {
  // The dropped corner taps carry weight w0*w0 etc. (< 0.0053 of the total); on a smooth image
  // (values ~1.5 +- 1, period ~50 px) the approximation error is far below that.
  ImageF img = smooth_image(64, 48);
  PlaneView v = view(img, 0);
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> ux(3.0f, 61.0f), uy(3.0f, 45.0f);
  float worst = 0;
  for (int i = 0; i < 2000; ++i) {
    float x = ux(rng), y = uy(rng);
    worst =
        std::max(worst, std::abs(sample_catmull_rom_5(v, x, y) - sample_catmull_rom_16(v, x, y)));
  }
  EXPECT_LT(worst, 2e-3f);
  // And it is a real approximation, not the same function: on noise it differs.
  ImageF noise = test::random_image(64, 48, 1, 10, 0.0f, 4.0f);
  PlaneView nv = view(noise, 0);
  float diff = 0;
  for (int i = 0; i < 200; ++i) {
    float x = ux(rng), y = uy(rng);
    diff =
        std::max(diff, std::abs(sample_catmull_rom_5(nv, x, y) - sample_catmull_rom_16(nv, x, y)));
  }
  EXPECT_GT(diff, 1e-3f);
}

// The lane-templated gathers are compared with these per plane in tests/reproject_test.cpp.
