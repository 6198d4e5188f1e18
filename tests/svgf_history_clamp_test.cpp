// SVGF history quality options (svgf/history_clamp.h): the fast-history box clamp against a
// closed form, the ghost it removes after a step change (faster than plain accumulation), the
// rank clamp on a firefly and on smooth gradients, the seconds conversion at 30 fps against
// the frame-based alpha, options that change nothing leave the output bit-identical, the passes
// equal to their plain versions (svgf/reference.h) bit for bit, thread / SIMD independence with
// every option on, and the state round trip with the fast history.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <utility>
#include <vector>

#include "core/error.h"
#include "svgf/denoiser.h"
#include "svgf/history_clamp.h"
#include "svgf/reference.h"
#include "test_util.h"

namespace afterimage::svgf {
namespace {

using test::moving_square_frame;

std::vector<ImageF> run(const SvgfSettings& s, const std::vector<Frame>& seq, Exec ex = {}) {
  SvgfDenoiser den(s, ex);
  std::vector<ImageF> out;
  for (const Frame& f : seq) out.push_back(den.process(f).color);
  return out;
}

TEST(SvgfHistoryClamp, FastBoxClampMatchesTheClosedForm) {
  // Fast history plane 0 a 0/1 checkerboard, plane 1 constant 2, plane 2 a ramp; the long
  // history 10 everywhere, this frame 0.5, alpha 0.25. At an interior pixel with x + y even
  // (a 0) the 3x3 window holds four 1s and five 0s: mean 4/9, population sd sqrt(20)/9, so the
  // long history becomes 4/9 + sigma sqrt(20)/9 and the blend lerp(that, 0.5, 0.25). Every pixel is
  // also checked against a double-precision loop with the window clamped to the edge.
  const int w = 7, h = 5;
  const float sigma = 1.5f, alpha = 0.25f, cur = 0.5f, hist = 10.0f;
  ImageF fast(w, h, 3), long_prev(w, h, 3, hist), a(w, h, 1, alpha), acc(w, h, 3, cur);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      fast.at(x, y, 0) = float((x + y) % 2);
      fast.at(x, y, 1) = 2.0f;
      fast.at(x, y, 2) = 0.1f * float(x);
    }
  a.at(6, 4, 0) = 1.0f;          // no history: this frame's value exactly
  long_prev.at(1, 1, 2) = 0.1f;  // inside its box: left as is
  clamp_history_to_fast_box(fast, long_prev, a, sigma, 1, acc);

  const double box_hi = 4.0 / 9.0 + sigma * std::sqrt(20.0) / 9.0;
  EXPECT_NEAR(acc.at(3, 1, 0), box_hi + 0.25 * (0.5 - box_hi), 1e-6);
  EXPECT_NEAR(acc.at(3, 1, 1), 2.0 + 0.25 * (0.5 - 2.0), 1e-6);
  EXPECT_NEAR(acc.at(1, 1, 2), 0.1 + 0.25 * (0.5 - 0.1), 1e-6);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(acc.at(6, 4, c), cur);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        if (x == 6 && y == 4) continue;
        double m = 0, v = 0;
        for (int pass = 0; pass < 2; ++pass)
          for (int j = -1; j <= 1; ++j)
            for (int i = -1; i <= 1; ++i) {
              const double f = fast.at(std::clamp(x + i, 0, w - 1), std::clamp(y + j, 0, h - 1), c);
              if (pass == 0)
                m += f / 9.0;
              else
                v += (f - m) * (f - m) / 9.0;
            }
        const double sd = std::sqrt(v);
        const double p = std::clamp(double(long_prev.at(x, y, c)), m - sigma * sd, m + sigma * sd);
        EXPECT_NEAR(acc.at(x, y, c), p + alpha * (cur - p), 1e-5) << x << "," << y << "," << c;
      }
}

