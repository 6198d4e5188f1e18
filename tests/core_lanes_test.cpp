// core/ lane helpers (lanes.h, neighborhood.h, sanitize.h, simd.h stream_copy) against scalar
// truths, at full SIMD width and at 1 lane. Odd sizes exercise tails and borders (OIDN habit).
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "core/color.h"
#include "core/lanes.h"
#include "core/neighborhood.h"
#include "core/parallel.h"
#include "core/sanitize.h"
#include "core/simd.h"
#include "lane_test_util.h"
#include "test_util.h"

using namespace afterimage;
using namespace afterimage::test;

namespace {}  // namespace

TEST(CoreLanes, YCoCgKnownValuesAndRoundTrip) {
  // (1, 0, 0) -> Y = 1/4, Co = 1/2, Cg = -1/4 (seed 003 RGB2YCoCg).
  expect_near3(lane0(kOne, rgb_to_ycocg(kOne, set3(kOne, {1, 0, 0}))), {0.25f, 0.5f, -0.25f}, 0);
  expect_near3(lane0(kOne, rgb_to_ycocg(kOne, set3(kOne, {0, 1, 0}))), {0.5f, 0.0f, 0.5f}, 0);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 50.0f);
  for (int i = 0; i < 200; ++i) {
    Vec3f c{u(rng), u(rng), u(rng)};
    auto y = rgb_to_ycocg(kFull, set3(kFull, c));
    expect_near3(lane0(kFull, y), afterimage::rgb_to_ycocg(c), 1e-5f);  // core/color.h twin
    expect_near3(lane0(kFull, ycocg_to_rgb(kFull, y)), c, 1e-5f);
  }
}

TEST(CoreLanes, LuminanceIsRec709) {
  EXPECT_NEAR(hn::GetLane(luminance(kOne, set3(kOne, {1, 2, 4}))), 0.2126f + 1.4304f + 0.2888f,
              1e-6f);
  EXPECT_NEAR(hn::GetLane(luminance(kFull, set3(kFull, {0.3f, 0.5f, 0.7f}))),
              afterimage::luminance(Vec3f{0.3f, 0.5f, 0.7f}), 1e-6f);
}

TEST(CoreLanes, ColorArithmeticHandValues) {
  const auto a = set3(kOne, {1, 2, 3}), b = set3(kOne, {4, -1, 0.5f});
  EXPECT_EQ(lane0(kOne, add(a, b)), (Vec3f{5, 1, 3.5f}));
  EXPECT_EQ(lane0(kOne, sub(a, b)), (Vec3f{-3, 3, 2.5f}));
  EXPECT_EQ(lane0(kOne, scale(a, hn::Set(kOne, 2.0f))), (Vec3f{2, 4, 6}));
  EXPECT_EQ(lane0(kOne, mul_add(a, hn::Set(kOne, 2.0f), b)), (Vec3f{6, 3, 6.5f}));
  EXPECT_EQ(lane0(kOne, cmin(a, b)), (Vec3f{1, -1, 0.5f}));
  EXPECT_EQ(lane0(kOne, cmax(a, b)), (Vec3f{4, 2, 3}));
  EXPECT_EQ(lane0(kOne, select<OneTag>(hn::Gt(hn::Set(kOne, 1.0f), hn::Zero(kOne)), a, b)),
            (Vec3f{1, 2, 3}));
  EXPECT_EQ(
      hn::GetLane(lerp<OneTag>(hn::Set(kOne, 2.0f), hn::Set(kOne, 4.0f), hn::Set(kOne, 0.25f))),
      2.5f);
  EXPECT_EQ(hn::GetLane(saturate(kOne, hn::Set(kOne, 1.5f))), 1.0f);
  EXPECT_EQ(hn::GetLane(saturate(kOne, hn::Set(kOne, -0.5f))), 0.0f);
  EXPECT_TRUE(hn::AllTrue(kOne, all_finite(kOne, a)));
  const float inf = std::numeric_limits<float>::infinity();
  EXPECT_FALSE(hn::AllTrue(kOne, all_finite(kOne, set3(kOne, {1, inf, 0}))));
  EXPECT_FALSE(hn::AllTrue(kOne, all_finite(kOne, set3(kOne, {std::nanf(""), 1, 0}))));
}

TEST(CoreLanes, MinMaxBoxOfPoints) {
  Color3<OneTag> s[3] = {set3(kOne, {1, 5, 0}), set3(kOne, {3, 2, -1}), set3(kOne, {2, 4, 7})};
  Aabb<OneTag> b = minmax_box(s, 3);
  EXPECT_EQ(lane0(kOne, b.lo), (Vec3f{1, 2, -1}));
  EXPECT_EQ(lane0(kOne, b.hi), (Vec3f{3, 5, 7}));
  Aabb<OneTag> p = aabb_extend(aabb_of_point(s[0]), s[1]);
  EXPECT_EQ(lane0(kOne, p.lo), (Vec3f{1, 2, -1}));
  EXPECT_EQ(lane0(kOne, p.hi), (Vec3f{3, 5, 0}));
}

