// SVGF per-pixel functions and spatial passes (svgf/svgf_kernels.h, svgf/filter.h) against
// closed forms: the moving averages are plain means while alpha = 1/(n+1); the central-moment
// form keeps the variance at high luminance where the raw difference mu2 - mu1^2 loses it; the
// B3 kernel sums to 1; a depth step does not bleed; Eq.二.4 shrinks the variance by
// sum h^2 per unweighted iteration; the spatial estimate is used exactly below 4 frames.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "svgf/filter.h"
#include "svgf/reference.h"
#include "svgf/svgf_kernels.h"

namespace afterimage::svgf {
namespace {

const OneTag d1;
float lane(V<OneTag> v) {
  return hn::GetLane(v);
}
V<OneTag> set(float v) {
  return hn::Set(d1, v);
}

TEST(SvgfKernels, AlphaMakesTheFirstFramesAPlainMean) {
  // alpha = 1/(n+1) with n the frames already averaged: the accumulation is the running mean.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 4.0f);
  float acc = 0.0f;
  double sum = 0.0;
  for (int n = 0; n < 10; ++n) {
    const float x = u(rng);
    sum += x;
    const auto a = temporal_alpha(d1, set(float(n)), 0.001f);
    EXPECT_FLOAT_EQ(lane(a), 1.0f / float(n + 1));
    acc = n == 0 ? x : lane(accumulate(d1, set(acc), set(x), a));
    EXPECT_NEAR(acc, sum / (n + 1), 1e-5) << n;
  }
  // Floored by alpha_min, and the history length is capped.
  EXPECT_FLOAT_EQ(lane(temporal_alpha(d1, set(100.0f), 0.2f)), 0.2f);
  EXPECT_FLOAT_EQ(lane(next_history_length(d1, set(31.5f), 32.0f)), 32.0f);
  EXPECT_FLOAT_EQ(lane(next_history_length(d1, set(3.0f), 32.0f)), 4.0f);
}

TEST(SvgfKernels, CentralMomentsEqualTheRawMomentAveragesInExactArithmetic) {
  // Same estimator as mu2' - mu1'^2 of the moving averages (computed here in double).
  std::mt19937 rng(5);
  std::normal_distribution<double> g(2.0, 0.5);
  double mu1 = 0, mu2 = 0;
  Moments<OneTag> m{set(0.0f), set(0.0f)};
  for (int t = 0; t < 50; ++t) {
    const double x = g(rng);
    const double a = std::max(0.2, 1.0 / (t + 1));
    mu1 = t == 0 ? x : (1 - a) * mu1 + a * x;
    mu2 = t == 0 ? x * x : (1 - a) * mu2 + a * x * x;
    m = accumulate_moments(d1, t == 0 ? Moments<OneTag>{set(float(x)), set(0.0f)} : m,
                           set(float(x)), set(float(a)));
    EXPECT_NEAR(lane(m.mean), mu1, 1e-5);
    EXPECT_NEAR(lane(m.var), mu2 - mu1 * mu1, 1e-5) << t;
  }
}

TEST(SvgfKernels, MomentPrecisionAtHighLuminanceWhereThePlainDifferenceFails) {
  // Luminance 3000 with noise sigma 0.5: mu2 ~ 9e6 has a float spacing of 1, so mu2 - mu1^2
  // (seed 001 Eq.二.8 / the paper's raw moments) cannot resolve a variance of 0.25; the central
  // form carries it directly. Truth: the same moving averages in double.
  std::mt19937 rng(11);
  std::normal_distribution<double> g(3000.0, 0.5);
  float mu1 = 0, mu2 = 0;  // the plain form, in float as a GPU or our planes would hold it
  double t1 = 0, t2 = 0;   // double truth of the same estimator
  Moments<OneTag> m{set(0.0f), set(0.0f)};
  double worst_plain = 0, worst_central = 0;
  for (int t = 0; t < 64; ++t) {
    const float x = float(g(rng));
    const float a = std::max(0.2f, 1.0f / float(t + 1));
    if (t == 0) {
      mu1 = x;
      mu2 = x * x;
      t1 = x;
      t2 = double(x) * x;
      m = {set(x), set(0.0f)};
      continue;
    }
    mu1 = (1 - a) * mu1 + a * x;
    mu2 = (1 - a) * mu2 + a * (x * x);
    const double ad = a;  // weights summing to 1 in double (1 - a in float would not)
    t1 = (1 - ad) * t1 + ad * x;
    t2 = (1 - ad) * t2 + ad * x * x;
    m = accumulate_moments(d1, m, set(x), set(a));
    if (t < 8) continue;  // compare once the estimate has settled
    const double truth = t2 - t1 * t1;
    const double plain = lane(raw_moment_variance(d1, set(mu1), set(mu2)));
    worst_plain = std::max(worst_plain, std::abs(plain - truth) / truth);
    worst_central = std::max(worst_central, std::abs(double(lane(m.var)) - truth) / truth);
  }
  EXPECT_LT(worst_central, 1e-2);
  EXPECT_GT(worst_plain, 0.5);  // the plain difference is off by more than half (or 0, or < 0)
}

TEST(SvgfKernels, FastExponentialIsAccurateOverTheWeightRange) {
  double worst = 0;
  for (int i = 0; i <= 87000; ++i) {
    const float e = float(i) * 1e-3f;
    const double truth = std::exp(-double(e));
    worst = std::max(worst, std::abs(double(lane(exp_neg(d1, set(e)))) - truth) / truth);
  }
  // The degree-3 polynomial's 1.0e-4 plus the float rounding of t = -e log2(e) (ulp(125) ~ 8e-6
  // in t at e = 87).
  EXPECT_LT(worst, 1.2e-4);
  EXPECT_EQ(lane(exp_neg(d1, set(0.0f))), 1.0f);
}

TEST(SvgfKernels, BlendedMomentsAreTheBlendOfRawMoments) {
  const V<OneTag> w[3] = {set(0.5f), set(0.3f), set(0.2f)};
  const V<OneTag> mean[3] = {set(1.0f), set(2.0f), set(4.0f)};
  const V<OneTag> var[3] = {set(0.1f), set(0.2f), set(0.4f)};
  double m1 = 0, m2 = 0;
  const double ws[3] = {0.5, 0.3, 0.2}, ms[3] = {1, 2, 4}, vs[3] = {0.1, 0.2, 0.4};
  for (int k = 0; k < 3; ++k) {
    m1 += ws[k] * ms[k];
    m2 += ws[k] * (vs[k] + ms[k] * ms[k]);
  }
  const Moments<OneTag> b = blend_moments<OneTag, 3>(d1, w, mean, var);
  EXPECT_NEAR(lane(b.mean), m1, 1e-6);
  EXPECT_NEAR(lane(b.var), m2 - m1 * m1, 1e-6);
}

TEST(SvgfKernels, LaneFunctionsEqualThePlainOnesBitForBit) {
  // svgf_kernels.h at full width against reference.h, lane by lane, on random inputs including
  // zero alpha, zero lengths, the exponential's clamp and its range ends.
  const FullTag d;
  const size_t n = hn::Lanes(d);
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::exponential_distribution<float> ex(0.5f);
  std::vector<float> a(n), b(n), c(n), e(n), out(n);
  auto lanes = [&](const std::vector<float>& v) { return hn::LoadU(d, v.data()); };
  size_t mismatches = 0;
  auto check = [&](V<FullTag> got, auto plain, const char* what) {
    hn::StoreU(got, d, out.data());
    for (size_t i = 0; i < n; ++i) {
      const float want = plain(i);
      if (std::bit_cast<uint32_t>(out[i]) != std::bit_cast<uint32_t>(want)) {
        if (mismatches++ < 5) ADD_FAILURE() << what << ": " << out[i] << " vs " << want;
      }
    }
  };
  for (int round = 0; round < 2000; ++round) {
    for (size_t i = 0; i < n; ++i) {
      a[i] = round % 7 == 0 ? 0.0f : u(rng);              // alpha, weights
      b[i] = float(int(ex(rng) * 8.0f));                  // history length
      c[i] = ex(rng) * (u(rng) < 0.1f ? 1e4f : 1.0f);     // values
      e[i] = round % 11 == 0 ? 87.0f * u(rng) : ex(rng);  // exponents
    }
    namespace ref = reference;
    check(
        temporal_alpha(d, lanes(b), 0.05f),
        [&](size_t i) { return ref::temporal_alpha(b[i], 0.05f); }, "temporal_alpha");
    check(
        next_history_length(d, lanes(b), 32.0f),
        [&](size_t i) { return ref::next_history_length(b[i], 32.0f); }, "history length");
    check(
        accumulate(d, lanes(c), lanes(e), lanes(a)),
        [&](size_t i) { return ref::accumulate(c[i], e[i], a[i]); }, "accumulate");
    const Moments<FullTag> m = accumulate_moments(d, {lanes(c), lanes(e)}, lanes(b), lanes(a));
    check(
        m.mean,
        [&](size_t i) {
          return ref::accumulate_moments({c[i], e[i]}, b[i], a[i]).mean;
        },
        "moments mean");
    check(
        m.var,
        [&](size_t i) {
          return ref::accumulate_moments({c[i], e[i]}, b[i], a[i]).var;
        },
        "moments var");
    check(
        raw_moment_variance(d, lanes(c), lanes(e)),
        [&](size_t i) { return ref::raw_moment_variance(c[i], e[i]); }, "raw variance");
    const V<FullTag> w2[2] = {lanes(a), hn::Sub(hn::Set(d, 1.0f), lanes(a))};
    const V<FullTag> mean2[2] = {lanes(c), lanes(b)}, var2[2] = {lanes(e), lanes(c)};
    const Moments<FullTag> bm = blend_moments<FullTag, 2>(d, w2, mean2, var2);
    auto plain_blend = [&](size_t i) {
      const float w[2] = {a[i], 1.0f - a[i]}, mean[2] = {c[i], b[i]}, var[2] = {e[i], c[i]};
      return ref::blend_moments<2>(w, mean, var);
    };
    check(
        bm.mean, [&](size_t i) { return plain_blend(i).mean; }, "blend mean");
    check(
        bm.var, [&](size_t i) { return plain_blend(i).var; }, "blend var");
    check(
        demodulation_factor(d, lanes(a), 1e-3f),
        [&](size_t i) { return ref::demodulation_factor(a[i], 1e-3f); }, "demodulation");
    check(
        exp_neg(d, hn::Min(lanes(e), hn::Set(d, 87.0f))),
        [&](size_t i) { return ref::exp_neg(ref::min_ps(e[i], 87.0f)); }, "exp_neg");
    check(
        edge_stopping_weight(d, lanes(e), lanes(c), lanes(a)),
        [&](size_t i) { return ref::edge_stopping_weight(e[i], c[i], a[i]); }, "weight");
    check(
        edge_stopping_weight_exp(d, lanes(e), lanes(c)),
        [&](size_t i) { return ref::edge_stopping_weight_exp(e[i], c[i]); }, "weight exp");
    const auto dot = hn::Sub(hn::Mul(hn::Set(d, 2.0f), lanes(a)), hn::Set(d, 1.0f));
    for (int sigma_n : {128, 64, 7})
      check(
          normal_weight(d, dot, sigma_n),
          [&](size_t i) { return ref::normal_weight(2.0f * a[i] - 1.0f, sigma_n); }, "w_n");
    check(
        normal_exponent(d, dot, 128.0f, 1.38629436f),
        [&](size_t i) { return ref::normal_exponent(2.0f * a[i] - 1.0f, 128.0f, 1.38629436f); },
        "normal exponent");
    check(
        luminance_inv_phi(d, lanes(c), 4.0f),
        [&](size_t i) { return ref::luminance_inv_phi(c[i], 4.0f); }, "inv phi");
    check(
        luminance_exponent(d, lanes(c), lanes(e), lanes(a)),
        [&](size_t i) { return ref::luminance_exponent(c[i], e[i], a[i]); }, "lum exponent");
    check(
        luminance(d, Color3<FullTag>{lanes(a), lanes(c), lanes(e)}),
        [&](size_t i) { return ref::luminance(a[i], c[i], e[i]); }, "luminance");
  }
  EXPECT_EQ(mismatches, 0u);
}

TEST(SvgfKernels, KernelWeightsSumToOneAndEdgeStoppingClosedForms) {
  double h = 0, g = 0;
  for (int j = -2; j <= 2; ++j)
    for (int i = -2; i <= 2; ++i) h += b3_weight(i, j);
  for (int j = -1; j <= 1; ++j)
    for (int i = -1; i <= 1; ++i) g += gauss3_weight(i, j);
  EXPECT_DOUBLE_EQ(h, 1.0);
  EXPECT_DOUBLE_EQ(g, 1.0);
  // The 3x3 kernel (atrous_kernel = 3x3) sums to 1 as well, and each -ln h is the logarithm of
  // its weight (normal_exp folds it into the exponent).
  double h1 = 0;
  for (int j = -1; j <= 1; ++j)
    for (int i = -1; i <= 1; ++i) {
      h1 += atrous_weight<1>(i, j);
      EXPECT_NEAR(std::exp(-double(atrous_neg_log<1>(i, j))), atrous_weight<1>(i, j), 1e-7);
      EXPECT_NEAR(std::exp(-double(atrous_neg_log<2>(i, j))), atrous_weight<2>(i, j), 1e-7);
    }
  EXPECT_DOUBLE_EQ(h1, 1.0);
  EXPECT_DOUBLE_EQ(atrous_weight<1>(0, 0), 0.25);
  EXPECT_NEAR(lane(normal_weight(d1, set(0.99f), 128)), std::pow(0.99, 128), 1e-6);
  EXPECT_EQ(lane(normal_weight(d1, set(-0.5f), 128)), 0.0f);
  EXPECT_NEAR(lane(normal_weight(d1, set(0.9f), 5)), std::pow(0.9, 5), 1e-6);
  // exp(-(|dz| / (sigma_z |grad . dp| + eps) + |dl| / (sigma_l sigma + eps))) w_n
  const auto ez = depth_exponent(d1, set(2.0f), set(2.5f), set(-0.25f), 1.0f, set(0.0f));
  EXPECT_FLOAT_EQ(lane(ez), 2.0f);
  const auto el =
      luminance_exponent(d1, set(1.0f), set(3.0f), luminance_inv_phi(d1, set(0.25f), 4.0f));
  EXPECT_NEAR(lane(el), 1.0f, 1e-6);
  // Within exp_neg's relative error (FastExponentialIsAccurateOverTheWeightRange).
  EXPECT_NEAR(lane(edge_stopping_weight(d1, ez, el, set(0.5f))), 0.5 * std::exp(-3.0),
              0.5 * std::exp(-3.0) * 1.2e-4);
}

// ---- Spatial passes on synthetic images ----------------------------------------------------

struct Scene {
  ImageF depth, normal, gradient;
  Guide guide() const { return {&depth, &normal, &gradient}; }
};
// A fronto-parallel plane (depth `z`, normal +z) with a depth step to `z_right` from column
// `step_x` on (a second fronto-parallel plane).
Scene planes(int w, int h, float z, float z_right = 0, int step_x = 1 << 30) {
  Scene s{ImageF(w, h, 1), ImageF(w, h, 3), ImageF()};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      s.depth.at(x, y, 0) = x >= step_x ? z_right : z;
      s.normal.at(x, y, 2) = 1.0f;
    }
  depth_gradient(s.depth, s.gradient);
  return s;
}

TEST(SvgfFilter, DepthGradientIsExactOnARampAndOneSidedAtASilhouette) {
  ImageF depth(12, 5, 1);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 12; ++x) depth.at(x, y, 0) = x < 6 ? 2.0f + 0.25f * x + 0.5f * y : 40.0f;
  ImageF g;
  depth_gradient(depth, g);
  EXPECT_FLOAT_EQ(g.at(3, 2, 0), 0.25f);
  EXPECT_FLOAT_EQ(g.at(0, 2, 0), 0.25f);  // one-sided at the border
  EXPECT_FLOAT_EQ(g.at(3, 2, 1), 0.5f);
  EXPECT_FLOAT_EQ(g.at(5, 2, 0), 0.25f);  // beside the step: its own surface's slope
  EXPECT_FLOAT_EQ(g.at(6, 2, 0), 0.0f);   // the far plane is flat
}

