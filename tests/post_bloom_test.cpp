// post/bloom: the mip-chain bloom (Jimenez 2014) against hand values, its energy balance, its
// FFT reference with the chain's own PSF, determinism, the NaN policy and the settings table.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "core/error.h"
#include "core/params.h"
#include "metrics/display.h"
#include "metrics/psnr.h"
#include "post/bloom.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"

#include "test_util.h"

using namespace afterimage;
using namespace afterimage::post;

namespace {

double sum_of(const ImageF& img) {
  double s = 0.0;
  for (float v : img.data()) s += double(v);
  return s;
}

// HDR test image: uniform [0, 4) plus sparse bright spikes up to 2000 (scene-like light
// sources), odd size so borders and odd mip sizes are exercised.
ImageF hdr_image(int w, int h, unsigned seed) {
  ImageF img = test::random_image(w, h, 3, seed, 0.0f, 4.0f);
  std::mt19937 rng(seed + 100);
  std::uniform_int_distribution<int> ux(0, w - 1), uy(0, h - 1);
  std::uniform_real_distribution<float> uv(50.0f, 2000.0f);
  for (int i = 0; i < 20; ++i) {
    const int x = ux(rng), y = uy(rng);
    const float v = uv(rng);
    for (int c = 0; c < 3; ++c) img.at(x, y, c) = v * (0.6f + 0.2f * c);
  }
  return img;
}

ImageF point_image(int w, int h, int x, int y, float v, int channels = 3) {
  ImageF img(w, h, channels, 0.0f);
  for (int c = 0; c < channels; ++c) img.at(x, y, c) = v;
  return img;
}

ImageF scene_color(const char* name, int w, int h) {
  render::RenderSettings rs;
  rs.width = w;
  rs.height = h;
  return render::render_gbuffer(render::make_builtin_scene(name), 0, rs, Exec{}).color;
}

// Linear PSNR with peak = max of the reference (metrics::psnr_linear_hdr).
double linear_psnr(const ImageF& ref, const ImageF& test) {
  return metrics::psnr_linear_hdr(ref, test).psnr;
}

// The pixels at least `band` from every border (the edge policies differ).
ImageF crop(const ImageF& img, int band) {
  ImageF out(img.width() - 2 * band, img.height() - 2 * band, img.channels());
  for (int c = 0; c < img.channels(); ++c)
    for (int y = 0; y < out.height(); ++y)
      for (int x = 0; x < out.width(); ++x) out.at(x, y, c) = img.at(x + band, y + band, c);
  return out;
}

// A Gaussian PSF with the same per-axis variance as `psf` (same size, sums to 1).
ImageF matched_gaussian(const ImageF& psf) {
  const int r = psf.width() / 2;
  double var = 0.0, total = 0.0;
  for (int y = 0; y < psf.height(); ++y)
    for (int x = 0; x < psf.width(); ++x) {
      var += double(psf.at(x, y, 0)) * double(x - r) * double(x - r);
      total += psf.at(x, y, 0);
    }
  var /= total;
  ImageF g(psf.width(), psf.height(), 1);
  double gs = 0.0;
  for (int y = 0; y < g.height(); ++y)
    for (int x = 0; x < g.width(); ++x) {
      const double d2 = double(x - r) * (x - r) + double(y - r) * (y - r);
      g.at(x, y, 0) = float(std::exp(-0.5 * d2 / var));
      gs += g.at(x, y, 0);
    }
  for (float& v : g.data()) v = float(v / gs);
  return g;
}

}  // namespace

// ---- Per-pixel math ----------------------------------------------------------------------