// A static plane whose color steps from `before` to `after` at frame `switch_at` (a light
// turned down), with uniform noise of +-5%.
Frame step_frame(int w, int h, int t, int switch_at, float before, float after) {
  Frame f = moving_square_frame(w, h, t, 0, 0, 0.0f);
  std::mt19937 rng(5 + unsigned(t));
  std::uniform_real_distribution<float> u(-0.05f, 0.05f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        f.color.at(x, y, c) = (t < switch_at ? before : after) * (1.0f + u(rng));
  return f;
}

TEST(SvgfHistoryClamp, FastClampRemovesAGhostFasterThanPlainAccumulation) {
  // After the step the long history (alpha 0.1) lags; the fast history (alpha 0.5) follows
  // within a few frames and its box pulls the long one along. Lag = frames after the step until
  // the mean output is within 5% of the new level: with the clamp at most half of without.
  const int w = 32, h = 24, switch_at = 12, frames = 40;
  auto lag = [&](bool clamp) {
    SvgfSettings s;
    s.alpha_min = 0.1f;
    s.moments_alpha_min = 0.1f;
    s.fast_history_clamp = clamp;
    SvgfDenoiser den(s);
    for (int t = 0; t < frames; ++t) {
      const Frame out = den.process(step_frame(w, h, t, switch_at, 1.0f, 0.2f));
      double mean = 0;
      for (float v : out.color.data()) mean += v;
      mean /= double(out.color.data().size());
      if (t >= switch_at && std::abs(mean - 0.2) < 0.01) return t - switch_at;
    }
    return frames;
  };
  const int with = lag(true), without = lag(false);
  EXPECT_GT(without, 10);
  EXPECT_LE(2 * with, without) << with << " vs " << without;
}

TEST(SvgfHistoryClamp, SortingNetworkSortsEveryZeroOneInput) {
  // The 0-1 principle (Knuth 5.3.4): a comparator network that sorts all 2^8 0/1 inputs sorts
  // every input.
  const OneTag d;
  for (int bits = 0; bits < 256; ++bits) {
    V<OneTag> v[8];
    int ones = 0;
    for (int i = 0; i < 8; ++i) {
      v[i] = hn::Set(d, float((bits >> i) & 1));
      ones += (bits >> i) & 1;
    }
    sort8<OneTag>(v);
    for (int i = 0; i < 8; ++i) ASSERT_EQ(hn::GetLane(v[i]), i >= 8 - ones ? 1.0f : 0.0f) << bits;
  }
}

TEST(SvgfHistoryClamp, RankClampRemovesAFireflyAndLeavesSmoothGradientsExactly) {
  const int w = 19, h = 13;
  auto clamp = [&](const ImageF& img, int rank) {
    SignalInputs in;
    in.w = w;
    in.h = h;
    for (int c = 0; c < 3; ++c) in.signal[c] = img.plane(c);
    ImageF out, lum;
    demodulate_and_clamp_fireflies(in, rank, out, lum, Exec{2, true});
    return out;
  };
  // Smooth gradients (linear, diagonal, quadratic bowl), a different slope per channel: every
  // interior pixel has at least 3 neighbours at or above it, so k <= 3 changes nothing.
  for (int shape = 0; shape < 3; ++shape) {
    ImageF g(w, h, 3);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          const float fx = float(x), fy = float(y);
          const float v = shape == 0 ? 0.1f + 0.05f * fx
                          : shape == 1
                              ? 0.2f + 0.03f * fx + 0.02f * fy
                              : 0.05f + 0.01f * ((fx - 9) * (fx - 9) + (fy - 6) * (fy - 6));
          g.at(x, y, c) = v * float(c + 1);
        }
    for (int k = 1; k <= 3; ++k) {
      const ImageF out = clamp(g, k);
      for (int y = 1; y < h - 1; ++y)
        for (int x = 1; x < w - 1; ++x)
          for (int c = 0; c < 3; ++c)
            ASSERT_EQ(out.at(x, y, c), g.at(x, y, c)) << shape << " k" << k << " " << x << "," << y;
    }
  }
  // A firefly on a constant background, inside and in a corner (its mirrored neighbours are
  // background too): its luminance drops to the background's, its chroma is kept, and no
  // other pixel changes.
  ImageF f(w, h, 3, 0.5f);
  const float spike[3] = {100.0f, 50.0f, 20.0f};
  for (int c = 0; c < 3; ++c) f.at(7, 5, c) = f.at(0, 0, c) = spike[c];
  for (int k = 1; k <= 8; ++k) {
    const ImageF out = clamp(f, k);
    for (const auto& [x, y] : {std::pair{7, 5}, std::pair{0, 0}}) {
      const double lum =
          0.2126 * out.at(x, y, 0) + 0.7152 * out.at(x, y, 1) + 0.0722 * out.at(x, y, 2);
      EXPECT_NEAR(lum, 0.5, 1e-6) << k;
      EXPECT_NEAR(out.at(x, y, 0) / out.at(x, y, 2), 5.0, 1e-5);
      EXPECT_NEAR(out.at(x, y, 1) / out.at(x, y, 2), 2.5, 1e-5);
    }
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (!((x == 7 && y == 5) || (x == 0 && y == 0))) {
          for (int c = 0; c < 3; ++c) ASSERT_EQ(out.at(x, y, c), 0.5f) << x << "," << y;
        }
  }
  // A two-pixel firefly: each pixel's largest neighbour is the other, so k = 1 keeps it and
  // k >= 2 brings both down to the background.
  ImageF pair(w, h, 3, 0.5f);
  for (int c = 0; c < 3; ++c) pair.at(12, 8, c) = pair.at(13, 8, c) = spike[c];
  for (int k = 1; k <= 8; ++k) {
    const ImageF out = clamp(pair, k);
    for (int c = 0; c < 3; ++c) {
      if (k == 1) {
        EXPECT_EQ(out.at(12, 8, c), spike[c]);
      } else {
        EXPECT_NEAR(out.at(13, 8, c), spike[c] * 0.5 / 58.464, 1e-5) << k;  // luminance 58.464
      }
    }
  }
}

