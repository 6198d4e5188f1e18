// PSNR, SSIM (against scikit-image values in tests/data/ssim), the display transform, the pair
// comparison of `afterimage compare` and the JSON form of the results.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "metrics/display.h"
#include "metrics/metrics.h"
#include "metrics/psnr.h"
#include "metrics/ssim.h"
#include "test_util.h"

using namespace afterimage;
using namespace afterimage::metrics;

namespace {

const double kInf = std::numeric_limits<double>::infinity();

// Reads a raw float32 (H, W, C)-interleaved image written by scripts/gen_ssim_testdata.py.
ImageF read_bin(const std::string& path, int w, int h, int c) {
  std::ifstream f(path, std::ios::binary);
  EXPECT_TRUE(f.good()) << path;
  std::vector<float> buf(size_t(w) * h * c);
  f.read(reinterpret_cast<char*>(buf.data()), std::streamsize(buf.size() * sizeof(float)));
  EXPECT_EQ(size_t(f.gcount()), buf.size() * sizeof(float)) << path;
  ImageF img(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k) img.at(x, y, k) = buf[(size_t(y) * w + x) * c + k];
  return img;
}

// ---- PSNR ------------------------------------------------------------------------------

TEST(MetricsPsnr, IdenticalImagesGiveInfinity) {
  const ImageF a = test::random_image(31, 17, 3, 1);
  EXPECT_EQ(psnr(a, a), kInf);
  EXPECT_EQ(psnr_linear_hdr(a, a).psnr, kInf);
  EXPECT_EQ(psnr_from_mse(0.0), kInf);
}

TEST(MetricsPsnr, PlusMinusDeltaPatternGivesMseDeltaSquared) {
  // Dyadic values keep a +- delta exact in float, so the MSE is exactly delta^2.
  const float delta = 1.0f / 64.0f;
  ImageF a(33, 21, 3), b(33, 21, 3);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < a.height(); ++y)
      for (int x = 0; x < a.width(); ++x) {
        a.at(x, y, c) = float(64 + (x * 5 + y * 3 + c) % 128) / 256.0f;
        b.at(x, y, c) = a.at(x, y, c) + (((x + y + c) & 1) ? delta : -delta);
      }
  EXPECT_DOUBLE_EQ(mean_squared_error(a, b), double(delta) * delta);
  EXPECT_NEAR(psnr(a, b), 10.0 * std::log10(1.0 / (double(delta) * delta)), 1e-9);
  EXPECT_NEAR(psnr(a, b), 36.123599479677743, 1e-9);  // 20 log10(64)

  // Linear HDR: the peak is the maximum of the reference.
  ImageF ref = a, test = b;
  ref.at(3, 4, 1) = 4.0f;
  test.at(3, 4, 1) = 4.0f;
  const LinearPsnr lin = psnr_linear_hdr(ref, test);
  EXPECT_EQ(lin.peak, 4.0);
  // One pixel-channel of 33*21*3 has no error now.
  const double mse = double(delta) * delta * (33.0 * 21 * 3 - 1) / (33.0 * 21 * 3);
  EXPECT_NEAR(lin.psnr, 10.0 * std::log10(16.0 / mse), 1e-9);
}

TEST(MetricsPsnr, MismatchedShapesThrowInputError) {
  EXPECT_THROW(psnr(ImageF(4, 4, 3), ImageF(5, 4, 3)), InputError);
  EXPECT_THROW(psnr(ImageF(4, 4, 3), ImageF(4, 4, 1)), InputError);
}

// ---- SSIM ------------------------------------------------------------------------------

TEST(SsimReference, MatchesScikitImageOnStoredCases) {
  const std::string dir = std::string(AFTERIMAGE_TESTDATA_DIR) + "/ssim/";
  std::ifstream f(dir + "expected.json");
  ASSERT_TRUE(f.good()) << "run scripts/gen_ssim_testdata.py";
  const nlohmann::json meta = nlohmann::json::parse(f);
  ASSERT_GE(meta["cases"].size(), 5u);
  for (const auto& c : meta["cases"]) {
    const int w = c["width"], h = c["height"], ch = c["channels"];
    const ImageF a = read_bin(dir + c["a"].get<std::string>(), w, h, ch);
    const ImageF b = read_bin(dir + c["b"].get<std::string>(), w, h, ch);
    const double ours = ch == 1 ? ssim(view(a, 0), view(b, 0)) : ssim_channels(a, b);
    EXPECT_NEAR(ours, c["ssim"].get<double>(), 1e-4) << c["name"];
    // We compute in double like scikit-image; the match is in fact much tighter.
    EXPECT_NEAR(ours, c["ssim"].get<double>(), 1e-9) << c["name"];
  }
}

TEST(SsimBasics, IdenticalIsOneAndDifferentIsLess) {
  const ImageF a = test::random_image(23, 19, 3, 2);
  EXPECT_DOUBLE_EQ(ssim_channels(a, a), 1.0);
  const ImageF b = test::random_image(23, 19, 3, 3);
  EXPECT_LT(ssim_channels(a, b), 0.5);
}

