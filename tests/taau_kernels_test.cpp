// TAAU per-pixel kernels against closed-form values (taau/upscale_kernels.h): the splat
// weights, the accumulation rule, and the mapping of low-resolution samples to output pixels
// (DESIGN.md §3 at both resolutions), full-width lanes and 1 lane alike.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "lane_test_util.h"
#include "taau/resample.h"
#include "taau/upscale_kernels.h"

using namespace afterimage;
using namespace afterimage::taau;
using afterimage::test::kFull;
using afterimage::test::kOne;
using afterimage::test::lanes;

namespace {

double sinc(double x) {
  return x == 0 ? 1.0 : std::sin(std::numbers::pi * x) / (std::numbers::pi * x);
}

template <class D>
float lanczos_at(D d, float r, float width) {
  return lanes(d, lanczos2_weight(d, hn::Set(d, r * r), 1.0f / width))[0];
}
template <class D>
float gaussian_at(D d, float r, float sigma) {
  return lanes(d, gaussian_weight(d, hn::Set(d, r * r), 1.0f / (2 * sigma * sigma)))[0];
}

}  // namespace

TEST(TaauKernels, Lanczos2MatchesSincProduct) {
  for (float r : {0.0f, 0.0005f, 0.25f, 0.5f, 0.75f, 1.0f, 1.25f, 1.5f, 1.9f}) {
    const double want = sinc(r) * sinc(r / 2.0);
    EXPECT_NEAR(lanczos_at(kFull, r, 1.0f), want, 2e-6) << "r = " << r;
    EXPECT_NEAR(lanczos_at(kOne, r, 1.0f), want, 2e-6) << "r = " << r;
  }
  // Closed forms: L2(0.5) = (2/pi) (2 sqrt(2)/pi), L2(1) = 0, L2(1.5) = -(2/(3 pi)) (2 sqrt(2)/(3
  // pi)).
  const double pi = std::numbers::pi, s2 = std::numbers::sqrt2;
  EXPECT_NEAR(lanczos_at(kFull, 0.5f, 1.0f), (2 / pi) * (2 * s2 / pi), 2e-6);
  EXPECT_NEAR(lanczos_at(kFull, 1.0f, 1.0f), 0.0, 1e-6);
  EXPECT_NEAR(lanczos_at(kFull, 1.5f, 1.0f), -(2 / (3 * pi)) * (2 * s2 / (3 * pi)), 2e-6);
  EXPECT_EQ(lanczos_at(kFull, 2.0f, 1.0f), 0.0f);
  EXPECT_EQ(lanczos_at(kFull, 3.0f, 1.0f), 0.0f);
  // The width scales the argument: zero crossing at r = width.
  EXPECT_NEAR(lanczos_at(kFull, 1.5f, 1.5f), 0.0, 1e-6);
  EXPECT_NEAR(lanczos_at(kFull, 1.0f, 2.0f), sinc(0.5) * sinc(0.25), 2e-6);
}

TEST(TaauKernels, GaussianWeight) {
  for (float sigma : {0.3f, 0.5f, 1.0f})
    for (float r : {0.0f, 0.3f, 1.0f, 2.0f}) {
      const double want = std::exp(-double(r) * r / (2.0 * sigma * sigma));
      EXPECT_NEAR(gaussian_at(kFull, r, sigma), want, 1e-6 + 1e-5 * want);
      EXPECT_EQ(gaussian_at(kFull, r, sigma), gaussian_at(kOne, r, sigma));
    }
}