TEST(SvgfHistoryClamp, SecondsAt30FpsEqualTheFrameBasedSettings) {
  // tau = -dt / ln(1 - alpha) gives back alpha at dt = 1/30: 1 - exp(ln(1 - alpha)) = alpha.
  const double dt = 1.0 / 30.0;
  for (const double alpha : {0.05, 0.2, 0.4, 0.9})
    EXPECT_NEAR(alpha_for_time_constant(dt, -dt / std::log(1.0 - alpha)), alpha, 1e-6);
  EXPECT_EQ(history_cap_for_seconds(dt, 32.0 / 30.0), 32);
  EXPECT_EQ(history_cap_for_seconds(dt, 1e-6), 1);
  EXPECT_NEAR(frame_time_step(2.0 / 30.0, 1.0 / 30.0, 60.0f), dt, 1e-12);
  EXPECT_EQ(frame_time_step(0.0, 0.0, 60.0f), 1.0 / 60.0);  // no increasing time: fallback
  EXPECT_EQ(frame_time_step(1.0, NAN, 60.0f), 1.0 / 60.0);

  // End to end: frames carrying time t / 30 with tau for alpha 0.4 and a cap of 32 frames run
  // with the frame-based values; at 60 fps alpha is 1 - sqrt(0.6) (half the interval).
  const double tau = -dt / std::log(1.0 - 0.4);
  SvgfSettings sec;
  sec.alpha_seconds = float(tau);
  sec.moments_alpha_seconds = float(tau);
  sec.history_cap_seconds = 32.0f / 30.0f;
  SvgfSettings frames = sec;
  frames.alpha_seconds = frames.moments_alpha_seconds = frames.history_cap_seconds = 0.0f;
  frames.alpha_min = frames.moments_alpha_min = 0.4f;
  frames.history_cap = 32;
  SvgfDenoiser a(sec), b(frames), c(sec);
  for (int t = 0; t < 6; ++t) {
    Frame f = moving_square_frame(40, 24, t, 8, 1);
    f.time = t / 30.0;
    const ImageF oa = a.process(f).color, ob = b.process(f).color;
    EXPECT_NEAR(a.frame_settings().alpha_min, 0.4f, 1e-6);
    EXPECT_NEAR(a.frame_settings().moments_alpha_min, 0.4f, 1e-6);
    EXPECT_EQ(a.frame_settings().history_cap, 32);
    for (size_t i = 0; i < oa.data().size(); ++i)
      ASSERT_NEAR(oa.data()[i], ob.data()[i], 1e-4 * (1.0 + std::abs(ob.data()[i])));
    f.time = t / 60.0;
    c.process(f);
    if (t > 0) {
      EXPECT_NEAR(c.frame_settings().alpha_min, 1.0 - std::sqrt(0.6), 1e-6);
      EXPECT_EQ(c.frame_settings().history_cap, 64);
    }
  }
}