TEST(SvgfFilter, AtrousKeepsAConstantAndShrinksVarianceByEq24) {
  // Constant color: every luminance weight is 1, the geometry is one plane, so w = 1 and
  // Var' = sum_q h(q)^2 Var(q) / (sum_q h(q))^2 = (70/256)^2 Var at pixels whose taps are all
  // inside the image (Eq.二.4 with the 1D B3 sum of squares 70/256).
  const int w = 80, h = 72;
  const Scene sc = planes(w, h, 5.0f);
  ImageF color(w, h, 3, 0.7f), var(w, h, 1, 0.36f), c1, v1, c2, v2;
  SvgfSettings s;
  atrous_iteration(sc.guide(), color, var, 1, s, c1, v1);
  atrous_iteration(sc.guide(), c1, v1, 2, s, c2, v2);
  const double k = (70.0 / 256.0) * (70.0 / 256.0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      EXPECT_NEAR(c2.at(x, y, 0), 0.7f, 1e-6);
      EXPECT_LE(v1.at(x, y, 0), 0.36f);
      EXPECT_LT(v2.at(x, y, 0), v1.at(x, y, 0));  // shrinks with each iteration
    }
  EXPECT_NEAR(v1.at(40, 36, 0), 0.36 * k, 1e-7);
  EXPECT_NEAR(v2.at(40, 36, 0), 0.36 * k * k, 1e-8);
}