TEST(TaauKernels, SampleWeightSelectsKernel) {
  TaauSettings s;
  s.kernel = SplatKernel::Gaussian;
  s.gaussian_sigma = 0.5f;
  EXPECT_FLOAT_EQ(sample_weight_param(s), 2.0f);
  s.kernel = SplatKernel::Lanczos2;
  s.lanczos_width = 0.5f;
  EXPECT_FLOAT_EQ(sample_weight_param(s), 2.0f);
  const float r2 = 0.25f;
  EXPECT_EQ(lanes(kFull, sample_weight(kFull, SplatKernel::Lanczos2, hn::Set(kFull, r2), 1.0f))[0],
            lanes(kFull, lanczos2_weight(kFull, hn::Set(kFull, r2), 1.0f))[0]);
  EXPECT_EQ(lanes(kFull, sample_weight(kFull, SplatKernel::Gaussian, hn::Set(kFull, r2), 2.0f))[0],
            lanes(kFull, gaussian_weight(kFull, hn::Set(kFull, r2), 2.0f))[0]);
}

TEST(TaauKernels, SplatIsTheWeightedMean) {
  const auto d = kFull;
  auto acc = splat_empty(d);
  acc = splat_add(acc, test::set3(d, {1, 2, 3}), hn::Set(d, 0.5f));
  acc = splat_add(acc, test::set3(d, {3, 0, 1}), hn::Set(d, 1.5f));
  EXPECT_FLOAT_EQ(lanes(d, acc.weight)[0], 2.0f);
  const Vec3f c = test::lane0(d, splat_color(d, acc, test::set3(d, {9, 9, 9})));
  test::expect_near3(c, {(0.5f + 4.5f) / 2, 1.0f / 2, (1.5f + 1.5f) / 2}, 1e-6f);
  // No weight: the fallback (the nearest sample).
  const Vec3f f = test::lane0(d, splat_color(d, splat_empty(d), test::set3(d, {9, 8, 7})));
  test::expect_near3(f, {9, 8, 7}, 0);
}

TEST(TaauKernels, AccumulationIsAWeightedRunningMean) {
  const auto d = kFull;
  auto v = [&](float x) { return hn::Set(d, x); };
  // No history: alpha 1; a frame without weight keeps history.
  EXPECT_EQ(lanes(d, alpha_from_weights(d, v(0), v(0.3f)))[0], 1.0f);
  EXPECT_EQ(lanes(d, alpha_from_weights(d, v(0), v(0)))[0], 1.0f);
  EXPECT_EQ(lanes(d, alpha_from_weights(d, v(2), v(0)))[0], 0.0f);
  EXPECT_FLOAT_EQ(lanes(d, alpha_from_weights(d, v(3), v(1)))[0], 0.25f);
  EXPECT_FLOAT_EQ(lanes(d, accumulated_weight(d, v(3), v(1), 8.0f))[0], 4.0f);
  EXPECT_FLOAT_EQ(lanes(d, accumulated_weight(d, v(7.5f), v(1), 8.0f))[0], 8.0f);
  // Samples x_k with weights w_k: the running mean equals sum w x / sum w (cap not reached).
  const float xs[4] = {1, 5, 2, 8}, ws[4] = {0.5f, 0.25f, 1.0f, 0.75f};
  float mean = 0, n = 0, num = 0, den = 0;
  for (int k = 0; k < 4; ++k) {
    const float a = lanes(d, alpha_from_weights(d, v(n), v(ws[k])))[0];
    mean = mean + a * (xs[k] - mean);
    n = lanes(d, accumulated_weight(d, v(n), v(ws[k]), 100.0f))[0];
    num += ws[k] * xs[k];
    den += ws[k];
  }
  EXPECT_NEAR(mean, num / den, 1e-5);
}

