// Temporal error, disocclusion masks and ages, the ghosting curve, sharpness, and the
// per-frame / aggregate sequence metrics.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "metrics/metrics.h"
#include "metrics/temporal.h"
#include "test_util.h"

using namespace afterimage;
using namespace afterimage::metrics;

namespace {

// A moving pattern: frame t is a sinusoid shifted by 2t pixels, values in [0.1, 2.1] (HDR).
std::vector<ImageF> moving_sequence(int frames, int w = 41, int h = 27) {
  std::vector<ImageF> seq;
  for (int t = 0; t < frames; ++t) {
    ImageF img(w, h, 3);
    for (int c = 0; c < 3; ++c)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          img.at(x, y, c) = 1.1f + std::sin(0.4f * float(x - 2 * t) + 0.3f * y + float(c));
    seq.push_back(img);
  }
  return seq;
}

// The sequence one frame late: frame t shows frame t - 1 (frame 0 itself).
std::vector<ImageF> one_frame_late(const std::vector<ImageF>& seq) {
  std::vector<ImageF> late{seq[0]};
  for (size_t t = 1; t < seq.size(); ++t) late.push_back(seq[t - 1]);
  return late;
}

// ---- Lag after a step ------------------------------------------------------------------

TEST(MetricsLag, DisplayErrorIsTheMeanDisplayDifference) {
  ImageF a(4, 3, 3, 1.0f), b(4, 3, 3, 3.0f);  // Reinhard: 0.5 and 0.75 before sRGB
  const double want = double(srgb_encode(0.75f)) - double(srgb_encode(0.5f));
  EXPECT_NEAR(display_error_frame(a, b), want, 1e-7);
  EXPECT_EQ(display_error_frame(a, a), 0.0);
  const std::vector<double> e = display_error_per_frame({a, a}, {b, a});
  ASSERT_EQ(e.size(), 2u);
  EXPECT_NEAR(e[0], want, 1e-7);
  EXPECT_THROW(display_error_per_frame({a}, {a, a}), InputError);
}

TEST(MetricsLag, ExponentialApproachClosedForm) {
  // A step at frame 5 followed by an error decaying as 0.1 * 0.5^k above a floor of 0.01: the
  // error is within 1.2 x 0.01 when 0.1 * 0.5^k <= 0.002, k >= log2(50) = 5.64, so lag 6.
  std::vector<double> e(5, 0.01);
  for (int k = 0; k < 25; ++k) e.push_back(0.01 + 0.1 * std::pow(0.5, k));
  const double steady =
      0.01 +
      0.1 * (std::pow(0.5, 21) + std::pow(0.5, 22) + std::pow(0.5, 23) + std::pow(0.5, 24)) / 4;
  EXPECT_GT(1.2 * steady, 0.012);
  EXPECT_EQ(lag_frames(e, 5), 6);
  EXPECT_EQ(lag_frames(e, 5, 4, 100.0), 0);  // any error within tolerance: no lag
  // Error stuck high until the last four frames (0.5): the first of them is the lag.
  std::vector<double> late(5, 0.01);
  for (int k = 0; k < 25; ++k) late.push_back(k < 21 ? 1.0 : 0.5);
  EXPECT_EQ(lag_frames(late, 5), 21);
  EXPECT_THROW(lag_frames(e, 28), InputError);
  EXPECT_THROW(lag_frames(e, 5, 4, 0.5), InputError);
}

// ---- Temporal error --------------------------------------------------------------------

TEST(MetricsTemporal, ZeroForEqualSequences) {
  const auto r = moving_sequence(6);
  EXPECT_EQ(temporal_error(r, r, 0), 0.0);
  EXPECT_EQ(temporal_error_frame(r[0], r[1], r[0], r[1]), 0.0);
}

TEST(MetricsTemporal, PositiveForOneFrameLaggedCopy) {
  const auto r = moving_sequence(6);
  const std::vector<ImageF> lagged = one_frame_late(r);
  EXPECT_GT(temporal_error(lagged, r, 0), 0.01);
  // Frame 1 of the lagged copy does not change at all: e(1) is the mean |R_1 - R_0|.
  EXPECT_GT(temporal_error(lagged, r, 1), 0.01);
}

TEST(MetricsTemporal, FlickerIsPenalisedButAConstantDisplayOffsetIsNot) {
  const auto r = moving_sequence(5);
  std::vector<ImageF> flicker;
  for (size_t t = 0; t < r.size(); ++t) {
    ImageF f = r[t];
    for (float& v : f.data()) v *= (t % 2) ? 1.2f : 0.8f;
    flicker.push_back(f);
  }
  EXPECT_GT(temporal_error(flicker, r, 0), 0.02);
  // e(t) only sees changes: a display-space offset that does not change is free.
  ImageF r0(8, 8, 3, 0.25f), r1(8, 8, 3, 0.5f), o0(8, 8, 3, 0.375f), o1(8, 8, 3, 0.625f);
  EXPECT_EQ(temporal_error_frame(o0, o1, r0, r1), 0.0);
}

TEST(MetricsTemporal, WarmupExcludesEarlyFramesAndAllWarmupIsNaN) {
  auto r = moving_sequence(4);
  auto o = r;
  for (float& v : o[1].data()) v += 0.5f;  // only pairs (0,1) and (1,2) see this frame
  EXPECT_GT(temporal_error(o, r, 0), 0.0);
  EXPECT_EQ(temporal_error(o, r, 2), 0.0);  // only the pair (2, 3)
  EXPECT_TRUE(std::isnan(temporal_error(o, r, 3)));
  EXPECT_THROW(temporal_error(o, std::vector<ImageF>(r.begin(), r.end() - 1), 0), InputError);
}

// ---- Disocclusion masks ----------------------------------------------------------------

struct GBuffer {
  ImageF depth, motion;
  ImageU32 id;
};

// A square (id 7, depth 5) at x in [x0, x0 + 8), y in [6, 14) on a background (id 0, depth
// 1e10); the square moved right by `dx` since the previous frame (its motion is (-dx, 0)).
GBuffer square_frame(int w, int h, int x0, int dx) {
  GBuffer g{ImageF(w, h, 1, 1e10f), ImageF(w, h, 2, 0.0f), ImageU32(w, h, 1, 0)};
  for (int y = 6; y < 14; ++y)
    for (int x = x0; x < x0 + 8 && x < w; ++x) {
      g.depth.at(x, y, 0) = 5.0f;
      g.id.at(x, y, 0) = 7;
      g.motion.at(x, y, 0) = float(-dx);
    }
  return g;
}

TEST(MetricsDisocclusion, UncoveredBackgroundIsDisoccludedAndTheMovingSquareIsNot) {
  const int w = 32, h = 20;
  const GBuffer prev = square_frame(w, h, 10, 0), cur = square_frame(w, h, 13, 3);
  const Mask m = disocclusion_mask(cur.depth, cur.id, cur.motion, prev.depth, prev.id);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool uncovered = y >= 6 && y < 14 && x >= 10 && x < 13;
      EXPECT_EQ(m.at(x, y, 0), uncovered ? 1 : 0) << x << "," << y;
    }
}

