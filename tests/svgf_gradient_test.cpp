// A-SVGF temporal gradients in the filter (svgf/gradient.h; Schied, Peters, Dachsbacher, HPG
// 2018): lambda and alpha' in closed form, the reconstruction of a constant and of a step
// gradient (edge-aware: no bleeding across a depth step, which a filter without the depth weight
// does), no gradient channel = plain SVGF bit for bit, lambda = 1 resets the history, NaN
// gradients never reach the history; history relighting in closed form, unbiased after a step
// in the lighting, and exactly neutral without change.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <utility>

#include "svgf/denoiser.h"
#include "svgf/gradient.h"

namespace afterimage::svgf {
namespace {

TEST(SvgfGradient, LambdaClosedForm) {
  EXPECT_FLOAT_EQ(gradient_lambda(0.5f, 2.0f), 0.25f);
  EXPECT_FLOAT_EQ(gradient_lambda(-1.0f, 4.0f), 0.25f);
  EXPECT_FLOAT_EQ(gradient_lambda(3.0f, 2.0f), 1.0f);  // capped
  EXPECT_EQ(gradient_lambda(1.0f, 0.0f), 0.0f);        // no luminance: no gradient
  EXPECT_EQ(gradient_lambda(std::nanf(""), 1.0f), 0.0f);
  EXPECT_EQ(gradient_lambda(0.5f, std::numeric_limits<float>::infinity()), 0.0f);
}

TEST(SvgfGradient, AlphaFormula) {
  EXPECT_FLOAT_EQ(gradient_alpha(0.2f, 0.0f), 0.2f);
  EXPECT_FLOAT_EQ(gradient_alpha(0.2f, 1.0f), 1.0f);
  EXPECT_FLOAT_EQ(gradient_alpha(0.2f, 0.5f), 0.6f);
  EXPECT_FLOAT_EQ(gradient_alpha(0.4f, 0.25f), 0.55f);
}

TEST(SvgfGradient, RelightClosedForm) {
  // prev = max - max(delta, 0): a brightening sample's max is its new value, a darkening one's
  // its old value.
  EXPECT_FLOAT_EQ(gradient_sample_previous(0.5f, 1.5f), 1.0f);
  EXPECT_FLOAT_EQ(gradient_sample_previous(-0.5f, 1.5f), 1.5f);
  EXPECT_FLOAT_EQ(gradient_relight(0.5f, 1.0f), 1.5f);  // now / prev = 1.5 / 1
  EXPECT_FLOAT_EQ(gradient_relight(-0.5f, 1.5f), 2.0f / 3.0f);
  EXPECT_EQ(gradient_relight(0.0f, 0.7f), 1.0f);  // no change: exactly 1
  EXPECT_FLOAT_EQ(gradient_relight(9.0f, 1.0f), kMaxRelight);
  EXPECT_FLOAT_EQ(gradient_relight(-0.99f, 1.0f), 1.0f / kMaxRelight);
  EXPECT_EQ(gradient_relight(1.0f, 0.0f), 1.0f);  // nothing to scale
  EXPECT_EQ(gradient_relight(std::nanf(""), 1.0f), 1.0f);
  EXPECT_EQ(gradient_relight(1.0f, std::numeric_limits<float>::infinity()), 1.0f);
}

// A flat fronto-parallel plane (depth `z(x)`, normal +z, luminance 1) and gradient samples at
// the center pixel of every stratum for which `has(sx, sy)`, delta = delta(sx), max 1.
struct Scene {
  ImageF depth, normal, dgrad, lum, gradient;
  Guide guide() const { return {&depth, &normal, &dgrad}; }
};
template <class Z, class Has, class Delta>
Scene plane(int w, int h, Z z, Has has, Delta delta) {
  Scene s{ImageF(w, h, 1), ImageF(w, h, 3), ImageF(w, h, 2), ImageF(w, h, 1, 1.0f),
          ImageF(w, h, 3)};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      s.depth.at(x, y, 0) = z(x);
      s.normal.at(x, y, 2) = 1.0f;
      const int sx = x / 3, sy = y / 3;
      if (x % 3 == 1 && y % 3 == 1 && has(sx, sy)) {
        s.gradient.at(x, y, 0) = delta(sx);
        s.gradient.at(x, y, 1) = 1.0f;
        s.gradient.at(x, y, 2) = 1.0f;
      }
    }
  return s;
}

TEST(SvgfGradient, ConstantGradientIsReconstructedEverywhere) {
  // Samples in one stratum of four (a checkerboard of 2x2 stratum blocks has every other
  // block empty); after 3 iterations every stratum carries lambda = 0.3.
  const Scene sc = plane(
      48, 36, [](int) { return 4.0f; }, [](int sx, int sy) { return sx % 2 == 0 && sy % 2 == 0; },
      [](int) { return 0.3f; });
  SvgfSettings s;
  ImageF strata, lambda;
  reconstruct_gradient(sc.gradient, sc.guide(), sc.lum, s, strata, lambda);
  ASSERT_EQ(strata.width(), 16);
  ASSERT_EQ(strata.height(), 12);
  for (int y = 0; y < 36; ++y)
    for (int x = 0; x < 48; ++x) ASSERT_NEAR(lambda.at(x, y, 0), 0.3f, 1e-5f) << x << "," << y;
  // Without iterations the empty strata have no gradient.
  s.gradient_iterations = 0;
  reconstruct_gradient(sc.gradient, sc.guide(), sc.lum, s, strata, lambda);
  EXPECT_EQ(lambda.at(4, 1, 0), 0.0f);  // stratum (1, 0): empty
  EXPECT_FLOAT_EQ(lambda.at(1, 1, 0), 0.3f);
}

// Same shape and the same bits (operator== would take -0 for +0).
bool same_bits(const ImageF& a, const ImageF& b) {
  return a.width() == b.width() && a.height() == b.height() && a.channels() == b.channels() &&
         std::memcmp(a.data().data(), b.data().data(), a.data().size() * sizeof(float)) == 0;
}

TEST(SvgfGradient, ReconstructionEqualsThePlainVersionBitForBit) {
  // The lanes (gradient.cpp) against reference.h gradient_atrous_at, which --simd off runs:
  // random samples in some strata, a depth step, tilted normals and noisy luminance guides, at
  // sizes whose strata rows are not a multiple of the lane width and whose last strata are
  // partial, 1 to 4 iterations (steps up to 8 strata, beyond the border), 1 and 2 threads.
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (const auto& [w, h] : {std::pair{50, 37}, std::pair{8, 7}, std::pair{101, 22}}) {
    ImageF depth(w, h, 1), normal(w, h, 3), dgrad(w, h, 2), lum(w, h, 1), gradient(w, h, 3);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        depth.at(x, y, 0) = x < w / 2 ? 2.0f + 0.01f * float(y) : 6.0f;
        dgrad.at(x, y, 0) = x < w / 2 ? 0.0f : 0.02f * u(rng);
        dgrad.at(x, y, 1) = x < w / 2 ? 0.01f : 0.0f;
        const float t = 0.4f * u(rng);
        normal.at(x, y, 0) = t;
        normal.at(x, y, 2) = std::sqrt(1.0f - t * t);
        lum.at(x, y, 0) = 2.0f * u(rng);
        if (u(rng) < 0.15f) {
          gradient.at(x, y, 0) = u(rng) - 0.5f;
          gradient.at(x, y, 1) = u(rng) + 0.5f;
          gradient.at(x, y, 2) = 1.0f;
        }
      }
    const Guide g{&depth, &normal, &dgrad};
    for (int iterations = 1; iterations <= 4; ++iterations) {
      SvgfSettings s;
      s.gradient_iterations = iterations;
      ImageF ref_strata, ref_lambda, ref_relight;
      reconstruct_gradient(gradient, g, lum, s, ref_strata, ref_lambda, &ref_relight,
                           Exec{1, false});
      for (const Exec ex : {Exec{1, true}, Exec{2, true}, Exec{2, false}}) {
        ImageF strata, lambda, relight;
        reconstruct_gradient(gradient, g, lum, s, strata, lambda, &relight, ex);
        EXPECT_TRUE(same_bits(strata, ref_strata)) << w << "x" << h << " iterations " << iterations;
        EXPECT_TRUE(same_bits(lambda, ref_lambda)) << w << "x" << h << " iterations " << iterations;
        EXPECT_TRUE(same_bits(relight, ref_relight))
            << w << "x" << h << " iterations " << iterations;
      }
    }
  }
}

