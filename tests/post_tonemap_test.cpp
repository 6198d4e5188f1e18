// Tonemapping (issue 12): each operator against closed-form values, monotonicity, the white
// point, grey staying grey through AgX's inset/outset, the sRGB encoding, and non-finite input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "core/error.h"
#include "post/tonemap.h"

namespace afterimage {
namespace {

using post::TonemapOperator;
using post::TonemapSettings;

TonemapSettings linear_out(TonemapOperator op) {
  TonemapSettings s;
  s.op = op;
  s.srgb = false;
  return s;
}

TEST(Tonemap, SettingsRegisteredAndValidated) {
  EXPECT_EQ(aggregate_member_count<TonemapSettings>(), TonemapSettings::params().size());
  TonemapSettings s;
  EXPECT_THROW(s.set_assignment("exposure=0"), SettingsError);
  EXPECT_THROW(s.set_assignment("operator=filmic"), SettingsError);
  s.set_assignment("operator=agx");
  EXPECT_EQ(s.op, TonemapOperator::AgX);
}

TEST(Tonemap, CurvesMatchTheirClosedForms) {
  EXPECT_FLOAT_EQ(post::reinhard_curve(1.0f), 0.5f);
  EXPECT_FLOAT_EQ(post::reinhard_curve(3.0f), 0.75f);
  // Reinhard et al. 2002 Eq. 4: white maps to exactly 1, x(1 + x/w^2)/(1 + x) below.
  EXPECT_FLOAT_EQ(post::reinhard_extended_curve(4.0f, 4.0f), 1.0f);
  EXPECT_FLOAT_EQ(post::reinhard_extended_curve(1.0f, 4.0f), 1.0f * (1.0f + 1.0f / 16.0f) / 2.0f);
  EXPECT_FLOAT_EQ(post::reinhard_extended_curve(9.0f, 4.0f), 1.0f);
  // Narkowicz's fit at x = 1 (0.6 after pre-exposure): 0.6 (1.506 + 0.03) / (0.6 (1.458 +
  // 0.59) + 0.14).
  const double x = 0.6;
  EXPECT_NEAR(post::aces_fitted_curve(1.0f), x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14),
              1e-6);
  EXPECT_EQ(post::aces_fitted_curve(0.0f), 0.0f);
  EXPECT_EQ(post::aces_fitted_curve(1e4f), 1.0f);  // the fit exceeds 1 far out; clipped
  EXPECT_NEAR(post::agx_curve(0.0f), 0.0f, 1e-6);
  EXPECT_NEAR(post::agx_curve(1.0f), 1.0f, 1e-6);
  EXPECT_NEAR(post::agx_log_encode(0.18f), 10.0f / 16.5f, 1e-6);
}

TEST(Tonemap, EveryOperatorIsMonotoneAndBounded) {
  for (auto op : {TonemapOperator::Reinhard, TonemapOperator::ReinhardExtended,
                  TonemapOperator::AcesFitted, TonemapOperator::AgX, TonemapOperator::Clamp})
    for (bool srgb : {false, true}) {
      TonemapSettings s = linear_out(op);
      s.srgb = srgb;
      float prev = -1.0f;
      for (float v = 0.0f; v < 200.0f; v = v * 1.1f + 0.001f) {
        const Vec3f y = post::tonemap_pixel({v, v, v}, s);
        EXPECT_GE(y.x, prev) << post::to_string(op) << " at " << v;
        EXPECT_GE(y.x, 0.0f);
        EXPECT_LE(y.x, 1.0f);
        // Grey stays grey (AgX's inset rows sum to 1).
        EXPECT_NEAR(y.y, y.x, 1e-5f) << post::to_string(op);
        EXPECT_NEAR(y.z, y.x, 1e-5f) << post::to_string(op);
        prev = y.x;
      }
    }
}

TEST(Tonemap, AgxOutsetInvertsInsetAndDesaturatesBrightColors) {
  const Vec3f c{0.7f, 0.2f, 0.05f};
  const Vec3f r = post::agx_outset(post::agx_inset(c));
  EXPECT_NEAR(r.x, c.x, 1e-6f);
  EXPECT_NEAR(r.y, c.y, 1e-6f);
  EXPECT_NEAR(r.z, c.z, 1e-6f);
  // A very bright pure red goes toward white under AgX, while per-channel Reinhard keeps
  // green and blue at 0 (the hue-skew / clipping AgX avoids).
  const Vec3f agx = post::tonemap_pixel({200.0f, 0.0f, 0.0f}, linear_out(TonemapOperator::AgX));
  const Vec3f rh = post::tonemap_pixel({200.0f, 0.0f, 0.0f}, linear_out(TonemapOperator::Reinhard));
  EXPECT_GT(agx.y, 0.3f);
  EXPECT_EQ(rh.y, 0.0f);
}

TEST(Tonemap, SrgbEncodingAndNonFiniteInput) {
  TonemapSettings s;
  s.op = TonemapOperator::Clamp;
  EXPECT_NEAR(post::tonemap_pixel({0.5f, 1.0f, 0.002f}, s).x, 0.735357f, 1e-5f);
  EXPECT_FLOAT_EQ(post::tonemap_pixel({0.5f, 1.0f, 0.002f}, s).y, 1.0f);
  EXPECT_FLOAT_EQ(post::tonemap_pixel({0.5f, 1.0f, 0.002f}, s).z, 12.92f * 0.002f);
  const float nan = std::numeric_limits<float>::quiet_NaN(),
              inf = std::numeric_limits<float>::infinity();
  for (auto op : {TonemapOperator::Reinhard, TonemapOperator::AcesFitted, TonemapOperator::AgX}) {
    s.op = op;
    const Vec3f y = post::tonemap_pixel({nan, inf, -3.0f}, s);
    EXPECT_EQ(y.x, 0.0f);
    EXPECT_EQ(y.y, 0.0f);
    EXPECT_EQ(y.z, 0.0f);
  }
  // Radiance the exposure takes past the largest float is white, never NaN or black.
  for (auto op : {TonemapOperator::Reinhard, TonemapOperator::ReinhardExtended,
                  TonemapOperator::AcesFitted, TonemapOperator::AgX, TonemapOperator::Clamp}) {
    s.op = op;
    s.exposure = 1e6f;
    const Vec3f y = post::tonemap_pixel({3e38f, 1e30f, 0.0f}, s);
    EXPECT_FLOAT_EQ(y.x, 1.0f) << post::to_string(op);  // the encode's 1.055 - 0.055
    EXPECT_FLOAT_EQ(y.y, 1.0f) << post::to_string(op);
    if (op != TonemapOperator::AgX) {  // AgX mixes the channels
      EXPECT_EQ(y.z, 0.0f) << post::to_string(op);
    }
  }
  s.exposure = 2.0f;
  s.op = TonemapOperator::Reinhard;
  s.srgb = false;
  EXPECT_FLOAT_EQ(post::tonemap_pixel({1.0f, 0.0f, 0.0f}, s).x, 2.0f / 3.0f);
  EXPECT_THROW(post::tonemap(ImageF(4, 4, 1), s), InputError);
  ImageF img(5, 3, 3, 0.25f);
  const ImageF one = post::tonemap(img, s, Exec{1}), two = post::tonemap(img, s, Exec{2});
  EXPECT_EQ(one, two);
  EXPECT_FLOAT_EQ(one.at(4, 2, 1), 0.5f / 1.5f);
}

// The encode's power segment against the power law in double on every float v in
// (0.0031308, 1], in units of the float spacing at the exact value; beside it the form it
// replaced, exp(log(v) / 2.4) through Highway's Exp and Log (post/tonemap.h), whose largest
// error on the same inputs is reported for comparison. Also monotone, and the lanes give the
// one-lane (--simd off) bits.
TEST(PostTonemap, SrgbEncodeIsWithinFourUlpOfThePowerLaw) {
  const FullTag d;
  const size_t n = hn::Lanes(d);
  std::vector<float> v, out(n), old(n);
  for (float x = std::nextafter(0.0031308f, 1.0f); x <= 1.0f; x = std::nextafter(x, 2.0f))
    v.push_back(x);
  while (v.size() % n) v.push_back(1.0f);
  double worst = 0.0, worst_old = 0.0;
  float prev = 0.0f;
  bool monotone = true;
  for (size_t i = 0; i < v.size(); i += n) {
    const V<FullTag> x = hn::LoadU(d, v.data() + i);
    hn::StoreU(post::srgb_encode(d, x), d, out.data());
    const V<FullTag> pw = hn::Exp(d, hn::Mul(hn::Log(d, x), hn::Set(d, 1.0f / 2.4f)));
    hn::StoreU(hn::Sub(hn::Mul(hn::Set(d, 1.055f), pw), hn::Set(d, 0.055f)), d, old.data());
    for (size_t k = 0; k < n; ++k) {
      const double ref = 1.055 * std::pow(double(v[i + k]), 1.0 / 2.4) - 0.055;
      const double ulp = std::nextafter(float(ref), 2.0f) - float(ref);
      worst = std::max(worst, std::abs(out[k] - ref) / ulp);
      worst_old = std::max(worst_old, std::abs(old[k] - ref) / ulp);
      monotone &= out[k] >= prev;
      prev = out[k];
    }
    if (i % (97 * n) == 0)
      for (size_t k = 0; k < n; ++k) {
        const OneTag d1;
        ASSERT_EQ(hn::GetLane(post::srgb_encode(d1, hn::Set(d1, v[i + k]))), out[k]) << v[i + k];
      }
  }
  std::printf("sRGB encode on %zu floats: largest error %.2f ulp (exp/log form %.2f)\n", v.size(),
              worst, worst_old);
  EXPECT_LT(worst, 3.5);  // 3.27 measured (the exp/log form: 9.02)
  EXPECT_LE(worst, worst_old);
  EXPECT_TRUE(monotone);
  // The ends: the linear segment's last value and 1 -> 1.
  const OneTag d1;
  EXPECT_EQ(hn::GetLane(post::srgb_encode(d1, hn::Set(d1, 0.0031308f))), 12.92f * 0.0031308f);
  EXPECT_EQ(hn::GetLane(post::srgb_encode(d1, hn::Set(d1, 1.0f))), 1.055f - 0.055f);
}

}  // namespace
}  // namespace afterimage