TEST(MetricsDisocclusion, OffScreenHistoryAndDepthJumpsAreDisoccluded) {
  const int w = 16, h = 8;
  GBuffer g = square_frame(w, h, 100, 0);  // background only
  g.motion.at(0, 3, 0) = -1.0f;            // history at x = -0.5: off screen
  g.motion.at(15, 3, 0) = 0.6f;            // history at x = 16.1: off screen
  g.motion.at(5, 3, 1) = std::numeric_limits<float>::quiet_NaN();
  ImageF prev_depth = g.depth;
  prev_depth.at(8, 4, 0) = 1e9f;      // same id, depth differs by 90%
  prev_depth.at(9, 4, 0) = 0.95e10f;  // 5%: within the 10% tolerance
  const Mask m = disocclusion_mask(g.depth, g.id, g.motion, prev_depth, g.id);
  EXPECT_EQ(m.at(0, 3, 0), 1);
  EXPECT_EQ(m.at(15, 3, 0), 1);
  EXPECT_EQ(m.at(5, 3, 0), 1);
  EXPECT_EQ(m.at(8, 4, 0), 1);
  EXPECT_EQ(m.at(9, 4, 0), 0);
  EXPECT_EQ(m.at(1, 3, 0), 0);
}

// ---- Disocclusion age and ghosting -----------------------------------------------------

TEST(MetricsGhosting, AgeFollowsMotionVectors) {
  // A single disoccluded pixel at frame 0, then the content moves right 1 px per frame
  // (motion (-1, 0) everywhere): its age must follow it.
  const int w = 20, h = 3;
  ImageF motion(w, h, 2, 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) motion.at(x, y, 0) = -1.0f;
  DisocclusionAge age(8);
  Mask first(w, h, 1, 0);
  first.at(4, 1, 0) = 1;
  age.update(first, &motion);
  EXPECT_EQ(age.age().at(4, 1, 0), 1);
  const Mask none(w, h, 1, 0);
  for (int k = 2; k <= 9; ++k) {
    age.update(none, &motion);
    const int expect = k <= 8 ? k : 0;  // older than max_age -> 0
    EXPECT_EQ(age.age().at(4 + k - 1, 1, 0), expect) << "k=" << k;
    EXPECT_EQ(age.age().at(4, 1, 0), 0);  // the pixel it left carries nothing
  }
}