TEST(SvgfHistoryClamp, OptionsThatChangeNothingLeaveTheOutputBitIdentical) {
  // Off: the options' own parameters do not matter. Rank clamp k = 2 on a noise-free sequence
  // (ramps and a flat square: no pixel above its 2nd largest neighbour) clamps nothing, and
  // the demodulated input takes another path: still bit-identical. Seconds with the fallback
  // 30 fps and the float alpha they convert to: bit-identical to that frame-based alpha.
  std::vector<Frame> clean, noisy;
  for (int t = 0; t < 5; ++t) {
    clean.push_back(moving_square_frame(37, 23, t, 9, 2, 0.0f));
    noisy.push_back(moving_square_frame(37, 23, t, 9, 2));
  }
  for (const SvgfSettings& base : {preset_afterimage(), preset_svgf_paper()}) {
    const auto ref = run(base, noisy), ref_clean = run(base, clean);
    SvgfSettings off = base;
    off.fast_alpha_min = 0.9f;
    off.fast_clamp_sigma = 0.1f;
    off.fast_clamp_radius = 3;
    off.fallback_fps = 7.0f;
    EXPECT_EQ(run(off, noisy), ref);
    SvgfSettings rank = base;
    rank.firefly_rank = 2;
    EXPECT_EQ(run(rank, clean), ref_clean);
    SvgfSettings sec = base;
    sec.alpha_seconds = 0.2f;
    SvgfSettings frames = base;
    frames.alpha_min = alpha_for_time_constant(1.0 / 30.0, 0.2f);
    EXPECT_EQ(run(sec, noisy), run(frames, noisy));
  }
}

// Same shape and the same bits (operator== would take -0 for +0).
bool same_bits(const ImageF& a, const ImageF& b) {
  return a.width() == b.width() && a.height() == b.height() && a.channels() == b.channels() &&
         std::memcmp(a.data().data(), b.data().data(), a.data().size() * sizeof(float)) == 0;
}

TEST(SvgfHistoryClamp, PassesEqualThePlainVersionsBitForBit) {
  // The lanes (history_clamp.cpp) against reference.h, which --simd off runs: 1 and 2 signals,
  // with and without emission subtraction and demodulation (albedo below eps included), every
  // rank, fireflies and ties between neighbours; the fast-history clamp at radii 0-3 with
  // pixels without history (alpha 1). Widths not a multiple of the lane width.
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (const auto& [w, h] : {std::pair{37, 23}, std::pair{5, 3}, std::pair{70, 9}})
    for (int signals : {1, 2}) {
      ImageF signal(w, h, 3 * signals), emission(w, h, 3), albedo(w, h, 3);
      for (float& v : signal.data()) v = u(rng) < 0.03f ? 100.0f : (u(rng) < 0.1f ? 0.5f : u(rng));
      for (float& v : emission.data()) v = u(rng) < 0.5f ? 0.0f : 0.3f * u(rng);
      for (float& v : albedo.data()) v = u(rng) < 0.1f ? 1e-4f : u(rng);
      for (const bool combined : {false, true}) {
        SignalInputs in;
        in.w = w;
        in.h = h;
        in.signals = signals;
        for (int c = 0; c < 3 * signals; ++c) in.signal[c] = signal.plane(c);
        in.subtract_emission = combined;
        in.demodulate = combined;
        for (int c = 0; c < 3; ++c) {
          in.emission[c] = emission.plane(c);
          in.albedo[c] = albedo.plane(c);
        }
        for (int rank = 0; rank <= 8; ++rank) {
          ImageF ref, ref_lum, out, lum;
          reference::demodulate_and_clamp_fireflies(in, rank, ref, ref_lum, Exec{1, false});
          demodulate_and_clamp_fireflies(in, rank, out, lum, Exec{2, true});
          EXPECT_TRUE(same_bits(out, ref)) << w << "x" << h << " S" << signals << " rank " << rank;
          EXPECT_TRUE(same_bits(lum, ref_lum)) << w << "x" << h << " S" << signals;
        }
      }
      ImageF fast(w, h, 3 * signals), long_prev(w, h, 3 * signals), alpha(w, h, 1),
          cur(w, h, 3 * signals);
      for (float& v : fast.data()) v = u(rng) < 0.05f ? 20.0f : u(rng);
      for (float& v : long_prev.data()) v = 2.0f * u(rng);
      for (float& v : cur.data()) v = u(rng);
      for (float& v : alpha.data()) v = u(rng) < 0.1f ? 1.0f : 0.05f + 0.5f * u(rng);
      for (int radius = 0; radius <= 3; ++radius) {
        ImageF ref = cur, out = cur;
        reference::clamp_history_to_fast_box(fast, long_prev, alpha, 1.5f, radius, ref,
                                             Exec{1, false});
        clamp_history_to_fast_box(fast, long_prev, alpha, 1.5f, radius, out, Exec{2, true});
        EXPECT_TRUE(same_bits(out, ref)) << w << "x" << h << " S" << signals << " r" << radius;
        EXPECT_FALSE(same_bits(ref, cur));
      }
    }
}

