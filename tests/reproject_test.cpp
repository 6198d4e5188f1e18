// reproject/: history position, footprint, consistency tests and N-plane gathers, each
// against an independent truth (hand values, the scalar samplers of core/sampler.h, exact
// ramps). Odd sizes (257x89) exercise SIMD tails and borders.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <tuple>
#include <vector>

#include "core/sampler.h"
#include "lane_test_util.h"
#include "reproject/consistency.h"
#include "reproject/footprint.h"
#include "reproject/gather.h"
#include "reproject/history.h"
#include "test_util.h"

using namespace afterimage;
using namespace afterimage::reproject;
using namespace afterimage::test;

namespace {

template <class D>
std::vector<bool> mask_lanes(D d, hn::Mask<D> m) {
  auto v = lanes(d, hn::IfThenElse(m, hn::Set(d, 1.0f), hn::Zero(d)));
  return std::vector<bool>(v.begin(), v.end());
}

// Random sources (test::random_image) hold values in [0, 4); random motion fields (2 planes)
// in [-6, 6) px: sub-pixel, off-screen and large values.

// Resamples every pixel of `src` at p + motion with `fetch` (full width then 1 lane, or only
// 1 lane), returning the N planes and the N-plane footprint box (lo then hi).
template <int N, class Fetch>
ImageF resample(const ImageF& src, const ImageF& motion, bool simd, Fetch fetch) {
  const int w = src.width(), h = src.height();
  const Planes<N> p = planes_of<N>(src);
  ImageF out(w, h, 3 * N);
  Exec ex;
  ex.simd = simd;
  for (int y = 0; y < h; ++y)
    for_each_lane_block(ex, w, [&](auto d, int x) {
      using D = decltype(d);
      auto px = hn::Add(pixel_center_x(d, x), hn::LoadU(d, motion.row(0, y) + x));
      auto py = hn::Add(hn::Set(d, float(y) + 0.5f), hn::LoadU(d, motion.row(1, y) + x));
      PixelBox<D, N> box;
      Pixel<D, N> r = fetch(d, p, px, py, &box);
      for (int c = 0; c < N; ++c) {
        hn::StoreU(r.v[c], d, out.row(c, y) + x);
        hn::StoreU(box.lo.v[c], d, out.row(N + c, y) + x);
        hn::StoreU(box.hi.v[c], d, out.row(2 * N + c, y) + x);
      }
    });
  return out;
}

auto all_fetchers() {
  return std::make_tuple(
      [](auto d, const auto& p, auto x, auto y, auto* b) { return sample_point(d, p, x, y, b); },
      [](auto d, const auto& p, auto x, auto y, auto* b) { return sample_bilinear(d, p, x, y, b); },
      [](auto d, const auto& p, auto x, auto y, auto* b) {
        return sample_catmull_rom_5(d, p, x, y, b);
      },
      [](auto d, const auto& p, auto x, auto y, auto* b) {
        return sample_catmull_rom_9(d, p, x, y, b);
      },
      [](auto d, const auto& p, auto x, auto y, auto* b) {
        return sample_catmull_rom_16(d, p, x, y, b);
      });
}

}  // namespace

// ---------------------------------------------------------------------------------------
// History position
// ---------------------------------------------------------------------------------------

TEST(Reproject, HistoryPositionOfKnownMotion) {
  // Pixel (10, 5) has center (10.5, 5.5); motion (2.25, -1.5) -> (12.75, 4).
  auto hp = history_position(kOne, 10, 5, hn::Set(kOne, 2.25f), hn::Set(kOne, -1.5f), 37, 23);
  EXPECT_EQ(hn::GetLane(hp.x), 12.75f);
  EXPECT_EQ(hn::GetLane(hp.y), 4.0f);
  EXPECT_TRUE(hn::AllTrue(kOne, hp.onscreen));
  // Full width: lane l is pixel 10 + l.
  auto hf = history_position(kFull, 10, 5, hn::Set(kFull, 2.25f), hn::Set(kFull, -1.5f), 1000, 23);
  auto xs = lanes(kFull, hf.x);
  for (size_t l = 0; l < xs.size(); ++l) EXPECT_EQ(xs[l], 12.75f + float(l));
  // The nearest-pixel form: pixel (12, 4).
  auto np = nearest_history_pixel(10, 5, 2.25f, -1.5f, 37, 23);
  ASSERT_TRUE(np.has_value());
  EXPECT_EQ(np->x, 12);
  EXPECT_EQ(np->y, 4);
}