TEST(SvgfFilter, PropagatedVarianceMatchesTheOutputsEmpiricalVariance) {
  // Eq.二.4 predicts the variance of the filtered value: over many independent noise images
  // on one plane with weights all 1 (sigma_l huge), the output's variance at a pixel matches.
  const int w = 24, h = 24, trials = 1500;
  const Scene sc = planes(w, h, 5.0f);
  SvgfSettings s;
  s.sigma_l = 1e3f;  // luminance weights ~1: a pure B3 blur
  std::mt19937 rng(7);
  std::normal_distribution<float> g(1.0f, 0.3f);
  ImageF color(w, h, 3), var(w, h, 1, 0.09f), c1, v1;
  double sum = 0, sum2 = 0;
  for (int t = 0; t < trials; ++t) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const float v = g(rng);
        for (int c = 0; c < 3; ++c) color.at(x, y, c) = v;
      }
    atrous_iteration(sc.guide(), color, var, 1, s, c1, v1);
    sum += c1.at(12, 12, 0);
    sum2 += double(c1.at(12, 12, 0)) * c1.at(12, 12, 0);
  }
  const double mean = sum / trials, emp = sum2 / trials - mean * mean;
  EXPECT_NEAR(emp / v1.at(12, 12, 0), 1.0, 0.1);  // 1500 trials: ~4% standard error
}