TEST(PostBloom, SoftKneeHandValues) {
  // t = 1, knee 0.5 -> k = 0.5: 0 below 0.5, x - 1 above 1.5, (x - 0.5)^2 / 2 between.
  EXPECT_EQ(soft_knee_response(0.0f, 1.0f, 0.5f), 0.0f);
  EXPECT_EQ(soft_knee_response(0.4f, 1.0f, 0.5f), 0.0f);
  EXPECT_EQ(soft_knee_response(0.5f, 1.0f, 0.5f), 0.0f);
  EXPECT_FLOAT_EQ(soft_knee_response(0.75f, 1.0f, 0.5f), 0.03125f);
  EXPECT_FLOAT_EQ(soft_knee_response(1.0f, 1.0f, 0.5f), 0.125f);
  EXPECT_FLOAT_EQ(soft_knee_response(1.25f, 1.0f, 0.5f), 0.28125f);
  EXPECT_FLOAT_EQ(soft_knee_response(1.5f, 1.0f, 0.5f), 0.5f);
  EXPECT_FLOAT_EQ(soft_knee_response(3.0f, 1.0f, 0.5f), 2.0f);
  EXPECT_FLOAT_EQ(soft_knee_response(100.0f, 1.0f, 0.5f), 99.0f);
  // Hard threshold at knee 0.
  EXPECT_EQ(soft_knee_response(0.9f, 1.0f, 0.0f), 0.0f);
  EXPECT_FLOAT_EQ(soft_knee_response(1.7f, 1.0f, 0.0f), 0.7f);
  // Continuous (and C1) at both ends of the knee, never above x, monotone.
  for (float t : {0.5f, 1.0f, 8.0f})
    for (float kn : {0.1f, 0.5f, 1.0f}) {
      const float k = kn * t, e = 1e-3f * t;
      for (float x0 : {t - k, t + k}) {
        EXPECT_NEAR(soft_knee_response(x0 - e, t, kn), soft_knee_response(x0 + e, t, kn), 2.1f * e);
      }
      float prev = 0.0f;
      for (float x = 0.0f; x < 3.0f * t; x += t / 64) {
        const float r = soft_knee_response(x, t, kn);
        EXPECT_LE(r, x + 1e-6f);
        EXPECT_GE(r, prev);
        prev = r;
      }
    }
  // The pixel factor keeps hue: response(max) / max.
  EXPECT_FLOAT_EQ(soft_knee_bright_pass(3.0f, 1.0f, 0.5f), 2.0f / 3.0f);
  EXPECT_EQ(soft_knee_bright_pass(0.0f, 1.0f, 0.5f), 0.0f);
}

TEST(PostBloom, DownsampleAndTentWeights) {
  // The 13 taps' weights (Jimenez 2014): G, D E I J 0.125; B F H L 0.0625; A C K M 0.03125.
  const float want_fixed[13] = {0.03125f, 0.0625f, 0.03125f, 0.125f,   0.125f,  0.0625f, 0.125f,
                                0.0625f,  0.125f,  0.125f,   0.03125f, 0.0625f, 0.03125f};
  float total = 0.0f;
  for (int t = 0; t < 13; ++t) {
    std::array<float, 13> e{};
    e[t] = 1.0f;
    EXPECT_FLOAT_EQ(downsample_13tap(e), want_fixed[t]) << t;
    total += downsample_13tap(e);
  }
  EXPECT_FLOAT_EQ(total, 1.0f);
  // Karis weights with equal group lumas are the plain weights.
  std::array<float, 13> l{};
  l.fill(2.0f);
  const auto gw = karis_group_weights(l);
  EXPECT_FLOAT_EQ(gw[0], 0.5f);
  for (int g = 1; g < 5; ++g) EXPECT_FLOAT_EQ(gw[g], 0.125f);
  EXPECT_FLOAT_EQ(karis_weight(3.0f), 0.25f);

  // Tent upsample: the 3x3 tent (1 2 1)/4 of bilinear fetches at the high pixel's center
  // (low coordinate p/2 + 1/4, radius one low texel) equals the 4-tap polyphase weights.
  auto bilinear_1d = [](const std::vector<float>& v, double pos) {  // pos in texel units
    const double f = pos - 0.5;
    const int j = int(std::floor(f));
    const double a = f - j;
    auto at = [&](int k) { return (k >= 0 && k < int(v.size())) ? double(v[size_t(k)]) : 0.0; };
    return (1 - a) * at(j) + a * at(j + 1);
  };
  std::vector<float> low = {1.0f, 7.0f, -2.0f, 5.0f, 3.0f, 11.0f, 4.0f, 0.5f, 9.0f, 2.0f};
  for (int p = 4; p < 14; ++p) {
    const double c = (p + 0.5) / 2.0;
    const double tent =
        0.25 * bilinear_1d(low, c - 1) + 0.5 * bilinear_1d(low, c) + 0.25 * bilinear_1d(low, c + 1);
    const int j0 = tent_upsample_first_tap(p);
    float v[4];
    for (int a = 0; a < 4; ++a) v[a] = low[size_t(j0 + a)];
    EXPECT_NEAR(tent_upsample_3x3(v, p), tent, 1e-5) << p;
  }
}