// Convention check in closed form: at scale 2 the input pixel i covers output [2i, 2i + 2),
// so its unjittered sample (center i + 0.5) lands on the output edge 2i + 1 between pixels 2i
// and 2i + 1; jitter (in input pixels) moves it by 2 * jitter output pixels.
TEST(TaauKernels, SampleToOutputMappingClosedForm) {
  const Vec2f s2{2, 2};
  Vec2f p = sample_position_in_output(0, 0, {0, 0}, s2);
  EXPECT_EQ(p.x, 1.0f);
  EXPECT_EQ(p.y, 1.0f);
  p = sample_position_in_output(3, 1, {0.25f, -0.5f}, s2);
  EXPECT_EQ(p.x, 7.5f);  // (3 + 0.5 + 0.25) * 2
  EXPECT_EQ(p.y, 2.0f);  // (1 + 0.5 - 0.5) * 2
  // 1.5x: input center 1.5 -> 2.25; output center 2.5 -> input 2.5 / 1.5.
  p = sample_position_in_output(1, 1, {0, 0}, {1.5f, 1.5f});
  EXPECT_FLOAT_EQ(p.x, 2.25f);
  const Vec2f q = output_center_in_input(2, 0, {1 / 1.5f, 1 / 1.5f});
  EXPECT_FLOAT_EQ(q.x, 2.5f / 1.5f);
  EXPECT_FLOAT_EQ(q.y, 0.5f / 1.5f);
  // Output pixel 0 at 2x: center 0.5 -> input 0.25. With jitter +0.4 sample 0 sits at 0.9
  // and sample -1 (at -0.1, outside) would be nearer: the index is clamped to 0.
  EXPECT_EQ(nearest_sample_index(0.25f, 0.0f, 10), 0);
  EXPECT_EQ(nearest_sample_index(0.25f, 0.4f, 10), 0);
  EXPECT_EQ(nearest_sample_index(1.95f, 0.4f, 10), 1);   // sample 1 at 1.9
  EXPECT_EQ(nearest_sample_index(1.95f, -0.4f, 10), 2);  // sample 2 at 2.1
  EXPECT_EQ(nearest_sample_index(12.0f, 0.0f, 10), 9);
  // Motion in input pixels becomes motion * scale in output pixels.
  const Vec2f m = motion_in_output({-1.5f, 0.25f}, {2.0f, 1.5f});
  EXPECT_EQ(m.x, -3.0f);
  EXPECT_EQ(m.y, 0.375f);
}

// The nearest sample is within half an input pixel of any position (per axis), for any
// jitter in [-0.5, 0.5] away from the clamped borders.
TEST(TaauKernels, NearestSampleIsWithinHalfAPixel) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> jit(-0.5f, 0.5f), pos(1.0f, 99.0f);
  for (int k = 0; k < 10000; ++k) {
    const float q = pos(rng), j = jit(rng);
    const int i = nearest_sample_index(q, j, 100);
    EXPECT_LE(std::abs(float(i) + 0.5f + j - q), 0.5f + 1e-5f) << q << " " << j;
  }
}

TEST(TaauKernels, ResampleKernelsAndLinearPrecision) {
  EXPECT_EQ(catmull_rom_kernel(0), 1.0);
  EXPECT_EQ(catmull_rom_kernel(1), 0.0);
  EXPECT_EQ(catmull_rom_kernel(2), 0.0);
  EXPECT_NEAR(catmull_rom_kernel(0.5), 0.5625, 1e-12);
  EXPECT_EQ(lanczos3_kernel(0), 1.0);
  EXPECT_NEAR(lanczos3_kernel(1), 0.0, 1e-12);
  EXPECT_NEAR(lanczos3_kernel(0.5), sinc(0.5) * sinc(0.5 / 3), 1e-12);
  // A ramp in x (positive) upscaled 2x: interior output pixels reproduce the ramp at their
  // centers mapped to the input (X + 0.5) / 2 (Catmull-Rom exactly; Lanczos-3 is not
  // linear-precise: within 2% of the slope).
  ImageF in(16, 4, 1);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 16; ++x) in.at(x, y, 0) = 1.0f + 0.25f * (x + 0.5f);
  for (ResampleFilter f : {ResampleFilter::CatmullRom, ResampleFilter::Lanczos3}) {
    const ImageF out = resample_image(in, 32, 8, f);
    for (int x = 8; x < 24; ++x)
      EXPECT_NEAR(out.at(x, 3, 0), 1.0f + 0.25f * ((x + 0.5f) / 2.0f),
                  f == ResampleFilter::Lanczos3 ? 1e-2 : 1e-5)
          << x;
  }
}
