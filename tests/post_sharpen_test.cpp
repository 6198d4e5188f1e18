// post/sharpen: seed 000 Eq.5 with the overshoot clamped to the 3x3 range.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "core/error.h"
#include "core/simd.h"
#include "post/sharpen.h"
#include "test_util.h"

using namespace afterimage;
using namespace afterimage::post;

namespace {

const OneTag kOne;

ImageF random_rgb(int w, int h, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 4.0f);  // HDR: values above 1 are normal
  ImageF img(w, h, 3);
  for (float& v : img.data()) v = u(rng);
  return img;
}

}  // namespace

TEST(PostSharpen, LaplacianHandValues) {
  auto S = [](float v) { return hn::Set(kOne, v); };
  // c = 2, up 1, down 2, left 2, right 2: 4c - sum = 1; strength .5 -> 2.5 within [0, 4].
  EXPECT_NEAR(hn::GetLane(sharpen_laplacian(kOne, S(2), S(1), S(2), S(2), S(2), 0.5f, S(0), S(4))),
              2.5f, 1e-6f);
  // Overshoot is clamped to the 3x3 max; HDR values are not saturated.
  EXPECT_EQ(hn::GetLane(sharpen_laplacian(kOne, S(5), S(1), S(1), S(1), S(1), 1.0f, S(1), S(5))),
            5.0f);
  // Flat and linear ramps are unchanged.
  EXPECT_NEAR(hn::GetLane(sharpen_laplacian(kOne, S(3), S(2), S(4), S(1), S(5), 1.0f, S(0), S(9))),
              3.0f, 1e-6f);
}

TEST(PostSharpen, ZeroStrengthIsIdentityAndRangeIsChecked) {
  const ImageF img = random_rgb(31, 17, 1);
  EXPECT_EQ(sharpen(img, {}), img);
  EXPECT_THROW(sharpen(img, {-1.0f}), SettingsError);
  EXPECT_THROW(sharpen(img, {5.0f}), SettingsError);
}

TEST(PostSharpen, MatchesEq5InsideAndClampsToTheNeighbourhood) {
  const int w = 257, h = 89;  // odd sizes: SIMD tails and borders
  const ImageF img = random_rgb(w, h, 2);
  const float s = 0.5f;
  const ImageF out = sharpen(img, {s});
  int changed = 0;
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        float lo = 1e30f, hi = -1e30f;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            lo = std::min(lo, img.at_clamped(x + dx, y + dy, c));
            hi = std::max(hi, img.at_clamped(x + dx, y + dy, c));
          }
        const float v = img.at(x, y, c);
        const float lap = 4 * v - img.at_clamped(x, y - 1, c) - img.at_clamped(x, y + 1, c) -
                          img.at_clamped(x - 1, y, c) - img.at_clamped(x + 1, y, c);
        const float want = std::clamp(v + s * lap, lo, hi);
        ASSERT_NEAR(out.at(x, y, c), want, 1e-5f) << x << "," << y;
        ASSERT_GE(out.at(x, y, c), lo);
        ASSERT_LE(out.at(x, y, c), hi);
        changed += out.at(x, y, c) != v;
      }
  EXPECT_GT(changed, w * h);  // it does sharpen
}

TEST(PostSharpen, SimdOffAndAnyThreadCountAreBitIdentical) {
  const ImageF img = random_rgb(123, 45, 3);
  const ImageF a = sharpen(img, {0.7f}, test::scalar_exec());
  for (int threads : {1, 2, 3}) {
    Exec ex;
    ex.threads = threads;
    EXPECT_EQ(sharpen(img, {0.7f}, ex), a) << threads;
  }
}

TEST(PostSharpen, EveryMemberIsRegistered) {
  EXPECT_TRUE(settings::all_members_registered<SharpenSettings>());
  EXPECT_EQ(SharpenSettings::params().keys(), std::vector<std::string>{"sharpen"});
}