TEST(SsimBasics, MeanIsTheMapAveragedAwayFromTheBorder) {
  const ImageF a = test::random_image(29, 25, 1, 4), b = test::random_image(29, 25, 1, 5);
  const ImageF map = ssim_map(view(a, 0), view(b, 0));
  const int r = SsimSettings{}.radius();
  ASSERT_EQ(r, 5);
  double sum = 0.0;
  for (int y = r; y < a.height() - r; ++y)
    for (int x = r; x < a.width() - r; ++x) sum += map.at(x, y, 0);
  EXPECT_NEAR(sum / ((29 - 2 * r) * (25 - 2 * r)), ssim(view(a, 0), view(b, 0)), 1e-6);
}

TEST(SsimBasics, TooSmallForTheWindowThrows) {
  const ImageF a(10, 40, 1);
  EXPECT_THROW(ssim(view(a, 0), view(a, 0)), InputError);
}

TEST(SsimBasics, BitIdenticalForAnyThreadCountAndLaneWidth) {
  // 71 columns with 4 double lanes (AVX2): 8 two-vector blocks, a one-vector block and 3
  // single lanes in a row, and a last 32-column strip of 7 (one vector, 3 lanes); 45 rows: a
  // partial 16-row band.
  const ImageF a = test::random_image(71, 45, 3, 6), b = test::random_image(71, 45, 3, 7);
  Exec one, two, scalar;
  one.threads = 1;
  two.threads = 2;
  scalar.simd = false;
  EXPECT_EQ(ssim_channels(a, b, {}, one), ssim_channels(a, b, {}, two));
  EXPECT_EQ(ssim_channels(a, b, {}, scalar), ssim_channels(a, b, {}, two));
  EXPECT_TRUE(ssim_map(view(a, 1), view(b, 1), {}, one) ==
              ssim_map(view(a, 1), view(b, 1), {}, two));
  EXPECT_TRUE(ssim_map(view(a, 1), view(b, 1), {}, scalar) ==
              ssim_map(view(a, 1), view(b, 1), {}, two));
}

// ---- Display transform ----------------------------------------------------------------

TEST(MetricsDisplay, TonemapThenSrgbEncode) {
  DisplaySettings s;
  EXPECT_FLOAT_EQ(display_value(1.0f, s), srgb_encode(0.5f));  // Reinhard: 1 -> 1/2
  EXPECT_FLOAT_EQ(display_value(0.0f, s), 0.0f);
  EXPECT_LT(display_value(1e6f, s), 1.0f + 1e-6f);
  s.tonemap = false;  // display-referred input: only the sRGB encoding
  EXPECT_FLOAT_EQ(display_value(srgb_decode(0.25f), s), 0.25f);
  s.exposure = 0.0f;
  EXPECT_THROW(s.validate(), SettingsError);
}

// ---- Pair comparison and JSON ----------------------------------------------------------

TEST(MetricsCompare, IdenticalPairIsPerfectInBothRanges) {
  const ImageF a = test::random_image(40, 30, 3, 8, 0.0f, 3.0f);
  for (DynamicRange r : {DynamicRange::kLdr, DynamicRange::kHdr}) {
    const PairMetrics m = compare_images(a, a, r);
    EXPECT_EQ(m.psnr, kInf);
    EXPECT_EQ(m.psnr_luma, kInf);
    EXPECT_EQ(m.psnr_linear, kInf);
    EXPECT_DOUBLE_EQ(m.ssim, 1.0);
    EXPECT_DOUBLE_EQ(m.ssim_luma, 1.0);
    EXPECT_EQ(m.flip.mean, 0.0);
    const nlohmann::json j = m;
    EXPECT_EQ(j["psnr"], "inf");
    EXPECT_EQ(j["flip_mode"], r == DynamicRange::kHdr ? "HDR-FLIP" : "LDR-FLIP");
  }
}

TEST(MetricsCompare, NoisierTestScoresWorse) {
  const ImageF ref = test::random_image(40, 30, 3, 9, 0.1f, 0.9f);
  ImageF small = ref, large = ref;
  std::mt19937 rng(10);
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (size_t i = 0; i < ref.data().size(); ++i) {
    const float e = n(rng);
    small.data()[i] += 0.01f * e;
    large.data()[i] += 0.05f * e;
  }
  const PairMetrics a = compare_images(ref, small, DynamicRange::kLdr);
  const PairMetrics b = compare_images(ref, large, DynamicRange::kLdr);
  EXPECT_GT(a.psnr, b.psnr);
  EXPECT_GT(a.psnr_linear, b.psnr_linear);
  EXPECT_GT(a.ssim, b.ssim);
  EXPECT_LT(a.flip.mean, b.flip.mean);
  EXPECT_NE(format_pair_metrics(a).find("LDR-FLIP"), std::string::npos);
}

TEST(MetricsJson, InfinityAndNanAreSpelledOut) {
  EXPECT_EQ(json_number(kInf), "inf");
  EXPECT_EQ(json_number(-kInf), "-inf");
  EXPECT_TRUE(json_number(std::nan("")).is_null());
  EXPECT_EQ(json_number(0.25).get<double>(), 0.25);
  FrameMetrics f;
  f.psnr = kInf;
  f.temporal_error = std::nan("");
  const nlohmann::json j = f;
  EXPECT_EQ(j["psnr"], "inf");
  EXPECT_TRUE(j["temporal_error"].is_null());
  EXPECT_EQ(j.dump().find("nan"), std::string::npos);
}

}  // namespace