TEST(SvgfGradient, StepGradientStopsAtADepthEdge) {
  // Left half (strata 0..7): delta 0 on a plane at depth 2; right half: delta 1 on a plane at
  // depth 6. Every stratum sampled. The depth weight keeps the halves apart; the same samples
  // on one plane (no depth edge) bleed across the step.
  auto delta = [](int sx) { return sx < 8 ? 0.0f : 1.0f; };
  auto all = [](int, int) { return true; };
  const Scene edge = plane(
      48, 24, [](int x) { return x < 24 ? 2.0f : 6.0f; }, all, delta);
  const Scene flat = plane(
      48, 24, [](int) { return 4.0f; }, all, delta);
  SvgfSettings s;
  ImageF strata, lambda, strata_flat, lambda_flat;
  reconstruct_gradient(edge.gradient, edge.guide(), edge.lum, s, strata, lambda);
  reconstruct_gradient(flat.gradient, flat.guide(), flat.lum, s, strata_flat, lambda_flat);
  for (int y = 0; y < 24; ++y) {
    EXPECT_LT(lambda.at(22, y, 0), 1e-3f);   // stratum 7, beside the edge
    EXPECT_GT(lambda.at(25, y, 0), 0.999f);  // stratum 8
  }
  EXPECT_GT(lambda_flat.at(22, 10, 0), 0.05f);  // bleeding without the edge
  EXPECT_LT(lambda_flat.at(25, 10, 0), 0.95f);
}