// ---- Karis average ---------------------------------------------------------------------

TEST(PostBloom, KarisAverageDampsAFireflyOnTheFirstLevelOnly) {
  // A firefly F at texel (7, 7) of a black 16x16 image. Output (4, 4) of level 1 has its
  // center at texel corner (9, 9): the firefly is in tap A (texels 6..7) and tap D (7..8)
  // only, each a 2x2 average, so each reads F/4.
  //   plain: 0.03125 F/4 + 0.125 F/4 = 0.0390625 F
  //   Karis: groups {D,E,I,J} (0.5) and {A,B,F,G} (0.125) have mean F/16 and weight
  //          k = 1 / (1 + F/16); the three other outer groups are black (weight 1):
  //          (0.5 + 0.125) k F/16 / (0.625 k + 0.375)
  const float F = 1000.0f;
  const ImageF img = point_image(16, 16, 7, 7, F);
  BloomSettings plain;
  plain.levels = 2;
  BloomSettings karis = plain;
  karis.karis = true;
  const auto mp = bloom_mips(img, plain), mk = bloom_mips(img, karis);
  const double k = 1.0 / (1.0 + F / 16.0);
  const double want_karis = 0.625 * k * (F / 16.0) / (0.625 * k + 0.375);
  for (int c = 0; c < 3; ++c) {
    EXPECT_FLOAT_EQ(mp[1].at(4, 4, c), 0.0390625f * F);
    EXPECT_NEAR(mk[1].at(4, 4, c), want_karis, 1e-4 * want_karis);
  }
  EXPECT_LT(mk[1].at(4, 4, 0), 0.05f * mp[1].at(4, 4, 0));
  // The firefly's total contribution to level 1 is reduced (plain: exactly F/4 per channel).
  EXPECT_NEAR(sum_of(mp[1]) / 3.0, F / 4.0, 1e-3 * F);
  EXPECT_LT(sum_of(mk[1]), 0.5 * sum_of(mp[1]));
  // Level 2 is the plain 13-tap downsample of (Karis) level 1: Karis on the first level only.
  BloomSettings one = plain;
  one.levels = 1;
  EXPECT_EQ(mk[2], bloom_mips(mk[1], one)[1]);
  // And the blur differs only through level 1.
  EXPECT_NE(bloom_blur(img, karis), bloom_blur(img, plain));
}

// ---- Energy ------------------------------------------------------------------------------

// Threshold-less mode (the default) conserves energy: sum(out) = sum(in) up to float rounding
// (the conserving edge policy). Tolerance 1e-4 relative, measured worst ~1e-6 (printed).
TEST(PostBloom, ThresholdlessModeConservesEnergy) {
  const double kTol = 1e-4;
  double worst = 0.0;
  auto check = [&](const ImageF& in, const BloomSettings& s, const char* what) {
    const ImageF out = bloom(in, s);
    const ImageF light = bloom_blur(bloom_source(in, s), s);
    const double e_out = std::abs(sum_of(out) / sum_of(in) - 1.0);
    const double e_light = std::abs(sum_of(light) / sum_of(in) - 1.0);
    worst = std::max({worst, e_out, e_light});
    EXPECT_LT(e_out, kTol) << what << " levels " << s.levels;
    EXPECT_LT(e_light, kTol) << what << " levels " << s.levels;
  };
  for (int levels : {1, 3, 6, 9}) {
    BloomSettings s;
    s.levels = levels;
    s.intensity = 0.5f;
    check(hdr_image(257, 89, 1), s, "random 257x89");
    check(hdr_image(64, 33, 2), s, "random 64x33");
    check(point_image(101, 77, 50, 38, 1e4f), s, "bright point, center");
    check(point_image(101, 77, 0, 0, 1e4f), s, "bright point, corner");
    check(point_image(101, 77, 100, 3, 1e4f), s, "bright point, right edge");
    check(point_image(5, 3, 4, 2, 1e4f), s, "tiny image");
  }
  std::printf("[bloom] threshold-less energy: worst |sum out / sum in - 1| = %.3g\n", worst);

  // Karis trades energy for stability (measured, not a conservation test).
  BloomSettings k;
  k.karis = true;
  k.intensity = 1.0f;
  const ImageF scene = hdr_image(257, 89, 1);
  const double loss_scene = 1.0 - sum_of(bloom_blur(bloom_source(scene, k), k)) / sum_of(scene);
  const ImageF pt = point_image(101, 77, 50, 38, 1e4f);
  const double loss_point = 1.0 - sum_of(bloom_blur(pt, k)) / sum_of(pt);
  std::printf("[bloom] karis energy loss of the scattered light: random HDR %.3f, point %.4f\n",
              loss_scene, loss_point);
  EXPECT_GT(loss_point, 0.5);  // measured 0.75
}