TEST(Reproject, OffScreenRejectionAtTheBorders) {
  const int w = 37, h = 23;
  auto on = [&](float qx, float qy) {
    // Motion that moves pixel (0, 0)'s center (0.5, 0.5) to (qx, qy).
    auto hp =
        history_position(kOne, 0, 0, hn::Set(kOne, qx - 0.5f), hn::Set(kOne, qy - 0.5f), w, h);
    return hn::AllTrue(kOne, hp.onscreen);
  };
  // Lanes: closed test [0, w] x [0, h].
  EXPECT_TRUE(on(0.0f, 0.0f));
  EXPECT_TRUE(on(float(w), float(h)));
  EXPECT_FALSE(on(-0.25f, 3.0f));
  EXPECT_FALSE(on(3.0f, -0.25f));
  EXPECT_FALSE(on(float(w) + 0.25f, 3.0f));
  EXPECT_FALSE(on(3.0f, float(h) + 0.25f));
  // Off-screen fetch coordinates are clamped to [-2, w + 2] x [-2, h + 2].
  auto far = history_position(kOne, 0, 0, hn::Set(kOne, 1e9f), hn::Set(kOne, -1e9f), w, h);
  EXPECT_EQ(hn::GetLane(far.x), float(w) + 2.0f);
  EXPECT_EQ(hn::GetLane(far.y), -2.0f);
  EXPECT_FALSE(hn::AllTrue(kOne, far.onscreen));
  // Non-finite motion is off-screen, with finite fetch coordinates.
  auto nan = history_position(kOne, 3, 3, hn::Set(kOne, std::nanf("")), hn::Set(kOne, 0.0f), w, h);
  EXPECT_FALSE(hn::AllTrue(kOne, nan.onscreen));
  EXPECT_TRUE(std::isfinite(hn::GetLane(nan.x)));
  // Nearest pixel: half-open test [0, w) x [0, h).
  EXPECT_TRUE(nearest_history_pixel(0, 0, -0.5f, -0.5f, w, h).has_value());            // (0, 0)
  EXPECT_FALSE(nearest_history_pixel(0, 0, float(w) - 0.5f, 0.0f, w, h).has_value());  // x == w
  auto edge = nearest_history_pixel(0, 0, float(w) - 0.5f - 0.001f, float(h) - 0.5f - 0.001f, w, h);
  ASSERT_TRUE(edge.has_value());
  EXPECT_EQ(edge->x, w - 1);
  EXPECT_EQ(edge->y, h - 1);
  EXPECT_FALSE(nearest_history_pixel(5, 5, -5.75f, 0.0f, w, h).has_value());
  EXPECT_FALSE(nearest_history_pixel(5, 5, std::numeric_limits<float>::infinity(), 0, w, h));
  EXPECT_FALSE(nearest_history_pixel(5, 5, 0, std::nanf(""), w, h));
}

// ---------------------------------------------------------------------------------------
// Footprint
// ---------------------------------------------------------------------------------------