// The strided loader reads x + dx * step clamped to the row, at any lane width.
TEST(CoreLanes, StridedLoaderClampsAtBorders) {
  const int w = 257, h = 89;
  std::vector<float> img(size_t(w) * h);
  for (size_t i = 0; i < img.size(); ++i) img[i] = float(i) * 0.5f + 1.0f;
  auto check = [&](auto d, int step) {
    const int n = int(hn::Lanes(d));
    std::vector<float> out(static_cast<size_t>(n));
    for (int y : {0, 1, 2, 3, 44, 85, 86, 88}) {
      const auto rows = neighborhood_rows(y, w, h, step);
      EXPECT_EQ(rows[0], size_t(std::max(y - step, 0)) * w);
      EXPECT_EQ(rows[2], size_t(std::min(y + step, h - 1)) * w);
      for (int x = 0; x + n <= w; x += (x < 16 || x > w - 24) ? 1 : 37)
        for (int i = 0; i < 9; ++i) {
          hn::StoreU(load_neighbor(d, img.data(), rows, x, i, step, w), d, out.data());
          for (int l = 0; l < n; ++l) {
            const int sx = std::clamp(x + l + kNeighborDx[i] * step, 0, w - 1);
            const int sy = std::clamp(y + kNeighborDy[i] * step, 0, h - 1);
            ASSERT_EQ(out[size_t(l)], img[size_t(sy) * w + sx])
                << "step " << step << " x " << x << " y " << y << " neighbour " << i;
          }
        }
    }
  };
  for (int step : {1, 2, 4}) {
    check(kFull, step);
    check(kOne, step);
  }
  // Step 1 is the 3x3 loader.
  EXPECT_EQ(hn::GetLane(load_row_shifted(kOne, img.data(), 0, -1, w)), img[0]);
  EXPECT_EQ(hn::GetLane(load_row_shifted(kOne, img.data(), w - 1, 1, w)), img[size_t(w) - 1]);
}

TEST(CoreLanes, SanitizeDepthMapsNonFiniteToBackground) {
  const float inf = std::numeric_limits<float>::infinity();
  EXPECT_EQ(hn::GetLane(sanitize_depth(kOne, hn::Set(kOne, std::nanf("")), 1e10f)), 1e10f);
  EXPECT_EQ(hn::GetLane(sanitize_depth(kOne, hn::Set(kOne, inf), 1e10f)), 1e10f);
  EXPECT_EQ(hn::GetLane(sanitize_depth(kOne, hn::Set(kOne, 3.5f), 1e10f)), 3.5f);
}

TEST(CoreLanes, SanitizeColorReplacesNonFiniteAndNegative) {
  const int w = 37, h = 23;
  const float inf = std::numeric_limits<float>::infinity(), nan = std::nanf("");
  ImageF img = test::random_image(w, h, 3, 2, 0.0f, 4.0f);
  // A clean image is left alone.
  ImageF out, invalid;
  Exec ex;
  EXPECT_FALSE(sanitize_color(img, out, invalid, ex));
  EXPECT_TRUE(out.empty());
  img.at(10, 5, 0) = nan;
  img.at(11, 5, 0) = inf;  // neighbour of the NaN: excluded from its mean
  img.at(0, 0, 1) = -inf;  // corner: clamped neighbours
  img.at(36, 22, 2) = nan;
  img.at(20, 10, 1) = -2.0f;  // negative -> 0
  img.at(21, 10, 1) = -1.0f;  // negative neighbour of nothing bad
  // Truth: mean of the finite, negative-clamped 3x3 neighbours (clamp to edge), per channel.
  auto truth = [&](int x, int y, int c) {
    const float v = img.at(x, y, c);
    if (std::isfinite(v)) return std::max(v, 0.0f);
    float sum = 0.0f, cnt = 0.0f;
    for (int i = 1; i < 9; ++i) {
      const float q = img.at_clamped(x + kNeighborDx[i], y + kNeighborDy[i], c);
      if (std::isfinite(q)) {
        sum += std::max(q, 0.0f);
        cnt += 1.0f;
      }
    }
    return cnt > 0.0f ? sum / cnt : 0.0f;
  };
  ImageF ref_out, ref_invalid;
  for (bool simd : {true, false}) {
    Exec e;
    e.simd = simd;
    ASSERT_TRUE(sanitize_color(img, out, invalid, e));
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        bool bad = false;
        for (int c = 0; c < 3; ++c) {
          bad |= !std::isfinite(img.at(x, y, c));
          EXPECT_NEAR(out.at(x, y, c), truth(x, y, c), 1e-6f) << x << " " << y << " " << c;
          EXPECT_TRUE(std::isfinite(out.at(x, y, c)) && out.at(x, y, c) >= 0.0f);
        }
        EXPECT_EQ(invalid.at(x, y, 0), bad ? 1.0f : 0.0f) << x << " " << y;
      }
    if (simd) {
      ref_out = out;
      ref_invalid = invalid;
    } else {
      EXPECT_EQ(out, ref_out);  // SIMD on == off, bit-exactly
      EXPECT_EQ(invalid, ref_invalid);
    }
  }
  EXPECT_EQ(out.at(20, 10, 1), 0.0f);
  EXPECT_EQ(invalid.at(20, 10, 0), 0.0f);  // negative is not "invalid": it is a sample
}