TEST(SvgfFilter, DepthStepDoesNotBleedWhereAnUnweightedBlurDoes) {
  // Left plane at depth 2 with luminance 1, right plane at depth 8 with luminance 4, both
  // noisy; five iterations. The weighted filter keeps the mean of each side within 0.1 of its
  // own level next to the edge; the same five iterations without edge stopping (all weights 1)
  // mix them by more than 1.
  const int w = 96, h = 40, edge = 48;
  const Scene sc = planes(w, h, 2.0f, 8.0f, edge);
  std::mt19937 rng(9);
  std::normal_distribution<float> g(0.0f, 0.2f);
  ImageF color(w, h, 3), var(w, h, 1, 0.04f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float v = (x < edge ? 1.0f : 4.0f) + g(rng);
      for (int c = 0; c < 3; ++c) color.at(x, y, c) = v;
    }
  auto run5 = [&](const SvgfSettings& s, bool unweighted) {
    ImageF c = color, v = var, c2, v2;
    Scene flat = planes(w, h, 2.0f);  // one plane: no depth edge at all
    for (int i = 0; i < 5; ++i) {
      atrous_iteration(unweighted ? flat.guide() : sc.guide(), c, v, 1 << i, s, c2, v2);
      std::swap(c, c2);
      std::swap(v, v2);
    }
    return c;
  };
  SvgfSettings weighted;
  SvgfSettings blur;
  blur.sigma_l = 1e3f;
  const ImageF a = run5(weighted, false), b = run5(blur, true);
  auto worst = [&](const ImageF& img) {
    double e = 0;
    for (int y = 0; y < h; ++y)
      for (int x = edge - 3; x < edge + 3; ++x)
        e = std::max(e, std::abs(double(img.at(x, y, 0)) - (x < edge ? 1.0 : 4.0)));
    return e;
  };
  EXPECT_LT(worst(a), 0.25);
  EXPECT_GT(worst(b), 1.0);
}