TEST(Reproject, FootprintWeightsSumToOneAndReproduceARamp) {
  // Ramp v = x/4 + y/8 + 3 at pixel centers, sampled at dyadic positions: every product and
  // sum is exact in float, so bilinear interpolation must return the ramp exactly.
  const int w = 41, h = 29;
  const ImageF img = test::ramp_image(w, h, 0.25f, 0.125f, 3.0f);
  const Planes<1> p = planes_of<1>(img);
  for (float x : {1.5f, 2.625f, 10.0f, 17.8125f, 39.25f})
    for (float y : {0.5f, 3.375f, 14.0f, 27.9375f}) {
      auto X = hn::Set(kOne, x), Y = hn::Set(kOne, y);
      const Footprint<OneTag> fp = bilinear_footprint(kOne, w, h, X, Y);
      const TapWeights<OneTag> tw = bilinear_tap_weights(kOne, fp.fx, fp.fy);
      float sum = 0.0f;
      for (auto wi : tw.w) sum += hn::GetLane(wi);
      EXPECT_EQ(sum, 1.0f);
      const float truth = 0.25f * x + 0.125f * y + 3.0f;
      EXPECT_EQ(hn::GetLane(sample_weighted(kOne, p, fp, tw).v[0]), truth) << x << " " << y;
      EXPECT_EQ(hn::GetLane(sample_bilinear(kOne, p, X, Y).v[0]), truth) << x << " " << y;
    }
  // Random positions: the sum is 1 up to rounding.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-3.0f, 45.0f);
  for (int i = 0; i < 200; ++i) {
    auto fp = bilinear_footprint(kFull, w, h, hn::Set(kFull, u(rng)), hn::Set(kFull, u(rng)));
    auto tw = bilinear_tap_weights(kFull, fp.fx, fp.fy);
    float sum = 0.0f;
    for (auto wi : tw.w) sum += hn::GetLane(wi);
    EXPECT_NEAR(sum, 1.0f, 1e-6f);
  }
}

// ---------------------------------------------------------------------------------------
// Consistency tests and renormalisation
// ---------------------------------------------------------------------------------------

TEST(Reproject, DepthStepRejectsFarTapsAndRenormalises) {
  // History position (10.3, 7.6): footprint pixels x 9..10, y 7..8; fx = 0.8, fy = 0.1.
  // Previous depth: column 9 at 1 (the near surface), column 10 at 10 (a wall behind).
  const float prev_depth[4] = {1.0f, 10.0f, 1.0f, 10.0f};  // taps 00, 10, 01, 11
  const float cur = 1.005f;
  auto fp = bilinear_footprint(kOne, 37, 23, hn::Set(kOne, 10.3f), hn::Set(kOne, 7.6f));
  auto tw = bilinear_tap_weights(kOne, fp.fx, fp.fy);
  hn::Mask<OneTag> pass[4];
  for (int i = 0; i < 4; ++i)
    pass[i] = depth_within_relative(kOne, hn::Set(kOne, prev_depth[i]), hn::Set(kOne, cur), 0.01f);
  EXPECT_TRUE(hn::AllTrue(kOne, pass[0]));
  EXPECT_FALSE(hn::AllTrue(kOne, pass[1]));
  EXPECT_TRUE(hn::AllTrue(kOne, pass[2]));
  EXPECT_FALSE(hn::AllTrue(kOne, pass[3]));
  auto r = renormalize_weights(kOne, tw, pass);
  EXPECT_TRUE(hn::AllTrue(kOne, r.any));
  float sum = 0.0f, w[4];
  for (int i = 0; i < 4; ++i) sum += w[i] = hn::GetLane(r.weights.w[i]);
  EXPECT_NEAR(sum, 1.0f, 1e-6f);
  EXPECT_EQ(w[1], 0.0f);
  EXPECT_EQ(w[3], 0.0f);
  // The remaining taps keep their bilinear proportion (1 - fy) : fy = 0.9 : 0.1.
  EXPECT_NEAR(w[0], 0.9f, 1e-5f);
  EXPECT_NEAR(w[2], 0.1f, 1e-5f);
  // Nothing passes: no history, all weights 0.
  const hn::Mask<OneTag> none[4] = {pass[1], pass[1], pass[3], pass[3]};
  auto z = renormalize_weights(kOne, tw, none);
  EXPECT_FALSE(hn::AllTrue(kOne, z.any));
  for (auto wi : z.weights.w) EXPECT_EQ(hn::GetLane(wi), 0.0f);
  // TAA's rule: a tap only counts if it carries weight.
  hn::Mask<OneTag> used[4];
  taps_used(kOne, bilinear_tap_weights(kOne, hn::Zero(kOne), hn::Zero(kOne)), used);  // tap 00
  const hn::Mask<OneTag> only_10[4] = {pass[1], pass[0], pass[1], pass[1]};
  EXPECT_FALSE(hn::AllTrue(kOne, any_used_tap_passes(kOne, used, only_10)));
  EXPECT_TRUE(hn::AllTrue(kOne, any_used_tap_passes(kOne, used, pass)));
}