// iota_from(d, first) is hn::Iota(d, first) computed in registers: the same lanes, for integer
// and float starts (negative, large, and float starts that round), at full width and 1 lane.
TEST(CoreLanes, IotaFromEqualsHighwaysIota) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const size_t n = hn::Lanes(df);
  std::vector<float> a(n), b(n);
  std::vector<int32_t> ia(n), ib(n);
  for (const int first : {0, 1, -7, 1919, -2147483647 + 64, 2147483647 - 64}) {
    hn::StoreU(iota_from(di, first), di, ia.data());
    hn::StoreU(hn::Iota(di, first), di, ib.data());
    EXPECT_EQ(ia, ib) << first;
  }
  for (const float first : {0.0f, 0.5f, -3.25f, 1919.0f, 16777215.0f, 3.0e7f, 0.1f}) {
    hn::StoreU(iota_from(df, first), df, a.data());
    hn::StoreU(hn::Iota(df, first), df, b.data());
    for (size_t l = 0; l < n; ++l) EXPECT_EQ(a[l], b[l]) << first << " lane " << l;
    EXPECT_EQ(hn::GetLane(iota_from(OneTag(), first)), first);
  }
  // Lane l is first + l (the test is not trivially comparing a function with itself).
  hn::StoreU(iota_from(df, 10.0f), df, a.data());
  for (size_t l = 0; l < n; ++l) EXPECT_EQ(a[l], 10.0f + float(l));
}

TEST(CoreLanes, StreamCopyCopiesEveryBitAtAnyAlignmentAndLength) {
  // Every destination misalignment of a 64-byte vector and lengths around it: the bits of the
  // source (NaN payloads, -0, subnormals included) and nothing past the end.
  std::vector<uint32_t> src(300), dst(340);
  std::mt19937 rng(5);
  for (auto& v : src) v = uint32_t(rng());
  src[3] = 0x7FC01234u;  // NaN with payload
  src[4] = 0x80000000u;  // -0
  src[5] = 0x00000001u;  // subnormal
  for (size_t off = 0; off < 17; ++off)
    for (size_t n :
         {size_t(0), size_t(1), size_t(15), size_t(16), size_t(17), size_t(33), size_t(299)}) {
      std::fill(dst.begin(), dst.end(), 0xDEADBEEFu);
      stream_copy(src.data(), dst.data() + off, n);
      for (size_t i = 0; i < dst.size(); ++i) {
        const bool inside = i >= off && i < off + n;
        ASSERT_EQ(dst[i], inside ? src[i - off] : 0xDEADBEEFu) << off << " " << n << " " << i;
      }
    }
}

TEST(CoreParallel, RowRangesCoverEveryRowOnce) {
  // parallel_row_ranges: contiguous, non-empty ranges that cover [0, height) once, for one
  // thread (a single range), two, and a clamped arena of another size; nothing for height 0.
  for (int threads : {1, 2, 3})
    for (int height : {0, 1, 7, 68, 1000}) {
      std::vector<std::atomic<int>> seen(static_cast<size_t>(height));
      std::atomic<int> calls{0}, bad{0};
      parallel_row_ranges(Exec{threads, true}, height, [&](int y0, int y1) {
        ++calls;
        if (!(0 <= y0 && y0 < y1 && y1 <= height)) ++bad;
        for (int y = y0; y < y1; ++y) ++seen[size_t(y)];
      });
      EXPECT_EQ(bad.load(), 0) << threads << " " << height;
      for (int y = 0; y < height; ++y) ASSERT_EQ(seen[size_t(y)].load(), 1) << threads << " " << y;
      if (height == 0) {
        EXPECT_EQ(calls.load(), 0);
      } else if (threads == 1) {
        EXPECT_EQ(calls.load(), 1);
      }
    }
}
