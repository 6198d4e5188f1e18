// SvgfDenoiser (svgf/denoiser.h) on synthetic sequences built here: the temporal variance of a
// static sequence with known per-pixel noise, the spatial estimate exactly while n < 4,
// disocclusion behind a moving square resets the history length, NaN / Inf never enter
// history, thread / SIMD independence, state continuation and the remodulation identity of
// every signal split.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/state_file.h"
#include "svgf/denoiser.h"
#include "test_util.h"

namespace afterimage::svgf {
namespace {

using test::moving_square_frame;

// A static gray plane (depth 4, normal +z, albedo 1, id 1) whose luminance at pixel x has
// mean `mean(x, y)` and Gaussian noise of standard deviation `sigma(x, y)`, fresh per frame.
template <class Mean, class Sigma>
Frame noisy_static_frame(int w, int h, int t, Mean mean, Sigma sigma) {
  Frame f = Frame::allocate(w, h);
  f.index = t;
  std::mt19937 rng(1000 + unsigned(t));
  std::normal_distribution<float> g(0.0f, 1.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float v = mean(x, y) + sigma(x, y) * g(rng);
      for (int c = 0; c < 3; ++c) {
        f.color.at(x, y, c) = v;
        f.albedo.at(x, y, c) = 1.0f;
      }
      f.depth.at(x, y, 0) = 4.0f;
      f.normal.at(x, y, 2) = 1.0f;
      f.id.at(x, y, 0) = 1;
    }
  return f;
}

float sigma_of(int x, int, int w) {
  return 0.1f + 0.3f * float(x) / float(w);
}

TEST(SvgfDenoiser, TemporalVarianceOfAStaticSequenceMatchesTheNoise) {
  // Known per-pixel variance sigma(x)^2 (0.01 .. 0.16). With moments_alpha_min below 1/33 the
  // 32-frame moments are a plain mean and E[mu2 - mu1^2] = (31/32) sigma^2; with the paper's
  // alpha = 0.2 the moving average of weights w_k has E = (1 - sum w_k^2) sigma^2 (computed
  // here). Pooled over the pixels, within 10%.
  const int w = 48, h = 32, frames = 32;
  for (const float alpha : {0.001f, 0.2f}) {
    SvgfSettings s;
    s.moments_alpha_min = alpha;
    s.history_cap = 64;
    SvgfDenoiser den(s);
    std::vector<double> wts;  // weights of the moving average over the frames, newest last
    for (int t = 0; t < frames; ++t) {
      den.process(noisy_static_frame(
          w, h, t, [](int, int) { return 1.0f; }, [&](int x, int y) { return sigma_of(x, y, w); }));
      const double a = std::max(double(alpha), 1.0 / (t + 1));
      for (double& v : wts) v *= 1 - a;
      wts.push_back(a);
    }
    double sum_w2 = 0;
    for (double v : wts) sum_w2 += v * v;
    double ratio = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        ASSERT_EQ(den.history_length().at(x, y, 0), float(frames));
        const double s2 = double(sigma_of(x, y, w)) * sigma_of(x, y, w);
        ratio += den.variance().at(x, y, 0) / (s2 * (1 - sum_w2));
      }
    EXPECT_NEAR(ratio / (w * h), 1.0, 0.1) << "alpha " << alpha;
  }
}

TEST(SvgfDenoiser, SpatialVarianceExactlyWhileTheHistoryIsShorterThanFourFrames) {
  // A checkerboard of means 0.5 / 1.5 (large spatial variance) with small temporal noise:
  // frames 1-3 (n = 1, 2, 3) use the spatial estimate (~0.25), frame 4 on the temporal one
  // (the moments' own variance, ~1e-4).
  const int w = 32, h = 24;
  SvgfDenoiser den;
  for (int t = 0; t < 6; ++t) {
    den.process(noisy_static_frame(
        w, h, t, [](int x, int y) { return (x + y) % 2 ? 1.5f : 0.5f; },
        [](int, int) { return 0.01f; }));
    const float n = den.history_length().at(10, 10, 0);
    EXPECT_EQ(n, float(t + 1));
    for (int y = 3; y < h - 3; ++y)
      for (int x = 3; x < w - 3; ++x) {
        const float v = den.variance().at(x, y, 0), temporal = den.moments().at(x, y, 1);
        if (t + 1 < 4) {
          ASSERT_GT(v, 0.2f) << t;
        } else {
          ASSERT_EQ(v, temporal) << t;
          ASSERT_LT(v, 1e-3f) << t;
        }
      }
  }
}

TEST(SvgfDenoiser, DisocclusionResetsTheHistoryLength) {
  // Behind the moving square the background reappears: where no pixel of the 2x2 taps nor of
  // the 3x3 fallback showed background in the previous frame, n restarts at 1; where the
  // fallback finds background beside it, n continues from there; still background continues
  // its own history (n + 1) and the square, moving with its motion vectors, too.
  const int w = 64, h = 32, side = 12, speed = 4;
  SvgfDenoiser den;
  ImageF prev_n;
  for (int t = 0; t < 6; ++t) {
    den.process(moving_square_frame(w, h, t, side, speed));
    const ImageF& n_map = den.history_length();
    if (t > 0) {
      const int x0 = 4 + speed * t, px0 = x0 - speed, y0 = 6;
      auto was_square = [&](int x, int y) {
        return x >= px0 && x < px0 + side && y >= y0 && y < y0 + side;
      };
      int reset = 0;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const bool in = x >= x0 && x < x0 + side && y >= y0 && y < y0 + side;
          const float n = n_map.at(x, y, 0);
          if (in) {
            EXPECT_EQ(n, float(t + 1)) << x << "," << y << " t" << t;
          } else if (!was_square(x, y)) {
            EXPECT_EQ(n, prev_n.at(x, y, 0) + 1.0f) << x << "," << y << " t" << t;
          } else {
            // Uncovered: any background pixel in the previous frame's 3x3 around it?
            bool background_near = false;
            for (int j = -1; j <= 1; ++j)
              for (int i = -1; i <= 1; ++i) {
                const int xx = x + i, yy = y + j;
                if (xx >= 0 && yy >= 0 && xx < w && yy < h && !was_square(xx, yy))
                  background_near = true;
              }
            if (!background_near) {
              EXPECT_EQ(n, 1.0f) << x << "," << y << " t" << t;
              ++reset;
            } else {
              EXPECT_GT(n, 1.0f) << x << "," << y << " t" << t;  // the 3x3 fallback found it
            }
          }
        }
      EXPECT_EQ(reset, (speed - 1) * (side - 2)) << t;
    }
    prev_n = n_map;
  }
}