TEST(SvgfFilter, SpatialVarianceBelowFourFramesTemporalFrom) {
  // Moments with a strong spatial pattern (means 0.5 / 1.5 in a checkerboard) and a small
  // temporal variance 1e-4: the estimate is the window's variance where n < 4 and the pixel's
  // own temporal variance where n >= 4. On one fronto-parallel plane every depth / normal weight
  // is 1, so the spatial estimate is the plain 7x7 variance of the moments (in-image taps).
  const int w = 20, h = 14;
  const Scene sc = planes(w, h, 3.0f);
  ImageF moments(w, h, 2), length(w, h, 1), var;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      moments.at(x, y, 0) = (x + y) % 2 ? 1.5f : 0.5f;
      moments.at(x, y, 1) = 1e-4f;
      length.at(x, y, 0) = float((x + 2 * y) % 6);  // 0..5
    }
  SvgfSettings s;
  estimate_variance(sc.guide(), moments, length, s, var);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double n = 0, m1 = 0, m2 = 0;
      for (int j = -3; j <= 3; ++j)
        for (int i = -3; i <= 3; ++i) {
          const int xx = x + i, yy = y + j;
          if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
          const double m = moments.at(xx, yy, 0);
          n += 1;
          m1 += m;
          m2 += m * m + moments.at(xx, yy, 1);
        }
      const double spatial = m2 / n - (m1 / n) * (m1 / n);
      if (length.at(x, y, 0) < 4.0f) {
        EXPECT_NEAR(var.at(x, y, 0), spatial, 1e-5) << x << "," << y;
        EXPECT_GT(var.at(x, y, 0), 0.2f);
      } else {
        EXPECT_EQ(var.at(x, y, 0), 1e-4f) << x << "," << y;
      }
    }
}

TEST(SvgfFilter, ThreadsAndSimdGiveIdenticalResults) {
  const int w = 61, h = 23;  // not a multiple of the vector width
  const Scene sc = planes(w, h, 2.0f, 6.0f, 30);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 3.0f);
  ImageF color(w, h, 6), var(w, h, 2);
  for (float& v : color.data()) v = u(rng);
  for (float& v : var.data()) v = 0.1f * u(rng);
  SvgfSettings s;
  ImageF ref_c, ref_v;
  atrous_iteration(sc.guide(), color, var, 4, s, ref_c, ref_v, Exec{1, true});
  for (Exec ex : {Exec{2, true}, Exec{2, false}}) {
    ImageF c, v;
    atrous_iteration(sc.guide(), color, var, 4, s, c, v, ex);
    EXPECT_EQ(c, ref_c);
    EXPECT_EQ(v, ref_v);
  }
}

}  // namespace
}  // namespace afterimage::svgf