TEST(Reproject, NormalFlipAndIdMismatchReject) {
  const Color3<OneTag> n = splat(kOne, 0.0f, 0.6f, 0.8f);
  const float cos25 = std::cos(25.0f * 3.14159265f / 180.0f);
  EXPECT_TRUE(hn::AllTrue(kOne, normal_within_angle(kOne, n, n, cos25)));
  EXPECT_FALSE(
      hn::AllTrue(kOne, normal_within_angle(kOne, splat(kOne, 0.0f, -0.6f, -0.8f), n, cos25)));
  // 20 degrees apart passes a 25 degree threshold, 30 degrees does not.
  auto tilted = [&](float deg) {
    const float a = deg * 3.14159265f / 180.0f;
    return splat(kOne, std::sin(a), 0.0f, std::cos(a));
  };
  EXPECT_TRUE(hn::AllTrue(kOne, normal_within_angle(kOne, tilted(20), tilted(0), cos25)));
  EXPECT_FALSE(hn::AllTrue(kOne, normal_within_angle(kOne, tilted(30), tilted(0), cos25)));
  const hn::CappedTag<uint32_t, 1> du;
  EXPECT_TRUE(hn::AllTrue(du, id_matches(du, hn::Set(du, 7u), hn::Set(du, 7u))));
  EXPECT_FALSE(hn::AllTrue(du, id_matches(du, hn::Set(du, 7u), hn::Set(du, 8u))));
  // Motion: |(3, 4) - (0, 0)| = 5.
  auto tol2 = hn::Set(kOne, 25.0f);
  auto z = hn::Zero(kOne);
  EXPECT_TRUE(
      hn::AllTrue(kOne, motion_within(kOne, hn::Set(kOne, 3.0f), hn::Set(kOne, 4.0f), z, z, tol2)));
  EXPECT_FALSE(
      hn::AllTrue(kOne, motion_within(kOne, hn::Set(kOne, 3.0f), hn::Set(kOne, 4.1f), z, z, tol2)));
}

TEST(Reproject, SlopeScaledDepthAcceptsASteepPlane) {
  // A plane at a grazing angle: depth grows by 2 units per pixel around d = 20. The tap one
  // pixel away has depth 22: 10% off, rejected by a 1% relative tolerance, but within
  // 1% * 20 + 1.5 * 2 * 1 = 3.2 with the slope term (SVGF: tolerance scaled by fwidth(z)).
  const auto cur = hn::Set(kOne, 20.0f), prev = hn::Set(kOne, 22.0f);
  const auto grad = hn::Set(kOne, 2.0f), dist = hn::Set(kOne, 1.0f);
  EXPECT_FALSE(hn::AllTrue(kOne, depth_within_relative(kOne, prev, cur, 0.01f)));
  EXPECT_TRUE(hn::AllTrue(kOne, depth_within_slope(kOne, prev, cur, 0.01f, 1.5f, grad, dist)));
  // A real depth step on the same plane (another surface 10 units behind) is still rejected.
  EXPECT_FALSE(hn::AllTrue(
      kOne, depth_within_slope(kOne, hn::Set(kOne, 32.0f), cur, 0.01f, 1.5f, grad, dist)));
  // Without a slope the two tests agree.
  EXPECT_EQ(
      hn::AllTrue(kOne, depth_within_slope(kOne, prev, cur, 0.2f, 1.5f, hn::Zero(kOne), dist)),
      hn::AllTrue(kOne, depth_within_relative(kOne, prev, cur, 0.2f)));
}

// ---------------------------------------------------------------------------------------
// Gathers
// ---------------------------------------------------------------------------------------