TEST(SvgfDenoiser, NanAndInfNeverEnterHistory) {
  const int w = 40, h = 24;
  SvgfDenoiser den;
  for (int t = 0; t < 6; ++t) {
    Frame f = moving_square_frame(w, h, t, 8, 1);
    if (t == 3) {
      f.color.at(20, 12, 1) = NAN;
      f.color.at(5, 5, 0) = INFINITY;
      f.albedo.at(30, 20, 2) = NAN;
    }
    const Frame out = den.process(f);
    for (float v : out.color.data()) ASSERT_TRUE(std::isfinite(v)) << t;
    for (float v : den.color_history().data()) ASSERT_TRUE(std::isfinite(v)) << t;
    for (float v : den.moments().data()) ASSERT_TRUE(std::isfinite(v)) << t;
    if (t == 3) {
      // History reset at the bad pixels only; their neighbours keep theirs.
      EXPECT_EQ(den.history_length().at(20, 12, 0), 0.0f);
      EXPECT_EQ(den.history_length().at(5, 5, 0), 0.0f);
      EXPECT_EQ(den.history_length().at(30, 20, 0), 0.0f);
      EXPECT_EQ(den.history_length().at(21, 12, 0), 4.0f);
      EXPECT_EQ(den.history_length().at(6, 5, 0), 4.0f);
    }
    if (t == 4) {
      // Next frame: the repaired pixel's own value is nobody's history (length 0 fails the
      // reprojection test), so it takes its neighbours' through the 3x3 fallback: 4 + 1.
      EXPECT_EQ(den.history_length().at(5, 5, 0), 5.0f);
      EXPECT_EQ(den.history_length().at(30, 20, 0), 5.0f);
    }
  }
}