// With a threshold, energy is conserved for scale 1 too (the bright part is moved, not added),
// and scale s adds (s - 1) intensity sum(P).
TEST(PostBloom, BrightPassMovesOnlyTheBrightPart) {
  const ImageF in = hdr_image(123, 77, 3);
  BloomSettings s;
  s.threshold = 8.0f;
  s.intensity = 0.7f;
  const ImageF p = bloom_source(in, s);
  for (int y = 0; y < in.height(); ++y)
    for (int x = 0; x < in.width(); ++x)
      if (in.at(x, y, 0) < 4.0f && in.at(x, y, 1) < 4.0f && in.at(x, y, 2) < 4.0f) {
        ASSERT_EQ(p.at(x, y, 0) + p.at(x, y, 1) + p.at(x, y, 2), 0.0f);
      }
  // A spike of 1000 * (0.6, 0.8, 1.0): max 1000 -> factor (1000 - 8) / 1000, hue kept.
  EXPECT_NEAR(std::abs(sum_of(bloom(in, s)) / sum_of(in) - 1.0), 0.0, 1e-5);
  BloomSettings g = s;
  g.scale = 2.0f;
  EXPECT_NEAR(sum_of(bloom(in, g)) - sum_of(in), 0.7 * sum_of(p), 1e-4 * sum_of(in));
  const ImageF pt = point_image(9, 9, 4, 4, 1000.0f);
  EXPECT_FLOAT_EQ(bloom_source(pt, s).at(4, 4, 1), 992.0f);
}

// ---- FFT reference -----------------------------------------------------------------------

TEST(PostBloom, PsfIsNormalisedCompactAndSymmetric) {
  BloomSettings s;
  s.levels = 5;
  const ImageF psf = bloom_psf(s);
  const int r = bloom_psf_radius(s);
  ASSERT_EQ(psf.width(), 2 * r + 1);
  EXPECT_NEAR(sum_of(psf), 1.0, 1e-5);
  double ring = 0.0;
  int support = 0;
  for (int y = 0; y < psf.height(); ++y)
    for (int x = 0; x < psf.width(); ++x) {
      ASSERT_GE(psf.at(x, y, 0), 0.0f);
      if (psf.at(x, y, 0) > 0.0f) support = std::max({support, std::abs(x - r), std::abs(y - r)});
      if (std::abs(x - r) > r - 8 || std::abs(y - r) > r - 8) ring += psf.at(x, y, 0);
      // Same filters on both axes (not bit-exact: the axes are filtered in a fixed order).
      ASSERT_NEAR(psf.at(x, y, 0), psf.at(y, x, 0), 1e-6f * psf.at(r, r, 0));
    }
  EXPECT_EQ(ring, 0.0);  // the radius bound holds with margin: no edge folding in the PSF
  std::printf("[bloom] PSF levels %d: support radius %d px (bound %d)\n", s.levels, support, r);
}