TEST(MetricsGhosting, CurveOnASyntheticTrailDecaysAsConstructed) {
  // Static screen. At frame t column t is disoccluded; the output's error at a pixel
  // disoccluded k frames ago (age k) is 0.5^k in display units, elsewhere 0. The curve must
  // return exactly err(k) = 0.5^k.
  const int w = 24, h = 5, frames = 20;
  DisocclusionAge age(8);
  GhostingAccumulator acc(8);
  for (int t = 0; t < frames; ++t) {
    Mask m(w, h, 1, 0);
    for (int y = 0; y < h; ++y) m.at(t % w, y, 0) = 1;
    age.update(m);
    ImageF ref(w, h, 3, 0.25f), out(w, h, 3, 0.25f);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int a = age.age().at(x, y, 0);
        if (a > 0)
          for (int c = 0; c < 3; ++c) out.at(x, y, c) = 0.25f + std::ldexp(1.0f, -a);
      }
    acc.add(out, ref, age.age());
  }
  const GhostingCurve c = acc.curve();
  ASSERT_EQ(c.error.size(), 8u);
  for (int k = 1; k <= 8; ++k) {
    EXPECT_NEAR(c.error[size_t(k - 1)], std::ldexp(1.0, -k), 1e-12) << "k=" << k;
    EXPECT_EQ(c.samples[size_t(k - 1)], uint64_t(h) * uint64_t(frames - k + 1)) << "k=" << k;
  }
}

TEST(MetricsGhosting, LinearSequenceWrapperDecaysAndCountsOnlyAfterWarmup) {
  const int w = 16, h = 4, frames = 12;
  std::vector<ImageF> out, ref;
  std::vector<Mask> masks;
  for (int t = 0; t < frames; ++t) {
    Mask m(w, h, 1, 0);
    for (int y = 0; y < h; ++y) m.at(t, y, 0) = 1;
    masks.push_back(m);
    ImageF r(w, h, 3, 0.5f), o(w, h, 3, 0.5f);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x <= t; ++x)
        for (int c = 0; c < 3; ++c) o.at(x, y, c) = 0.5f + 2.0f / float(t - x + 1);  // 1/age
    ref.push_back(r);
    out.push_back(o);
  }
  const GhostingCurve c = ghosting_curve(out, ref, masks, {}, 4);
  for (int k = 2; k <= 8; ++k) EXPECT_LT(c.error[size_t(k - 1)], c.error[size_t(k - 2)]);
  EXPECT_EQ(c.samples[0], uint64_t(h) * (frames - 4));
}

// ---- Sharpness -------------------------------------------------------------------------

TEST(MetricsSharpness, GradientEnergyOfARampAndRatios) {
  ImageF ramp(9, 4, 1);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 9; ++x) ramp.at(x, y, 0) = 0.125f * x;
  EXPECT_DOUBLE_EQ(gradient_energy(view(ramp, 0)), 8.0 * 4 * 0.125 * 0.125);

  const ImageF ref = test::random_image(30, 20, 3, 3);
  ImageF blurred = ref;
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < 20; ++y)
      for (int x = 1; x + 1 < 30; ++x)
        blurred.at(x, y, c) = (ref.at(x - 1, y, c) + ref.at(x, y, c) + ref.at(x + 1, y, c)) / 3.0f;
  EXPECT_DOUBLE_EQ(sharpness_ratio(ref, ref), 1.0);
  EXPECT_LT(sharpness_ratio(blurred, ref), 0.7);
  EXPECT_GT(sharpness_ratio(ref, blurred), 1.4);
  const ImageF flat(30, 20, 3, 0.5f);
  EXPECT_DOUBLE_EQ(sharpness_ratio(flat, flat), 1.0);
  EXPECT_EQ(sharpness_ratio(ref, flat), std::numeric_limits<double>::infinity());
}

// ---- Sequence metrics ------------------------------------------------------------------

TEST(MetricsSequence, IdenticalSequenceIsPerfectAndSerialises) {
  const auto r = moving_sequence(5);
  std::vector<Mask> masks(r.size(), Mask(r[0].width(), r[0].height(), 1, 0));
  masks[2].at(3, 3, 0) = 1;
  MetricsSettings s;
  s.warmup = 1;
  const SequenceMetrics m = evaluate_sequence(r, r, masks, {}, s);
  ASSERT_EQ(m.frames.size(), 5u);
  EXPECT_TRUE(std::isnan(m.frames[0].temporal_error));
  for (const auto& f : m.frames) {
    EXPECT_EQ(f.psnr, std::numeric_limits<double>::infinity());
    EXPECT_DOUBLE_EQ(f.ssim, 1.0);
    EXPECT_EQ(f.flip, 0.0);
    EXPECT_DOUBLE_EQ(f.sharpness, 1.0);
  }
  EXPECT_EQ(m.summary.frames_measured, 4);
  EXPECT_EQ(m.summary.temporal_error, 0.0);
  EXPECT_EQ(m.summary.ghosting.error[0], 0.0);
  EXPECT_TRUE(std::isnan(m.summary.ghosting.error[7]));  // pixel only reached age 3
  const nlohmann::json j = m;
  EXPECT_EQ(j["summary"]["psnr"], "inf");
  EXPECT_EQ(j["frames"].size(), 5u);
  EXPECT_TRUE(j["frames"][0]["temporal_error"].is_null());
  EXPECT_EQ(j["summary"]["ghosting"]["error_by_age"].size(), 8u);
}