// Every N-plane sampler equals the scalar core/sampler.h per plane (tolerances as the
// lane/scalar sampler tests have always used: bilinear 1e-5, Catmull-Rom 1e-4).
template <int N>
void expect_gathers_match_scalar(bool simd) {
  const int w = 257, h = 89;
  const ImageF src = test::random_image(w, h, N, 20 + N, 0.0f, 4.0f);
  const ImageF motion = test::random_image(w, h, 2, 30 + N, -6.0f, 6.0f);
  auto [pt, bl, c5, c9, c16] =
      std::apply([&](auto... f) { return std::make_tuple(resample<N>(src, motion, simd, f)...); },
                 all_fetchers());
  for (int c = 0; c < N; ++c) {
    const PlaneView v = view(src, c);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const float px = x + 0.5f + motion.at(x, y, 0), py = y + 0.5f + motion.at(x, y, 1);
        ASSERT_EQ(pt.at(x, y, c), sample_point(v, px, py));
        ASSERT_NEAR(bl.at(x, y, c), sample_bilinear(v, px, py), 1e-5f) << x << " " << y;
        ASSERT_NEAR(c5.at(x, y, c), sample_catmull_rom_5(v, px, py), 1e-4f) << x << " " << y;
        ASSERT_NEAR(c9.at(x, y, c), sample_catmull_rom_9(v, px, py), 1e-4f) << x << " " << y;
        ASSERT_NEAR(c16.at(x, y, c), sample_catmull_rom_16(v, px, py), 1e-4f) << x << " " << y;
      }
  }
}
TEST(Reproject, GathersMatchScalarSamplersPerPlane) {
  for (bool simd : {true, false}) {
    expect_gathers_match_scalar<1>(simd);
    expect_gathers_match_scalar<3>(simd);
    expect_gathers_match_scalar<4>(simd);
  }
}

TEST(Reproject, OneLaneEqualsFullWidthBitExactly) {
  const int w = 257, h = 89;
  const ImageF src = test::random_image(w, h, 3, 40, 0.0f, 4.0f);
  const ImageF motion = test::random_image(w, h, 2, 41, -6.0f, 6.0f);
  std::apply(
      [&](auto... f) {
        auto check = [&](auto fetch) {
          EXPECT_EQ(resample<3>(src, motion, true, fetch), resample<3>(src, motion, false, fetch));
          EXPECT_EQ(resample<1>(src, motion, true, fetch), resample<1>(src, motion, false, fetch));
        };
        (check(f), ...);
      },
      all_fetchers());
}

// gather() / gather_plane() load consecutive indices instead of gathering them: the values
// must be the gather's for consecutive, almost consecutive, repeated (clamped) and reversed
// indices, and a smooth sub-pixel pan (all-consecutive fetches) must still match one lane.
TEST(Reproject, ConsecutiveIndexLoadsEqualGathers) {
  const ImageF src = test::random_image(64, 4, 3, 50, -2.0f, 4.0f);
  const Planes<3> p = planes_of<3>(src);
  const hn::RebindToSigned<FullTag> di;
  const int n = int(hn::Lanes(kFull));
  std::vector<std::vector<int32_t>> cases;
  for (int start : {0, 5, 64 * 4 - n}) {
    std::vector<int32_t> c(static_cast<size_t>(n));
    for (int l = 0; l < n; ++l) c[size_t(l)] = start + l;
    cases.push_back(c);  // consecutive
    if (n > 1) {
      auto off = c;
      off[size_t(n - 1)] += 1;  // last lane skips one
      cases.push_back(off);
      auto rev = c;
      std::reverse(rev.begin(), rev.end());
      cases.push_back(rev);
      cases.push_back(std::vector<int32_t>(size_t(n), start));  // clamped to one pixel
    }
  }
  for (const auto& c : cases) {
    const auto idx = hn::LoadU(di, c.data());
    EXPECT_EQ(consecutive(kFull, idx), [&] {
      for (int l = 1; l < n; ++l)
        if (c[size_t(l)] != c[0] + l) return false;
      return true;
    }());
    const Pixel<FullTag, 3> g = gather(kFull, p, idx);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(test::lanes(kFull, g.v[k]),
                test::lanes(kFull, hn::GatherIndex(kFull, p.p[k], idx)));
      EXPECT_EQ(test::lanes(kFull, gather_plane(kFull, p.p[k], idx)), test::lanes(kFull, g.v[k]));
    }
  }
  // A uniform sub-pixel pan: every sampler's fetches are consecutive away from the borders.
  const int w = 123, h = 31;
  const ImageF img = test::random_image(w, h, 3, 51, 0.0f, 4.0f);
  ImageF pan(w, h, 2);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      pan.at(x, y, 0) = -2.3f;
      pan.at(x, y, 1) = 0.6f;
    }
  std::apply(
      [&](auto... f) {
        auto check = [&](auto fetch) {
          EXPECT_EQ(resample<3>(img, pan, true, fetch), resample<3>(img, pan, false, fetch));
        };
        (check(f), ...);
      },
      all_fetchers());
}