// The sanitising tests ride on the accumulation's reads (denoiser.cpp step 1). Each value the
// sanitiser repairs without resetting history (a negative color-like value -> 0, a non-finite
// or non-positive depth -> background, a non-finite normal or depth gradient -> 0) must give
// exactly the output of the same frame repaired by hand; a plane the tests missed would let
// the raw value through. Placed inside a lane block and at the last pixel (the 1-lane tail),
// on lanes and with --simd off.
TEST(SvgfDenoiser, EveryRepairedInputIsCaughtAsBeforeFiltering) {
  const int w = 37, h = 21;  // 37 = 2 x 16 lanes + a 5-pixel tail
  // The depth gradient as a channel (then tested itself) or computed from the depth (which
  // spreads a missed bad depth to the neighbours' gradients).
  auto frame = [&](int t, bool gradient_channel) {
    Frame f = moving_square_frame(w, h, t, 8, 1);
    for (Channel c : {Channel::emission, Channel::direct, Channel::indirect}) f.allocate_channel(c);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          f.emission.at(x, y, c) = 0.01f * float(c);
          f.direct.at(x, y, c) = 0.7f * f.color.at(x, y, c);
          f.indirect.at(x, y, c) = 0.3f * f.color.at(x, y, c);
        }
    if (gradient_channel) {
      f.allocate_channel(Channel::depth_gradient);
      svgf::depth_gradient(f.depth, f.depth_gradient);
    }
    return f;
  };
  struct Case {
    Channel channel;
    int plane;
    float bad, repaired;
  };
  const float bg = kBackgroundDepth;
  const Case cases[] = {
      {Channel::depth, 0, NAN, bg},
      {Channel::depth, 0, -INFINITY, bg},
      {Channel::depth, 0, 0.0f, bg},
      {Channel::depth, 0, -3.0f, bg},
      {Channel::normal, 1, NAN, 0.0f},
      {Channel::normal, 2, INFINITY, 0.0f},
      {Channel::depth_gradient, 0, INFINITY, 0.0f},
      {Channel::depth_gradient, 1, NAN, 0.0f},
      {Channel::color, 0, -1.0f, 0.0f},
      {Channel::emission, 2, -0.5f, 0.0f},
      {Channel::albedo, 1, -0.5f, 0.0f},
      {Channel::direct, 0, -2.0f, 0.0f},
      {Channel::indirect, 2, -2.0f, 0.0f},
  };
  for (const char* split : {"combined", "direct_indirect"}) {
    SvgfSettings s;
    s.set_assignment(std::string("split=") + split);
    const bool gradient_channel = std::string(split) == "direct_indirect";
    for (const Case& c : cases) {
      if (c.channel == Channel::depth_gradient && !gradient_channel) continue;
      for (const auto& [x, y] : {std::pair{20, 10}, std::pair{w - 1, h - 1}})
        for (const Exec ex : {Exec{2, true}, Exec{1, false}}) {
          SvgfDenoiser bad_den(s, ex), fixed_den(s, Exec{2, true});
          for (int t = 0; t < 4; ++t) {
            Frame bad = frame(t, gradient_channel), fixed = frame(t, gradient_channel);
            if (t == 2) {
              bad.plane_set(c.channel)->at(x, y, c.plane) = c.bad;
              fixed.plane_set(c.channel)->at(x, y, c.plane) = c.repaired;
            }
            const Frame a = bad_den.process(bad), b = fixed_den.process(fixed);
            ASSERT_EQ(a.color, b.color) << split << " " << channel_info(c.channel).name << " "
                                        << c.bad << " at " << x << "," << y << " frame " << t;
            ASSERT_EQ(bad_den.history_length(), fixed_den.history_length());
          }
        }
    }
  }
}

TEST(SvgfDenoiser, BitIdenticalForAnyThreadCountAndSimd) {
  const int w = 53, h = 29;
  std::vector<Frame> seq;
  for (int t = 0; t < 5; ++t) seq.push_back(moving_square_frame(w, h, t, 10, 2));
  auto run = [&](Exec ex) {
    SvgfDenoiser den({}, ex);
    std::vector<ImageF> out;
    for (const Frame& f : seq) out.push_back(den.process(f).color);
    return out;
  };
  const auto one = run(Exec{1, true}), two = run(Exec{2, true}), scalar = run(Exec{2, false});
  for (size_t t = 0; t < seq.size(); ++t) {
    EXPECT_EQ(one[t], two[t]) << t;
    EXPECT_EQ(one[t], scalar[t]) << t;
  }
}

TEST(SvgfDenoiser, SavedStateContinuesBitIdentically) {
  const int w = 33, h = 21;
  std::vector<Frame> seq;
  for (int t = 0; t < 5; ++t) seq.push_back(moving_square_frame(w, h, t, 8, 1));
  SvgfDenoiser a;
  for (int t = 0; t < 3; ++t) a.process(seq[size_t(t)]);
  const std::string path = (test::fresh_temp_dir("svgf_state") / "s.state").string();
  a.save_state(path);
  SvgfDenoiser b;
  b.load_state(path);
  for (int t = 3; t < 5; ++t)
    EXPECT_EQ(a.process(seq[size_t(t)]).color, b.process(seq[size_t(t)]).color);
  // A foreign or corrupt file changes nothing and says so.
  std::filesystem::resize_file(path, 100);
  EXPECT_THROW(b.load_state(path), InputError);
}