// A static noisy gray plane, optionally with a gradient channel of the given sample value.
Frame noisy_frame(int w, int h, int t, bool with_gradient, float delta, float max,
                  float level = 1.0f) {
  Frame f = Frame::allocate(w, h);
  f.index = t;
  std::mt19937 rng(77 + unsigned(t));
  std::normal_distribution<float> g(1.0f, 0.3f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float v = level * std::max(0.0f, g(rng));
      for (int c = 0; c < 3; ++c) {
        f.color.at(x, y, c) = v;
        f.albedo.at(x, y, c) = 1.0f;
      }
      f.depth.at(x, y, 0) = 4.0f;
      f.normal.at(x, y, 2) = 1.0f;
      f.id.at(x, y, 0) = 1;
    }
  if (with_gradient) {
    f.allocate_channel(Channel::gradient);
    for (int y = 1; y < h; y += 3)
      for (int x = 1; x < w; x += 3) {
        f.gradient.at(x, y, 0) = delta;
        f.gradient.at(x, y, 1) = max;
        f.gradient.at(x, y, 2) = 1.0f;
      }
  }
  return f;
}

TEST(SvgfGradient, WithoutTheChannelItIsPlainSvgfBitForBit) {
  SvgfSettings on = preset_afterimage(), off = preset_afterimage();
  on.temporal_gradient = true;
  off.temporal_gradient = false;
  SvgfDenoiser a(on), b(off);
  for (int t = 0; t < 4; ++t) {
    const Frame f = noisy_frame(24, 18, t, false, 0, 0);
    const Frame x = a.process(f), y = b.process(f);
    ASSERT_EQ(x.color.data(), y.color.data()) << "frame " << t;
  }
  // With the channel but temporal_gradient off: also plain SVGF.
  SvgfDenoiser c(off), d(off);
  for (int t = 0; t < 4; ++t)
    ASSERT_EQ(c.process(noisy_frame(24, 18, t, true, 1, 1)).color.data(),
              d.process(noisy_frame(24, 18, t, false, 0, 0)).color.data());
}