// Warm-up frames without output (the demo's SSAA rows) leave every mean and the ghosting
// curve as scoring them would: their masks still age the disocclusions (a column uncovered
// in frames 0..3 is 5..8 frames old after the warm-up of 4).
TEST(MetricsSequence, SkippedWarmupFramesKeepTheMeansAndTheGhosting) {
  const int w = 16, h = 12, frames = 12, warmup = 4;  // h: SSIM's 11x11 window fits
  MetricsSettings s;
  s.warmup = warmup;
  SequenceEvaluator scored(s), skipped(s), blank(s);
  for (int t = 0; t < frames; ++t) {
    Mask m(w, h, 1, 0);
    for (int y = 0; y < h; ++y) m.at(t, y, 0) = 1;
    ImageF r(w, h, 3, 0.5f), o(w, h, 3, 0.5f);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x <= t; ++x)
        for (int c = 0; c < 3; ++c) o.at(x, y, c) = 0.5f + 2.0f / float(t - x + 1);  // 1/age
    scored.add_frame(o, r, &m);
    if (t < warmup) {
      const FrameMetrics& f = skipped.skip_frame(&m);
      EXPECT_TRUE(std::isnan(f.psnr) && std::isnan(f.flip) && std::isnan(f.temporal_error));
      const Mask none(w, h, 1, 0);  // the warm-up's disocclusions left unaged
      blank.skip_frame(&none);
    } else {
      skipped.add_frame(o, r, &m);
      blank.add_frame(o, r, &m);
    }
  }
  const SequenceMetrics a = scored.result(), b = skipped.result();
  EXPECT_EQ(nlohmann::json(a.summary).dump(), nlohmann::json(b.summary).dump());
  EXPECT_TRUE(std::isnan(b.frames[size_t(warmup)].temporal_error));  // its pair lacks a frame
  EXPECT_FALSE(std::isnan(a.frames[size_t(warmup)].temporal_error));
  EXPECT_GT(b.summary.ghosting.samples[4], 0u);  // ages 5..8 come from skipped frames
  EXPECT_NE(nlohmann::json(blank.result().summary).dump(), nlohmann::json(b.summary).dump());
  // A frame that a mean reads cannot be skipped.
  EXPECT_THROW(skipped.skip_frame(), InputError);
}

// Scores against a reference prepared once equal those against the plain reference.
TEST(MetricsSequence, PreparedReferencesScoreAsThePlainOnes) {
  const auto r = moving_sequence(5);
  const std::vector<ImageF> out = one_frame_late(r);
  MetricsSettings s;
  s.warmup = 1;
  SequenceEvaluator plain(s), prepared(s);
  for (size_t t = 0; t < r.size(); ++t) {
    plain.add_frame(out[t], r[t]);
    prepared.add_frame(out[t], prepare_reference(r[t], s));
  }
  const std::string a = nlohmann::json(plain.result()).dump();
  EXPECT_EQ(a, nlohmann::json(prepared.result()).dump());
  EXPECT_NE(a.find("\"flip\""), std::string::npos);
}

TEST(MetricsSequence, LaggedOutputIsWorseAndResultsDoNotDependOnThreads) {
  const auto r = moving_sequence(6);
  const std::vector<ImageF> lagged = one_frame_late(r);
  MetricsSettings s;
  s.warmup = 2;
  Exec one, two;
  one.threads = 1;
  two.threads = 2;
  const SequenceMetrics a = evaluate_sequence(lagged, r, {}, {}, s, one);
  const SequenceMetrics b = evaluate_sequence(lagged, r, {}, {}, s, two);
  EXPECT_GT(a.summary.temporal_error, 0.0);
  EXPECT_LT(a.summary.psnr, 40.0);
  EXPECT_GT(a.summary.flip, 0.0);
  EXPECT_TRUE(a.summary.ghosting.error.empty());
  EXPECT_EQ(nlohmann::json(a).dump(), nlohmann::json(b).dump());
  s.warmup = -1;
  EXPECT_THROW(evaluate_sequence(lagged, r, {}, {}, s), SettingsError);
}

}  // namespace