// The G-buffer kept for the next frame is written by the accumulation's blocks (streaming
// stores where a vector is aligned, ordinary ones elsewhere: denoiser.cpp): the saved state's
// previous depth, normal and ids must be the frame's, after sanitising. 64 x 9 puts every
// block on the streaming path, 37 x 21 has unaligned rows and a 1-lane tail; on lanes and with
// --simd off; a non-finite depth must be kept as the background depth.
TEST(SvgfDenoiser, KeepsTheFramesSanitisedGBufferForTheNextFrame) {
  for (const auto& [w, h] : {std::pair{64, 9}, std::pair{37, 21}})
    for (const Exec ex : {Exec{2, true}, Exec{1, false}}) {
      SvgfDenoiser den({}, ex);
      Frame f;
      for (int t = 0; t < 2; ++t) {
        f = moving_square_frame(w, h, t, 8, 1);
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x) f.id.at(x, y, 0) = uint32_t(1000 * t + x + w * y);
        den.process(f);
      }
      f.depth.at(w - 1, h - 1, 0) = NAN;
      f.depth.at(3, 2, 0) = -1.0f;
      den.process(f);
      const std::string path = (test::fresh_temp_dir("svgf_gbuffer") / "s.state").string();
      den.save_state(path);
      const StateReader rd(path, "svgf", 1);
      ImageF depth = f.depth;
      depth.at(w - 1, h - 1, 0) = kBackgroundDepth;
      depth.at(3, 2, 0) = kBackgroundDepth;
      EXPECT_EQ(rd.get_image<float>("prev_depth", w, h, 1), depth) << w;
      EXPECT_EQ(rd.get_image<float>("prev_normal", w, h, 3), f.normal) << w;
      EXPECT_EQ(rd.get_image<uint32_t>("prev_id", w, h, 1), f.id) << w;
    }
}

TEST(SvgfDenoiser, RemodulationRestoresANoiseFreeFrameForEverySplit) {
  // A constant, noise-free frame composed as the channel contract says: every split filters a
  // constant signal, so the output is the input color.
  const int w = 24, h = 16;
  Frame f = Frame::allocate(w, h);
  for (Channel c :
       {Channel::emission, Channel::diffuse, Channel::specular, Channel::direct, Channel::indirect})
    f.allocate_channel(c);
  const float albedo[3] = {0.8f, 0.5f, 0.0f}, e[3] = {0.1f, 0.0f, 0.2f};
  const float diff[3] = {1.0f, 2.0f, 3.0f}, spec[3] = {0.3f, 0.2f, 0.1f};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.depth.at(x, y, 0) = 3.0f;
      f.normal.at(x, y, 2) = 1.0f;
      for (int c = 0; c < 3; ++c) {
        f.albedo.at(x, y, c) = albedo[c];
        f.emission.at(x, y, c) = e[c];
        f.diffuse.at(x, y, c) = diff[c];
        f.specular.at(x, y, c) = spec[c];
        f.direct.at(x, y, c) = 0.6f * (albedo[c] * diff[c] + spec[c]);
        f.indirect.at(x, y, c) = 0.4f * (albedo[c] * diff[c] + spec[c]);
        f.color.at(x, y, c) = e[c] + albedo[c] * diff[c] + spec[c];
      }
    }
  for (const char* split : {"combined", "diffuse_specular", "direct_indirect"}) {
    SvgfSettings s;
    s.set_assignment(std::string("split=") + split);
    SvgfDenoiser den(s);
    for (int t = 0; t < 2; ++t) {
      const Frame out = den.process(f);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          for (int c = 0; c < 3; ++c)
            ASSERT_NEAR(out.color.at(x, y, c), f.color.at(x, y, c), 1e-5) << split;
    }
    EXPECT_EQ(den.signals(), std::string(split) == "combined" ? 1 : 2);
  }
  // auto takes the paper's direct / indirect split when the frame has it.
  SvgfDenoiser den;
  den.process(f);
  EXPECT_EQ(den.split(), Split::DirectIndirect);
  // A split whose channels are missing is a one-line InputError naming them.
  Frame bare = Frame::allocate(w, h);
  SvgfSettings s;
  s.split = Split::DiffuseSpecular;
  SvgfDenoiser strict(s);
  EXPECT_NE(test::error_of<InputError>([&] { strict.process(bare); }).find("diffuse"),
            std::string::npos);
}

TEST(SvgfDenoiser, ReducesNoiseOnAStaticPlane) {
  // Sanity of the whole filter: after 8 frames the error against the noise-free plane is far
  // below the input noise (sigma 0.2 on luminance 1).
  const int w = 48, h = 32;
  SvgfDenoiser den;
  Frame out;
  for (int t = 0; t < 8; ++t)
    out = den.process(noisy_static_frame(
        w, h, t, [](int, int) { return 1.0f; }, [](int, int) { return 0.2f; }));
  double e2 = 0;
  for (float v : out.color.data()) e2 += (v - 1.0) * (v - 1.0);
  EXPECT_LT(std::sqrt(e2 / double(out.color.data().size())), 0.05);
}

}  // namespace
}  // namespace afterimage::svgf