TEST(SvgfGradient, FullChangeResetsTheHistoryAndZeroChangeKeepsIt) {
  SvgfSettings s = preset_afterimage();
  s.temporal_gradient = true;
  for (const bool shorten : {true, false}) {
    s.gradient_shorten_history = shorten;
    SvgfDenoiser full(s), none(s);
    for (int t = 0; t < 3; ++t) {
      full.process(noisy_frame(24, 18, t, true, 2.0f, 2.0f));  // lambda 1
      none.process(noisy_frame(24, 18, t, true, 0.0f, 2.0f));  // lambda 0
    }
    for (int y = 0; y < 18; ++y)
      for (int x = 0; x < 24; ++x) {
        ASSERT_EQ(full.gradient_lambda().at(x, y, 0), 1.0f);
        ASSERT_EQ(full.history_length().at(x, y, 0), shorten ? 1.0f : 3.0f);
        ASSERT_EQ(none.history_length().at(x, y, 0), 3.0f);
      }
  }
}

// The lighting of the noisy plane steps from 1 to 1.5 at frame 8, and the gradient samples
// say so (delta 0.5, max 1.5; lambda 1/3 at the paper's scale 1). With relighting the history
// after the step is centered on the new level (the truth: 1.5 times the old mean); without it,
// the paper's rule alone keeps (1 - lambda)(1 - alpha) = 0.4 of the old level (mean ~1.3).
// Before the step (delta 0) relighting changes nothing, bit for bit.
TEST(SvgfGradient, RelightingRemovesTheStaleBiasOfAStep) {
  SvgfSettings s = preset_afterimage();
  s.gradient_scale = 1.0f;
  SvgfSettings off = s;
  s.gradient_relight = true;
  off.gradient_relight = false;
  SvgfDenoiser on_d(s), off_d(off);
  auto mean = [](const ImageF& img) {
    double sum = 0.0;
    for (float v : img.data()) sum += v;
    return sum / double(img.data().size());
  };
  double before = 0.0;
  for (int t = 0; t < 8; ++t) {
    const Frame f = noisy_frame(30, 24, t, true, 0.0f, 1.0f);
    ASSERT_EQ(on_d.process(f).color.data(), off_d.process(f).color.data()) << "frame " << t;
    before = mean(on_d.color_history());
  }
  const Frame step = noisy_frame(30, 24, 8, true, 0.5f, 1.5f, 1.5f);
  on_d.process(step);
  off_d.process(step);
  const double relit = mean(on_d.color_history()), stale = mean(off_d.color_history());
  EXPECT_NEAR(relit / before, 1.5, 0.03);
  EXPECT_LT(stale / before, 1.4);
}

TEST(SvgfGradient, NanGradientNeverEntersHistory) {
  SvgfSettings s = preset_afterimage();
  s.temporal_gradient = true;
  SvgfDenoiser with_nan(s), clean(s);
  for (int t = 0; t < 4; ++t) {
    Frame f = noisy_frame(24, 18, t, true, 0.0f, 1.0f);
    Frame g = f;
    f.gradient.at(4, 4, 0) = std::nanf("");  // a NaN delta
    f.gradient.at(10, 7, 1) = std::numeric_limits<float>::infinity();
    g.gradient.at(4, 4, 2) = 0.0f;  // the same samples simply missing
    g.gradient.at(10, 7, 2) = 0.0f;
    const Frame a = with_nan.process(f), b = clean.process(g);
    for (float v : a.color.data()) ASSERT_TRUE(std::isfinite(v));
    for (float v : with_nan.color_history().data()) ASSERT_TRUE(std::isfinite(v));
    for (float v : with_nan.history_length().data()) ASSERT_TRUE(std::isfinite(v));
    ASSERT_EQ(a.color.data(), b.color.data());
  }
}

}  // namespace
}  // namespace afterimage::svgf
