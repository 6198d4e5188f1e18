// The OpenCV multi-frame NLM peer (issue 11): the display round trip, the temporal window at
// the sequence ends, and that it really denoises (a noisy still sequence gets closer to its
// clean image) without erasing an edge.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/error.h"
#include "peers/opencv_nlm.h"

namespace afterimage {
namespace {

using peers::NlmSettings;

TEST(PeersOpencvNlm, DisplayRoundTripIsWithinOneCode) {
  for (float v : {0.0f, 0.01f, 0.18f, 0.5f, 1.0f, 4.0f, 30.0f}) {
    const unsigned char code = peers::display_code(v, 1.0f);
    EXPECT_EQ(peers::display_code(peers::linear_from_code(code, 1.0f), 1.0f), code) << v;
  }
  EXPECT_EQ(peers::display_code(std::nanf(""), 1.0f), 0);
  EXPECT_TRUE(std::isfinite(peers::linear_from_code(255.0f, 1.0f)));
  EXPECT_NEAR(peers::linear_from_code(peers::display_code(2.0f, 0.5f), 0.5f), 2.0f, 0.05f);
}

TEST(PeersOpencvNlm, WindowShrinksAtTheEnds) {
  EXPECT_EQ(peers::nlm_window_at(0, 10, 5), 1);
  EXPECT_EQ(peers::nlm_window_at(1, 10, 5), 3);
  EXPECT_EQ(peers::nlm_window_at(2, 10, 5), 5);
  EXPECT_EQ(peers::nlm_window_at(9, 10, 5), 1);
  EXPECT_EQ(peers::nlm_window_at(0, 1, 5), 1);
  NlmSettings s;
  s.window = 4;
  EXPECT_THROW(s.validate(), SettingsError);
}

double rmse_to(const ImageF& a, float value, int x0, int x1) {
  double sum = 0;
  int n = 0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = x0; x < x1; ++x, ++n)
      for (int c = 0; c < 3; ++c) sum += (a.at(x, y, c) - value) * (a.at(x, y, c) - value);
  return std::sqrt(sum / (3.0 * n));
}

TEST(PeersOpencvNlm, DenoisesAStillSequenceAndKeepsItsEdge) {
  // Left half 0.1, right half 0.8, Gaussian noise of sigma 0.05 per frame.
  const int w = 64, h = 40;
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.0f, 0.05f);
  std::vector<ImageF> seq;
  for (int t = 0; t < 5; ++t) {
    ImageF img(w, h, 3);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c)
          img.at(x, y, c) = std::max(0.0f, (x < w / 2 ? 0.1f : 0.8f) + noise(rng));
    seq.push_back(img);
  }
  Exec ex;
  ex.threads = 1;
  const ImageF out = peers::opencv_nlm_frame(seq, 2, NlmSettings{}, ex);
  for (auto [x0, x1, v] : {std::tuple{2, w / 2 - 6, 0.1f}, std::tuple{w / 2 + 6, w - 2, 0.8f}}) {
    const double before = rmse_to(seq[2], v, x0, x1), after = rmse_to(out, v, x0, x1);
    std::printf("[nlm] flat %.1f: rmse %.4f -> %.4f\n", v, before, after);
    EXPECT_LT(after, 0.5 * before);
  }
  // The edge: the columns next to it keep their sides' values.
  double left = 0, right = 0;
  for (int y = 0; y < h; ++y) {
    left += out.at(w / 2 - 2, y, 1) / h;
    right += out.at(w / 2 + 1, y, 1) / h;
  }
  EXPECT_NEAR(left, 0.1, 0.05);
  EXPECT_NEAR(right, 0.8, 0.1);
  EXPECT_THROW(peers::opencv_nlm_frame(seq, 5, NlmSettings{}, ex), InputError);
  seq[1] = ImageF(w, h + 1, 3);
  EXPECT_THROW(peers::opencv_nlm_frame(seq, 2, NlmSettings{}, ex), InputError);
}

}  // namespace
}  // namespace afterimage