// The chain against the FFT convolution with its own PSF (taken at phase 0 of every level):
// the difference is the chain's shift variance and its per-level edge folding. PSNR on linear
// values of the scattered light L, peak = max of the reference (metrics::psnr_linear_hdr).
TEST(PostBloom, ChainMatchesFftReferenceWithItsOwnPsf) {
  BloomSettings s;  // default: 6 levels, threshold-less
  const ImageF psf = bloom_psf(s);
  const ImageF gauss = matched_gaussian(psf);
  struct Case {
    const char* name;
    ImageF img;
    double min_psnr;
  };
  std::vector<Case> cases;
  // A point at phase 0 of every level (like the PSF's) far from the borders: the same linear
  // operator, so only float rounding differs.
  cases.push_back({"point phase 0", point_image(1024, 1024, 512, 512, 1000.0f), 90.0});
  // A point at an odd phase far from the borders: the chain's shift variance alone.
  cases.push_back({"point odd phase", point_image(1024, 1024, 517, 493, 1000.0f), 40.0});
  // Near borders the chain folds light back per level, the reference once.
  cases.push_back({"point near edge", point_image(321, 181, 157, 93, 1000.0f), 40.0});
  cases.push_back({"random HDR", hdr_image(257, 143, 5), 33.0});
  cases.push_back({"thin scene", scene_color("thin", 320, 180), 45.0});
  cases.push_back({"sparkle scene", scene_color("sparkle", 320, 180), 40.0});
  for (const Case& c : cases) {
    const ImageF p = bloom_source(c.img, s);
    const ImageF chain = bloom_blur(p, s);
    const ImageF ref = bloom_reference_fft(p, psf);
    const ImageF ref_gauss = bloom_reference_fft(p, gauss);
    EXPECT_NEAR(sum_of(ref) / sum_of(p), 1.0, 1e-6) << c.name;  // reference conserves too
    const double q = linear_psnr(ref, chain);
    const double qg = linear_psnr(ref_gauss, chain);
    // The full-intensity composite (out = L) on the display transform (Reinhard + sRGB).
    BloomSettings full = s;
    full.intensity = 1.0f;
    const metrics::DisplaySettings ds;
    const double qd =
        metrics::psnr(metrics::to_display(bloom_composite(c.img, p, ref, full), ds),
                      metrics::to_display(bloom_composite(c.img, p, chain, full), ds));
    const double qi = metrics::psnr_from_mse(
        metrics::mean_squared_error(crop(ref, 48), crop(chain, 48)),
        metrics::psnr_linear_hdr(ref, chain).peak);  // same peak as the whole image
    std::printf(
        "[bloom] %-16s L vs FFT(own PSF) %.1f dB linear (%.1f dB 48 px from the "
        "borders), %.1f dB display; vs FFT(matched Gaussian) %.1f dB linear\n",
        c.name, q, qi, qd, qg);
    EXPECT_GE(q, c.min_psnr) << c.name;
  }
}

// A point centred in an image whose size is a multiple of 2^levels (a 2x2 block, centred on
// the image center) blooms symmetrically under x and y mirrors and the transpose.
TEST(PostBloom, CentredPointIsMirrorSymmetric) {
  BloomSettings s;
  s.intensity = 0.5f;
  const int n = 256;
  ImageF img(n, n, 3, 0.0f);
  for (int y : {n / 2 - 1, n / 2})
    for (int x : {n / 2 - 1, n / 2})
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = 500.0f;
  const ImageF out = bloom(img, s);
  float peak = 0.0f;
  for (float v : out.data()) peak = std::max(peak, v);
  const float tol = 1e-6f * peak;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const float v = out.at(x, y, 1);
      ASSERT_NEAR(v, out.at(n - 1 - x, y, 1), tol) << x << "," << y;
      ASSERT_NEAR(v, out.at(x, n - 1 - y, 1), tol) << x << "," << y;
      ASSERT_NEAR(v, out.at(y, x, 1), tol) << x << "," << y;
    }
}

// ---- Determinism, NaN policy, settings -----------------------------------------------------

TEST(PostBloom, AnyThreadCountAndSimdFlagAreBitIdentical) {
  const ImageF img = hdr_image(211, 97, 7);
  for (bool karis : {false, true}) {
    BloomSettings s;
    s.karis = karis;
    s.threshold = karis ? 1.0f : 0.0f;
    const ImageF a = bloom(img, s, test::scalar_exec());
    for (int threads : {0, 1, 2, 3}) {
      Exec ex;
      ex.threads = threads;
      EXPECT_EQ(bloom(img, s, ex), a) << threads;
    }
  }
}