TEST(SvgfHistoryClamp, BitIdenticalForAnyThreadCountAndSimdWithEveryOptionOn) {
  std::vector<Frame> seq;
  for (int t = 0; t < 5; ++t) seq.push_back(moving_square_frame(53, 29, t, 10, 2));
  SvgfSettings s = preset_afterimage();
  s.fast_history_clamp = true;
  s.fast_clamp_radius = 2;
  s.firefly_rank = 2;
  s.alpha_seconds = 0.1f;
  const auto one = run(s, seq, Exec{1, true}), two = run(s, seq, Exec{2, true}),
             scalar = run(s, seq, Exec{2, false});
  EXPECT_EQ(one, two);
  EXPECT_EQ(one, scalar);
  EXPECT_NE(one, run(preset_afterimage(), seq));  // the options do something here
}

TEST(SvgfHistoryClamp, SavedStateWithTheFastHistoryContinuesBitIdentically) {
  std::vector<Frame> seq;
  for (int t = 0; t < 6; ++t) {
    seq.push_back(moving_square_frame(33, 21, t, 8, 1));
    seq.back().time = t / 24.0;
  }
  SvgfSettings s;
  s.fast_history_clamp = true;
  s.alpha_seconds = 0.15f;
  SvgfDenoiser a(s);
  for (int t = 0; t < 3; ++t) a.process(seq[size_t(t)]);
  const std::string path = (test::fresh_temp_dir("svgf_fast_state") / "s.state").string();
  a.save_state(path);
  SvgfDenoiser b(s);
  b.load_state(path);
  EXPECT_EQ(b.fast_history(), a.fast_history());
  EXPECT_FALSE(b.fast_history().empty());
  for (int t = 3; t < 6; ++t) {
    EXPECT_EQ(a.process(seq[size_t(t)]).color, b.process(seq[size_t(t)]).color) << t;
    EXPECT_EQ(a.frame_settings().alpha_min, b.frame_settings().alpha_min);  // prev_time kept
  }
  // Without the fast history in the file the clamp restarts it from the long history: still a
  // valid continuation, but not the same frames.
  SvgfSettings plain;
  SvgfDenoiser p(plain);
  for (int t = 0; t < 3; ++t) p.process(seq[size_t(t)]);
  p.save_state(path);
  SvgfDenoiser q(s);
  q.load_state(path);
  EXPECT_TRUE(q.fast_history().empty());
  const ImageF out = q.process(seq[3]).color;
  for (float v : out.data()) ASSERT_TRUE(std::isfinite(v));
  EXPECT_EQ(q.fast_history().channels(), 3);  // one combined signal
}

}  // namespace
}  // namespace afterimage::svgf
