// The fast spatial passes of SVGF (svgf/filter.h: estimate_variance, atrous_iteration,
// atrous_iteration_remodulated) against their plain specification in the library
// (svgf/reference.h; seed 001 Eq.二.1-二.4; Schied et al. 2017 Sec. 4.2-4.3). Every output bit
// must match, on random images with depth steps, normal creases, background pixels (normal 0),
// zero-variance patches and fireflies, at sizes that are not a multiple of any lane or block
// width, for several steps, 1 and 2 signals, sigma_n 128 (the unrolled path) and another, the
// normal term in the exponent (normal_exp), 1 and 2 threads, and --simd off (which runs the
// plain version).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>

#include "core/image.h"
#include "core/parallel.h"
#include "frame/frame.h"
#include "svgf/filter.h"
#include "svgf/reference.h"
#include "svgf/settings.h"

namespace afterimage::svgf {
namespace {

// The plain specification (svgf/reference.h), one thread: what the fast stages must equal.
const Exec kPlain{1, false};

// ---- Random scenes -------------------------------------------------------------------------

struct Scene {
  ImageF depth, normal, gradient, color, var, moments, length;
};

// Two slanted planes meeting at a depth step, a crease in the normals, a background corner
// (normal 0, background depth), exponential 1-spp-like color with fireflies, a patch of zero
// variance (constant color), and history lengths on both sides of the temporal threshold.
Scene random_scene(int w, int h, int signals, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::exponential_distribution<float> ex(1.0f);
  Scene sc{
      ImageF(w, h, 1),       ImageF(w, h, 3),           ImageF(w, h, 2), ImageF(w, h, 3 * signals),
      ImageF(w, h, signals), ImageF(w, h, 2 * signals), ImageF(w, h, 1)};
  const int step_x = w / 3 + 1, crease_y = h / 2;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool near = x < step_x;
      const bool background = x >= w - w / 5 && y < h / 4;
      sc.depth.at(x, y, 0) = background ? kBackgroundDepth
                             : near     ? 2.0f + 0.01f * float(x) + 0.003f * float(y)
                                        : 6.0f + 0.05f * float(y);
      sc.gradient.at(x, y, 0) = near ? 0.01f : (u(rng) < 0.1f ? 0.5f * u(rng) : 0.0f);
      sc.gradient.at(x, y, 1) = near ? 0.003f : 0.05f;
      const float tilt = y < crease_y ? 0.2f : -0.35f + 0.02f * u(rng);
      sc.normal.at(x, y, 0) = background ? 0.0f : tilt;
      sc.normal.at(x, y, 1) = 0.0f;
      sc.normal.at(x, y, 2) = background ? 0.0f : std::sqrt(1.0f - tilt * tilt);
      const bool flat = x < w / 6 && y >= h - h / 4;  // constant color, zero variance
      for (int sg = 0; sg < signals; ++sg) {
        const float sample = u(rng) < 0.01f ? 50.0f : ex(rng);
        for (int ch = 0; ch < 3; ++ch)
          sc.color.at(x, y, 3 * sg + ch) = flat ? 0.5f : (0.2f + 0.3f * float(ch)) * sample;
        sc.var.at(x, y, sg) = flat ? 0.0f : ex(rng) * (u(rng) < 0.05f ? 100.0f : 1.0f);
        sc.moments.at(x, y, 2 * sg) = flat ? 0.5f : ex(rng);
        sc.moments.at(x, y, 2 * sg + 1) = flat ? 0.0f : ex(rng);
      }
      sc.length.at(x, y, 0) = float(int(u(rng) * 8.0f));
    }
  return sc;
}

// Number of outputs whose bits differ (NaN included); the first in `where`.
size_t bit_mismatches(const ImageF& a, const ImageF& b, std::string& where) {
  EXPECT_EQ(a.width(), b.width());
  EXPECT_EQ(a.height(), b.height());
  EXPECT_EQ(a.channels(), b.channels());
  size_t n = 0;
  for (int c = 0; c < a.channels(); ++c)
    for (int y = 0; y < a.height(); ++y)
      for (int x = 0; x < a.width(); ++x)
        if (std::bit_cast<uint32_t>(a.at(x, y, c)) != std::bit_cast<uint32_t>(b.at(x, y, c))) {
          if (n++ == 0)
            where = fmt::format("({},{}) c{}: {} vs {}", x, y, c, a.at(x, y, c), b.at(x, y, c));
        }
  return n;
}

const Exec kExecs[] = {{1, true}, {2, true}, {1, false}, {2, false}};
const char* exec_name(const Exec& e) {
  return e.simd ? (e.threads == 1 ? "1 thread" : "2 threads")
                : (e.threads == 1 ? "1 thread simd off" : "2 threads simd off");
}

struct Case {
  int w, h, signals, sigma_n;
  float sigma_l;
  bool normal_exp = false;
  AtrousKernel kernel = AtrousKernel::B3_5x5;
};
// Widths around and below the 16-lane AVX-512 width and not multiples of 4, 8 or 16.
const Case kCases[] = {{37, 23, 1, 128, 4.0f},
                       {53, 41, 2, 128, 2.0f},
                       {7, 5, 1, 64, 4.0f},
                       {70, 19, 2, 16, 8.0f},
                       {37, 23, 1, 128, 2.0f, true},
                       {53, 41, 2, 128, 4.0f, true},
                       {37, 23, 1, 128, 2.0f, true, AtrousKernel::Linear3x3},
                       {53, 41, 2, 128, 4.0f, false, AtrousKernel::Linear3x3},
                       {7, 5, 2, 64, 4.0f, true, AtrousKernel::Linear3x3}};

// The paper's settings with the case's weights.
SvgfSettings settings_of(const Case& c) {
  SvgfSettings s = preset_svgf_paper();
  s.sigma_n = c.sigma_n;
  s.sigma_l = c.sigma_l;
  s.normal_exp = c.normal_exp;
  s.atrous_kernel = c.kernel;
  return s;
}

TEST(SvgfFilterExact, AtrousEqualsTheReferenceBitForBit) {
  uint32_t seed = 1;
  for (const Case& c : kCases) {
    const Scene sc = random_scene(c.w, c.h, c.signals, seed++);
    const SvgfSettings s = settings_of(c);
    const Guide g{&sc.depth, &sc.normal, &sc.gradient};
    for (int step : {1, 2, 4, 8, 16}) {
      ImageF ref_c, ref_v;
      reference::atrous_iteration(g, sc.color, sc.var, step, s, ref_c, ref_v, kPlain);
      for (const Exec& ex : kExecs) {
        ImageF out_c, out_v;
        atrous_iteration(g, sc.color, sc.var, step, s, out_c, out_v, ex);
        std::string where;
        EXPECT_EQ(bit_mismatches(out_c, ref_c, where), 0u)
            << c.w << "x" << c.h << " S" << c.signals << " step " << step << " " << exec_name(ex)
            << " color " << where;
        EXPECT_EQ(bit_mismatches(out_v, ref_v, where), 0u)
            << c.w << "x" << c.h << " S" << c.signals << " step " << step << " " << exec_name(ex)
            << " variance " << where;
      }
    }
  }
}

TEST(SvgfFilterExact, ChainedIterationsEqualTheReferenceBitForBit) {
  // Five iterations feeding each other (the denoiser's loop), outputs reused as scratch.
  const Scene sc = random_scene(45, 31, 1, 11);
  const SvgfSettings s = preset_svgf_paper();
  const Guide g{&sc.depth, &sc.normal, &sc.gradient};
  ImageF rc = sc.color, rv = sc.var, c = sc.color, v = sc.var, tc, tv;
  for (int i = 0; i < 5; ++i) {
    ImageF nc, nv;
    reference::atrous_iteration(g, rc, rv, 1 << i, s, nc, nv, kPlain);
    rc = nc;
    rv = nv;
    atrous_iteration(g, c, v, 1 << i, s, tc, tv, Exec{2, true});
    std::swap(c, tc);
    std::swap(v, tv);
  }
  std::string where;
  EXPECT_EQ(bit_mismatches(c, rc, where), 0u) << where;
  EXPECT_EQ(bit_mismatches(v, rv, where), 0u) << where;
}

TEST(SvgfFilterExact, RemodulatedIterationEqualsTheReferenceBitForBit) {
  // The last iteration with the remodulation in its store (atrous_iteration_remodulated) against
  // the plain à-trous then remodulation (reference.h atrous_at, remodulate_at): every factor, with
  // and without emission, albedo below eps, subnormal products (the remodulation must not run with
  // subnormals flushed) and products that overflow (the input color then).
  uint32_t seed = 100;
  for (const Case& c : kCases) {
    const Scene sc = random_scene(c.w, c.h, c.signals, seed++);
    const SvgfSettings s = settings_of(c);
    const Guide g{&sc.depth, &sc.normal, &sc.gradient};
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    ImageF emission(c.w, c.h, 3), albedo(c.w, c.h, 3), color(c.w, c.h, 3);
    for (int y = 0; y < c.h; ++y)
      for (int x = 0; x < c.w; ++x)
        for (int ch = 0; ch < 3; ++ch) {
          const float p = u(rng);
          emission.at(x, y, ch) = p < 0.3f ? 0.0f : 0.1f * u(rng);
          albedo.at(x, y, ch) = p < 0.05f   ? 1e-40f  // subnormal products
                                : p < 0.08f ? 3e38f   // overflow
                                : p < 0.15f ? 1e-4f   // below eps
                                            : u(rng);
          color.at(x, y, ch) = 7.0f + u(rng);
        }
    using R = Remodulation;
    const R factors[][2] = {
        {R::Demodulated, R::Demodulated}, {R::Albedo, R::One}, {R::One, R::One}};
    for (const auto& f : factors)
      for (const bool with_emission : {false, true})
        for (int step : {1, 4}) {
          RemodulationInputs r;
          r.factor[0] = f[0];
          r.factor[1] = f[1];
          r.emission = with_emission ? &emission : nullptr;
          r.albedo = &albedo;
          r.color = &color;
          ImageF ref_c, ref_v, ref, ref_filtered;
          reference::atrous_iteration(g, sc.color, sc.var, step, s, ref_c, ref_v, kPlain);
          reference::atrous_iteration_remodulated(g, sc.color, sc.var, step, s, r, ref,
                                                  &ref_filtered, kPlain);
          std::string where;
          EXPECT_EQ(bit_mismatches(ref_filtered, ref_c, where), 0u) << where;
          for (const Exec& ex : kExecs) {
            ImageF out, filtered;
            atrous_iteration_remodulated(g, sc.color, sc.var, step, s, r, out, nullptr, ex);
            EXPECT_EQ(bit_mismatches(out, ref, where), 0u)
                << c.w << "x" << c.h << " S" << c.signals << " step " << step << " "
                << exec_name(ex) << " factor " << int(f[0]) << int(f[1]) << " emission "
                << with_emission << " " << where;
            out = ImageF();
            atrous_iteration_remodulated(g, sc.color, sc.var, step, s, r, out, &filtered, ex);
            EXPECT_EQ(bit_mismatches(out, ref, where), 0u) << where;
            EXPECT_EQ(bit_mismatches(filtered, ref_c, where), 0u) << where;
          }
        }
  }
}

TEST(SvgfFilterExact, VarianceEqualsTheReferenceBitForBit) {
  uint32_t seed = 100;
  for (const Case& c : kCases)
    for (int radius : {3, 1}) {
      const Scene sc = random_scene(c.w, c.h, c.signals, seed++);
      SvgfSettings s = preset_svgf_paper();
      s.sigma_n = c.sigma_n;
      s.normal_exp = c.normal_exp;
      s.spatial_radius = radius;
      const Guide g{&sc.depth, &sc.normal, &sc.gradient};
      ImageF ref;
      reference::estimate_variance(g, sc.moments, sc.length, s, ref, kPlain);
      for (const Exec& ex : kExecs) {
        ImageF out;
        estimate_variance(g, sc.moments, sc.length, s, out, ex);
        std::string where;
        EXPECT_EQ(bit_mismatches(out, ref, where), 0u)
            << c.w << "x" << c.h << " S" << c.signals << " radius " << radius << " "
            << exec_name(ex) << " " << where;
      }
    }
}

TEST(SvgfFilterExact, DepthGradientEqualsTheReferenceBitForBit) {
  // Slanted planes with a silhouette, background pixels and exact ties between the one-sided
  // differences, at widths below, around and not a multiple of the lane width.
  uint32_t seed = 300;
  for (const Case& c : kCases) {
    const Scene sc = random_scene(c.w, c.h, 1, seed++);
    ImageF depth = sc.depth;
    depth.at(c.w / 2, c.h / 2, 0) = 1e30f;  // a spike: both differences huge, opposite signs
    ImageF ref;
    reference::depth_gradient(depth, ref, kPlain);
    for (const Exec& ex : kExecs) {
      ImageF out;
      depth_gradient(depth, out, ex);
      std::string where;
      EXPECT_EQ(bit_mismatches(out, ref, where), 0u)
          << c.w << "x" << c.h << " " << exec_name(ex) << " " << where;
    }
  }
}

TEST(SvgfFilterExact, SubnormalWeightsAreFlushed) {
  // Black near surface (depth 1) beside a bright far one (depth 100), flat normals: the far
  // taps' depth exponent is clamped at 87, so with the power form their weight exp(-87) h(q)
  // is below 2^-126 and flushed to 0: the near pixels stay exactly black. Without flushing
  // they would get about 1e-36 (the weight times 1e3). normal_exp keeps the weight normal
  // (h(q) is inside its exponent, clamped at 87), so there the far taps still count, barely.
  const int w = 24, h = 20;
  ImageF depth(w, h, 1), normal(w, h, 3, 0.0f), gradient(w, h, 2, 0.0f), color(w, h, 3);
  ImageF var(w, h, 1, 1.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool near = x < w / 2;
      depth.at(x, y, 0) = near ? 1.0f : 100.0f;
      normal.at(x, y, 2) = 1.0f;
      for (int c = 0; c < 3; ++c) color.at(x, y, c) = near ? 0.0f : 1000.0f;
    }
  const Guide g{&depth, &normal, &gradient};
  for (const bool exp_form : {false, true}) {
    SvgfSettings s = preset_svgf_paper();
    s.normal_exp = exp_form;
    for (const Exec& ex : kExecs) {
      ImageF out_c, out_v;
      atrous_iteration(g, color, var, 1, s, out_c, out_v, ex);
      const float v = out_c.at(w / 2 - 1, h / 2, 0);
      if (exp_form)
        EXPECT_GT(v, 0.0f) << exec_name(ex);
      else
        EXPECT_EQ(v, 0.0f) << exec_name(ex);
      EXPECT_LT(v, 1e-30f) << exec_name(ex);
    }
  }
}

TEST(SvgfFilterExact, ReferenceIsNotTrivial) {
  // The comparison can fail: the edge-stopping weights move the result away from the
  // unweighted B3 blur and from the input, and a 0.1% change of one input changes outputs.
  const Scene sc = random_scene(37, 23, 1, 7);
  const SvgfSettings s = preset_svgf_paper();
  const Guide g{&sc.depth, &sc.normal, &sc.gradient};
  ImageF a_c, a_v, b_c, b_v;
  atrous_iteration(g, sc.color, sc.var, 1, s, a_c, a_v);
  std::string where;
  EXPECT_GT(bit_mismatches(a_c, sc.color, where), size_t(37 * 23 / 2));
  ImageF nudged = sc.color;
  nudged.at(20, 10, 1) *= 1.001f;
  atrous_iteration(g, nudged, sc.var, 1, s, b_c, b_v);
  EXPECT_GT(bit_mismatches(a_c, b_c, where), 0u);
}

}  // namespace
}  // namespace afterimage::svgf