TEST(Reproject, IntegerMotionReturnsExactPixels) {
  const int w = 37, h = 23;
  const ImageF src = test::random_image(w, h, 3, 5, 0.0f, 4.0f);
  const int motions[4][2] = {{0, 0}, {3, -2}, {-5, 4}, {1, 1}};
  std::apply(
      [&](auto... fetch) {
        auto check = [&](auto f) {
          for (bool simd : {true, false})
            for (const auto& m : motions) {
              ImageF mo(w, h, 2);
              for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x) {
                  mo.at(x, y, 0) = float(m[0]);
                  mo.at(x, y, 1) = float(m[1]);
                }
              ImageF out = resample<3>(src, mo, simd, f);
              for (int c = 0; c < 3; ++c)
                for (int y = 0; y < h; ++y)
                  for (int x = 0; x < w; ++x) {
                    int sx = std::clamp(x + m[0], 0, w - 1), sy = std::clamp(y + m[1], 0, h - 1);
                    ASSERT_EQ(out.at(x, y, c), src.at(sx, sy, c))
                        << "x " << x << " y " << y << " motion " << m[0] << "," << m[1];
                  }
            }
        };
        (check(fetch), ...);
      },
      all_fetchers());
}

TEST(Reproject, FootprintBoxIsTheBilinearFootprint) {
  const ImageF src = test::random_image(37, 23, 3, 13, 0.0f, 4.0f);
  const Planes<3> p = planes_of<3>(src);
  const auto px = hn::Set(kOne, 10.3f), py = hn::Set(kOne, 7.8f);  // pixels x 9..10, y 7..8
  PixelBox<OneTag, 3> boxes[4];
  sample_bilinear(kOne, p, px, py, &boxes[0]);
  sample_catmull_rom_5(kOne, p, px, py, &boxes[1]);
  sample_catmull_rom_9(kOne, p, px, py, &boxes[2]);
  sample_catmull_rom_16(kOne, p, px, py, &boxes[3]);
  for (int c = 0; c < 3; ++c) {
    float lo = 1e30f, hi = -1e30f;
    for (int y = 7; y <= 8; ++y)
      for (int x = 9; x <= 10; ++x) {
        lo = std::min(lo, src.at(x, y, c));
        hi = std::max(hi, src.at(x, y, c));
      }
    for (const auto& b : boxes) {
      EXPECT_EQ(hn::GetLane(b.lo.v[c]), lo);
      EXPECT_EQ(hn::GetLane(b.hi.v[c]), hi);
    }
  }
  // Point sampling's box is the pixel itself.
  PixelBox<OneTag, 3> pb;
  auto v = sample_point(kOne, p, px, py, &pb);
  EXPECT_EQ(hn::GetLane(pb.lo.v[1]), hn::GetLane(v.v[1]));
  EXPECT_EQ(hn::GetLane(pb.hi.v[1]), src.at(10, 7, 1));
}

TEST(Reproject, SampleHistoryDispatchesToTheSampler) {
  const int w = 257, h = 89;
  const ImageF src = test::random_image(w, h, 3, 50, 0.0f, 4.0f);
  const ImageF motion = test::random_image(w, h, 2, 51, -6.0f, 6.0f);
  const HistoryFilter kinds[5] = {HistoryFilter::Point, HistoryFilter::Bilinear,
                                  HistoryFilter::CatmullRom5, HistoryFilter::CatmullRom9,
                                  HistoryFilter::CatmullRom16};
  int k = 0;
  std::apply(
      [&](auto... f) {
        auto check = [&](auto fetch) {
          const HistoryFilter kind = kinds[k++];
          auto via = [kind](auto d, const auto& p, auto x, auto y, auto* b) {
            return sample_history(d, kind, p, x, y, b);
          };
          EXPECT_EQ(resample<3>(src, motion, true, via), resample<3>(src, motion, true, fetch));
        };
        (check(f), ...);
      },
      all_fetchers());
}