TEST(PostBloom, NonFinitePixelsDoNotSpread) {
  ImageF img = hdr_image(97, 61, 8);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  img.at(40, 30, 0) = nan;
  img.at(10, 50, 2) = inf;
  img.at(90, 5, 1) = -inf;
  img.at(60, 20, 1) = -3.0f;  // negative light scatters nothing either
  for (float thr : {0.0f, 2.0f}) {
    BloomSettings s;
    s.intensity = 0.3f;
    s.threshold = thr;
    s.karis = thr > 0;
    const ImageF p = bloom_source(img, s);
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(p.at(40, 30, c), 0.0f);
      EXPECT_EQ(p.at(10, 50, c), 0.0f);
      EXPECT_EQ(p.at(90, 5, c), 0.0f);
    }
    EXPECT_EQ(p.at(60, 20, 1), 0.0f);
    const ImageF out = bloom(img, s);
    int non_finite = 0;
    for (int c = 0; c < 3; ++c)
      for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x)
          if (!std::isfinite(out.at(x, y, c))) {
            ++non_finite;
            EXPECT_FALSE(std::isfinite(img.at(x, y, c))) << x << "," << y;
          }
    EXPECT_EQ(non_finite, 3);  // only the three non-finite input values, where they were
    EXPECT_TRUE(std::isnan(out.at(40, 30, 0)));
    EXPECT_EQ(out.at(10, 50, 2), inf);
    EXPECT_EQ(out.at(90, 5, 1), -inf);
  }
}

TEST(PostBloom, SettingsAreValidatedAndRegistered) {
  EXPECT_TRUE(settings::all_members_registered<BloomSettings>());
  EXPECT_EQ(
      BloomSettings::params().keys(),
      (std::vector<std::string>{"intensity", "levels", "threshold", "knee", "scale", "karis"}));
  const ImageF img = hdr_image(17, 9, 9);
  auto message = [&](BloomSettings s) {
    return test::error_of<SettingsError>([&] { (void)bloom(img, s); });
  };
  BloomSettings s;
  s.intensity = 1.5f;
  EXPECT_NE(message(s).find("intensity"), std::string::npos);
  s = {};
  s.intensity = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(message(s).find("intensity"), std::string::npos);
  s = {};
  s.levels = 0;
  EXPECT_NE(message(s).find("levels"), std::string::npos);
  s = {};
  s.levels = 13;
  EXPECT_NE(message(s).find("levels"), std::string::npos);
  s = {};
  s.threshold = -1.0f;
  EXPECT_NE(message(s).find("threshold"), std::string::npos);
  s = {};
  s.knee = 2.0f;
  EXPECT_NE(message(s).find("knee"), std::string::npos);
  s = {};
  s.scale = -1.0f;
  EXPECT_NE(message(s).find("scale"), std::string::npos);
  BloomSettings p;
  EXPECT_THROW(BloomSettings::params().set(p, "radius", "3"), SettingsError);
  BloomSettings::params().set(p, "karis", "true");
  BloomSettings::params().set(p, "levels", "4");
  EXPECT_TRUE(p.karis);
  EXPECT_EQ(p.levels, 4);
  p.levels = 9;
  EXPECT_THROW(bloom_psf(p), SettingsError);  // PSF only up to 8 levels (memory)
  EXPECT_THROW(bloom(ImageF{}, BloomSettings{}), InputError);
  EXPECT_EQ(bloom(img, BloomSettings{0.0f}), img);  // intensity 0: a copy
}

// bloom() never stores P or L at full resolution (it computes P's rows inside the first
// downsample and composites inside the last upsample); it must still be exactly the
// composition of the three public steps, with and without a bright pass.
TEST(PostBloom, FusedPassEqualsTheComposedSteps) {
  ImageF img = hdr_image(203, 117, 11);
  img.at(50, 60, 1) = std::numeric_limits<float>::quiet_NaN();
  for (float thr : {0.0f, 1.5f}) {
    BloomSettings s;
    s.intensity = 0.4f;
    s.threshold = thr;
    s.levels = 5;
    const ImageF p = bloom_source(img, s);
    const ImageF composed = bloom_composite(img, p, bloom_blur(p, s), s);
    const ImageF fused = bloom(img, s);
    ASSERT_TRUE(fused.same_shape(composed));
    for (size_t i = 0; i < fused.data().size(); ++i) {
      const float a = fused.data()[i], b = composed.data()[i];
      ASSERT_TRUE(a == b || (std::isnan(a) && std::isnan(b))) << i << " threshold " << thr;
    }
  }
}
