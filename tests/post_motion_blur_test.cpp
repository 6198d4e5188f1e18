// Motion blur (issue 12): a still scene is unchanged, a uniformly moving textured plane
// matches the box filter along its motion, a moving foreground over a still background does
// not take the background's color inside it nor smear the still background, per-pixel weights
// against McGuire et al. 2012, and determinism. The sequence options: the default output is
// the pass as it was before them (a copy of that pass below), camera and object clamps act
// separately on a camera translation with an object moving in front of it (closed-form
// camera motion), excluding the camera's rotation removes a pure turn's blur and keeps a
// translation's, and the running-sum trail is the box average of the last N frames.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include "camera/camera.h"
#include "core/error.h"
#include "post/motion_blur.h"
#include "test_util.h"

namespace afterimage {
namespace {

using post::MotionBlurSettings;

// Vertical stripes of period 12 px (smooth, so a box filter of it is well defined).
float stripes(double x) {
  return 0.5f + 0.4f * float(std::sin(2.0 * kPi * x / 12.0));
}

Frame plane_frame(int w, int h, float motion_x) {
  Frame f = Frame::allocate(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = stripes(x + 0.5);
      f.depth.at(x, y, 0) = 5.0f;
      f.motion.at(x, y, 0) = motion_x;
    }
  return f;
}

// The pass's per-pixel tap jitter in [-0.5, 0.5) (its hash, written out again; also the
// legacy pass's below).
double legacy_pixel_jitter(int x, int y) {
  uint32_t h = uint32_t(x) * 0x8da6b343u ^ uint32_t(y) * 0xd8163841u;
  h ^= h >> 15;
  h *= 0x2c1b3c6du;
  h ^= h >> 12;
  return double(h >> 8) * (1.0 / 16777216.0) - 0.5;
}

// PSNR of channel 0 in rows [y0, y1) against the closed-form box average of the stripes over
// the swept interval [x + 0.5 - half, x + 0.5 + half], 32 px away from the left and right borders.
double psnr_vs_swept_box(const ImageF& img, double half, int y0, int y1) {
  double se = 0;
  int n = 0;
  const double k = 2.0 * kPi / 12.0;
  for (int y = y0; y < y1; ++y)
    for (int x = 32; x < img.width() - 32; ++x) {
      const double a = x + 0.5 - half, b = x + 0.5 + half;
      const double box = 0.5 + 0.4 * (std::cos(k * a) - std::cos(k * b)) / (k * (b - a));
      const double e = img.at(x, y, 0) - box;
      se += e * e;
      ++n;
    }
  return 10 * std::log10(1.0 / (se / n));
}

TEST(PostMotionBlur, SettingsAndClosedFormWeights) {
  EXPECT_EQ(aggregate_member_count<MotionBlurSettings>(), MotionBlurSettings::params().size());
  MotionBlurSettings s;
  s.samples = 8;
  EXPECT_THROW(s.validate(), SettingsError);
  s = {};
  EXPECT_THROW(s.set_assignment("shutter=2"), SettingsError);
  EXPECT_DOUBLE_EQ(post::cone_weight(1.0, 4.0), 0.75);
  EXPECT_DOUBLE_EQ(post::cone_weight(5.0, 4.0), 0.0);
  EXPECT_DOUBLE_EQ(post::cylinder_weight(3.0, 4.0), 1.0);
  EXPECT_DOUBLE_EQ(post::cylinder_weight(4.0, 4.0), 0.5);
  EXPECT_DOUBLE_EQ(post::cylinder_weight(4.3, 4.0), 0.0);
  EXPECT_DOUBLE_EQ(post::soft_depth_compare(1.0, 2.0, 0.1), 1.0);  // a in front
  EXPECT_DOUBLE_EQ(post::soft_depth_compare(2.0, 1.0, 0.1), 0.0);  // a far behind
  // motion = p_prev - p_curr = -8 px: travel +8 px; a 180-degree shutter sweeps 4 px, half 2.
  const Vec2d v = post::blur_half_vector(-8.0f, 0.0f, 0.5f, 20);
  EXPECT_DOUBLE_EQ(v.x, 2.0);
  EXPECT_DOUBLE_EQ(post::blur_half_vector(-100.0f, 0.0f, 1.0f, 20).x, 20.0);
  EXPECT_DOUBLE_EQ(post::blur_half_vector(std::nanf(""), 0.0f, 1.0f, 20).x, 0.0);
}

TEST(PostMotionBlur, StillSceneIsUnchanged) {
  Frame f = plane_frame(64, 32, 0.0f);
  f.motion.at(10, 10, 0) = 0.4f;  // below half a pixel of blur: still
  EXPECT_EQ(post::motion_blur(f, f.color, {}), f.color);
}

// A plane moving 16 px per frame with the shutter open the whole frame: each pixel averages
// the texture over the 16 px it swept (box filter), checked away from the image borders.
TEST(PostMotionBlur, UniformMotionMatchesTheBoxFilter) {
  const int w = 160, h = 16;
  const Frame f = plane_frame(w, h, -16.0f);
  // PSNR against the closed-form box of the swept interval [x + 0.5 - 8, x + 0.5 + 8] (row 8).
  const auto psnr_vs_box = [](const ImageF& img) { return psnr_vs_swept_box(img, 8.0, 8, 9); };
  MotionBlurSettings s;
  s.shutter = 1.0f;
  s.samples = 31;
  const double fast = psnr_vs_box(post::motion_blur(f, f.color, s));
  s.uniform_tolerance = 0.0f;
  const double full = psnr_vs_box(post::motion_blur(f, f.color, s));
  const double none = psnr_vs_box(f.color);
  std::printf(
      "uniform 16 px/frame, shutter 1: PSNR vs box filter: fast path %.2f dB, full path %.2f dB "
      "(unblurred %.2f dB)\n",
      fast, full, none);
  // Measured: full path 33.3 dB (McGuire's weights add cone (triangle) terms to the cylinder
  // (box) ones when both pixels move alike, so its kernel is a little peakier than the box);
  // the fast path is the box filter sampled at 30 taps.
  EXPECT_GT(full, 31.0);
  EXPECT_GT(full, none + 15.0);
  EXPECT_GT(fast, full + 3.0);
}

// fast_tap_spacing on the fast path's case (a uniformly moving plane): PSNR against the
// closed-form box of the swept interval, with all 15 samples (spacing 0) and with fewer taps
// per pixel at 1 and 0.5 px (the default) spacing, at three speeds; the default loses nothing.
TEST(PostMotionBlur, FastTapSpacingAgainstTheBoxFilter) {
  const int w = 160, h = 16;
  for (const float speed : {2.0f, 4.0f, 16.0f}) {  // half vector |v| = speed / 2 at shutter 1
    const Frame f = plane_frame(w, h, -speed);
    const auto psnr_vs_box = [&](const ImageF& img) {
      return psnr_vs_swept_box(img, speed / 2, 0, h);
    };
    MotionBlurSettings s;
    s.shutter = 1.0f;
    s.fast_tap_spacing = 0.0f;
    const double all = psnr_vs_box(post::motion_blur(f, f.color, s));
    s.fast_tap_spacing = 1.0f;
    const ImageF one_px = post::motion_blur(f, f.color, s);
    EXPECT_EQ(post::motion_blur(f, f.color, s, Exec{2, false}), one_px);
    s.fast_tap_spacing = 0.5f;
    const double half_px = psnr_vs_box(post::motion_blur(f, f.color, s));
    const double none = psnr_vs_box(f.color);
    std::printf(
        "uniform %.0f px/frame, shutter 1: PSNR vs box: 15 samples %.2f dB, taps 1 px apart "
        "%.2f dB, 0.5 px apart %.2f dB (unblurred %.2f dB)\n",
        speed, all, psnr_vs_box(one_px), half_px, none);
    // Measured: 15 samples 43.39 / 42.26 / 39.53 dB at 2 / 4 / 16 px/frame, 0.5 px apart
    // 44.15 / 45.40 / 39.53 (the default: no loss), 1 px apart 34.00 / 28.93 / 39.53.
    EXPECT_GT(half_px, none + 3.0);
    EXPECT_GT(half_px, all - 0.1);
  }
}

// The fast path's taps on a uniformly moving plane of random colours against a straightforward
// reference of them written here (McGuire's jittered taps averaged: pair p of P = ceil(|v| /
// 0.5) pairs (at most 7) at (p + 0.5 + 0.5 j) / P of the way along +-v, j the pixel's
// jitter, each rounded to a pixel inside the image). The pass reads taps whose pixel the
// jitter cannot change as plain loads at a fixed offset; with random colours, any tap read
// from another pixel (a wrong offset, a border) is far outside the tolerance. Half vectors
// near the rounding boundaries, diagonal and negative ones; a 33-px-wide frame so blocks
// straddle both borders.
TEST(PostMotionBlur, FastPathTapsMatchAReferenceOfTheJitteredTaps) {
  const int w = 70, h = 23;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (const Vec2d v : {Vec2d{1.0, 0.0}, Vec2d{0.75, 0.0}, Vec2d{-0.6, 0.7}, Vec2d{2.0, 1.0},
                        Vec2d{6.0, -1.5}, Vec2d{0.0, -3.3}, Vec2d{4.6, 4.6}}) {
    for (const int width : {w, 33}) {
      Frame f = Frame::allocate(width, h);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < width; ++x) {
          for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = u(rng);
          f.depth.at(x, y, 0) = 5.0f;
          // shutter 1: half vector = -motion / 2
          f.motion.at(x, y, 0) = float(-2.0 * v.x);
          f.motion.at(x, y, 1) = float(-2.0 * v.y);
        }
      MotionBlurSettings s;
      s.shutter = 1.0f;
      const ImageF out = post::motion_blur(f, f.color, s);
      const int pairs = std::clamp(int(std::ceil(std::hypot(v.x, v.y) / 0.5)), 1, 7);
      double worst = 0;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < width; ++x) {
          const double j = legacy_pixel_jitter(x, y);
          double sum[3] = {0, 0, 0};
          for (int p = 0; p < pairs; ++p)
            for (const double sign : {-1.0, 1.0}) {
              const double t = sign * (p + 0.5 + 0.5 * j) / pairs;
              const int px = std::clamp(int(std::floor(x + t * v.x + 0.5)), 0, width - 1);
              const int py = std::clamp(int(std::floor(y + t * v.y + 0.5)), 0, h - 1);
              for (int c = 0; c < 3; ++c) sum[c] += f.color.at(px, py, c);
            }
          for (int c = 0; c < 3; ++c)
            worst = std::max(worst, std::abs(out.at(x, y, c) - sum[c] / (2 * pairs)));
        }
      EXPECT_LT(worst, 1e-5) << v.x << " " << v.y << " width " << width;
      EXPECT_EQ(out, post::motion_blur_reference(f, f.color, s)) << v.x << " " << v.y;
    }
  }
}

// A flat red square moving 12 px/frame right at depth 2 over a still striped background at
// depth 10: the square's interior keeps its color, the still background far from the square
// keeps its own, and the square's color spreads onto the background only along its motion.
TEST(PostMotionBlur, MovingForegroundOverStillBackground) {
  const int w = 128, h = 64;
  Frame f = plane_frame(w, h, 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) f.depth.at(x, y, 0) = 10.0f;
  for (int y = 16; y < 48; ++y)
    for (int x = 40; x < 88; ++x) {
      f.color.at(x, y, 0) = 1.0f;
      f.color.at(x, y, 1) = f.color.at(x, y, 2) = 0.0f;
      f.depth.at(x, y, 0) = 2.0f;
      f.motion.at(x, y, 0) = -12.0f;
    }
  const ImageF out = post::motion_blur(f, f.color, {});  // half-length 3 px
  for (int y = 20; y < 44; ++y)
    for (int x = 40 + 4; x < 88 - 4; ++x) {
      EXPECT_NEAR(out.at(x, y, 0), 1.0f, 1e-5f) << x << "," << y;
      EXPECT_NEAR(out.at(x, y, 1), 0.0f, 1e-5f) << x << "," << y;
    }
  // Background above and below the square (no motion along y): untouched.
  for (int x = 40; x < 88; ++x) {
    EXPECT_EQ(out.at(x, 10, 1), f.color.at(x, 10, 1));
    EXPECT_EQ(out.at(x, 54, 1), f.color.at(x, 54, 1));
  }
  // Beside it along the motion, within the 3 px it sweeps: the square's color (no green)
  // covers part of the background.
  EXPECT_LT(out.at(89, 30, 1), f.color.at(89, 30, 1) - 0.1f);
  EXPECT_LT(out.at(38, 30, 1), f.color.at(38, 30, 1) - 0.1f);
  EXPECT_EQ(out.at(100, 30, 0), f.color.at(100, 30, 0));
}

TEST(PostMotionBlur, DeterministicAcrossThreadsAndRefusesMissingChannels) {
  Frame f = plane_frame(97, 41, -9.0f);
  for (int y = 0; y < 41; ++y) f.motion.at(50, y, 1) = 3.0f;
  EXPECT_EQ(post::motion_blur(f, f.color, {}, Exec{1}), post::motion_blur(f, f.color, {}, Exec{2}));
  Frame g = Frame::allocate(8, 8, ChannelSet{Channel::color});
  EXPECT_THROW(post::motion_blur(g, g.color, {}), InputError);
  // A camera / object split on a frame that carries no camera: refused by every entry point
  // (the rows of half vectors check it), not blurred as if all motion were the objects'.
  f.camera_known = false;
  post::MotionBlurSettings split;
  split.camera_rotation = false;
  EXPECT_NO_THROW(post::motion_blur(f, f.color, {}));
  EXPECT_THROW(post::motion_blur(f, f.color, split), InputError);
  EXPECT_THROW(post::motion_blur_tile_max(f, split, nullptr), InputError);
}

// TileMax is, per tile, the first half vector of the largest length in row order
// (blur_half_vector, the scalar double reference, and add()'s strictly-longer rule) and the
// box of all of them. The pass proves most tiles from a float scan of the motion and runs the
// double rows only where a pixel may be the longest (motion_blur.cpp, tile_max); this frame
// mixes tiles of one motion (with -0 components), exact ties of different directions (3 4 5
// triangles), float near-ties a few ulp apart, pairs the float squares order wrongly (normal
// and subnormal), random, clamped, non-finite and tiny motion, at tile sizes wider and
// narrower than a SIMD vector, at 1 and 2 threads.
TEST(PostMotionBlur, TileMaxIsTheFirstLongestHalfVectorOfEachTile) {
  const int w = 151, h = 77;
  Frame f = Frame::allocate(w, h);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-30.0f, 30.0f);
  std::uniform_int_distribution<int> pick(0, 7);
  const float triangle[][2] = {{3, 4},  {4, 3},  {5, 0},      {0, 5},
                               {-3, 4}, {4, -3}, {-5, -0.0f}, {0, -5}};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float mx = 0.0f, my = 0.0f;
      switch ((x / 9 + 3 * (y / 7)) % 8) {  // regions of ~9 x 7 pixels
        case 0:  // one motion up to the sign of a zero (the first pixel's is the tile's), or
                 // one horizontal motion with vertical ones that vary
          mx = 6.5f, my = (x / 9) % 2 == 0 ? (pick(rng) < 4 ? -0.0f : 0.0f) : 0.25f * pick(rng);
          break;
        case 1:
          mx = triangle[pick(rng)][0], my = triangle[pick(rng)][1];
          break;
        case 2: {  // near-ties: a few ulp around (7, 2), or a pair whose float squares
                   // order them against their double lengths (the second is longer)
          const int k = pick(rng);
          if (k < 3) {
            mx = 13.000004768371582f, my = 10.99962043762207f;
          } else if (k < 6) {
            mx = 13.0f, my = 10.999626159667969f;
          } else {
            mx = 7.0f, my = 2.0f;
            for (int i = pick(rng); i > 0; --i) mx = std::nextafter(mx, 8.0f);
            for (int i = pick(rng); i > 0; --i) my = std::nextafter(my, 1.0f);
          }
          break;
        }
        case 3:
          mx = u(rng), my = u(rng);
          break;
        case 4:  // beyond every clamp below
          mx = 90.0f + u(rng), my = u(rng);
          break;
        case 5:
          mx = pick(rng) == 0 ? NAN : 1e-25f * float(pick(rng)),
          my = pick(rng) == 1 ? INFINITY : 0.0f;
          break;
        case 6:  // float squares underflow, or are subnormal (a few bits of precision)
          if (pick(rng) < 4)
            mx = 1e-40f * float(pick(rng)), my = -0.0f;
          else
            mx = 1e-21f * (1.0f + u(rng) / 3e4f), my = 1e-21f * (1.0f + u(rng) / 3e4f);
          break;
        default:
          break;  // still
      }
      f.motion.at(x, y, 0) = mx;
      f.motion.at(x, y, 1) = my;
    }
  // A 16 x 16 corner of tiny motion with two pixels whose subnormal float squares order them
  // against their double lengths by more than the scan's margin (the second is longer).
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) f.motion.at(x, y, 0) = f.motion.at(x, y, 1) = 0.0f;
  f.motion.at(2, 1, 0) = 9.999258532057552e-22f, f.motion.at(2, 1, 1) = 1.0006333793962043e-21f;
  f.motion.at(3, 1, 0) = 1.0002949138916538e-21f, f.motion.at(3, 1, 1) = 1.0005952111501661e-21f;
  // Beside it, a still block with a normal-range pair the float squares order wrongly.
  for (int y = 0; y < 16; ++y)
    for (int x = 16; x < 32; ++x) f.motion.at(x, y, 0) = f.motion.at(x, y, 1) = 0.0f;
  f.motion.at(18, 1, 0) = 13.000004768371582f, f.motion.at(18, 1, 1) = 10.99962043762207f;
  f.motion.at(19, 1, 0) = 13.0f, f.motion.at(19, 1, 1) = 10.999626159667969f;
  int compared = 0;
  for (const int radius : {16, 5, 37, 1})
    for (const float shutter : {0.5f, 1.0f, 0.37f, 0.0f}) {
      MotionBlurSettings s;
      s.max_radius = radius;
      s.shutter = shutter;
      const int tw = (w + radius - 1) / radius, th = (h + radius - 1) / radius;
      const std::vector<post::MotionTile> got = post::motion_blur_tile_max(f, s, nullptr, Exec{2});
      ASSERT_EQ(got.size(), size_t(tw) * size_t(th));
      const auto length = [](Vec2d v) { return std::sqrt(v.x * v.x + v.y * v.y); };
      for (int ty = 0; ty < th; ++ty)
        for (int tx = 0; tx < tw; ++tx) {
          Vec2d longest{0, 0};
          double lo_x = HUGE_VAL, hi_x = -HUGE_VAL, lo_y = HUGE_VAL, hi_y = -HUGE_VAL;
          for (int y = ty * radius; y < std::min(h, (ty + 1) * radius); ++y)
            for (int x = tx * radius; x < std::min(w, (tx + 1) * radius); ++x) {
              const Vec2d v = post::blur_half_vector(f.motion.at(x, y, 0), f.motion.at(x, y, 1),
                                                     shutter, radius);
              if (length(v) > length(longest)) longest = v;
              lo_x = std::min(lo_x, v.x), hi_x = std::max(hi_x, v.x);
              lo_y = std::min(lo_y, v.y), hi_y = std::max(hi_y, v.y);
            }
          const post::MotionTile& t = got[size_t(ty) * size_t(tw) + size_t(tx)];
          const auto at = ::testing::Message()
                          << radius << " " << shutter << " tile " << tx << "," << ty;
          ASSERT_EQ(std::bit_cast<uint64_t>(t.longest.x), std::bit_cast<uint64_t>(longest.x)) << at;
          ASSERT_EQ(std::bit_cast<uint64_t>(t.longest.y), std::bit_cast<uint64_t>(longest.y)) << at;
          // The box's extremes are exact in any order; a -0 may stand for a +0.
          ASSERT_EQ(t.min_x, lo_x) << at;
          ASSERT_EQ(t.max_x, hi_x) << at;
          ASSERT_EQ(t.min_y, lo_y) << at;
          ASSERT_EQ(t.max_y, hi_y) << at;
          ++compared;
        }
      const std::vector<post::MotionTile> one =
          post::motion_blur_tile_max(f, s, nullptr, Exec{1, false});
      for (size_t i = 0; i < got.size(); ++i) {
        ASSERT_EQ(std::bit_cast<uint64_t>(one[i].longest.x),
                  std::bit_cast<uint64_t>(got[i].longest.x));
        ASSERT_EQ(std::bit_cast<uint64_t>(one[i].longest.y),
                  std::bit_cast<uint64_t>(got[i].longest.y));
      }
    }
  EXPECT_GT(compared, 1000);
}

// The pass runs in SIMD lane blocks (a block of mixed paths pixel by pixel) and --simd off at
// one lane: the same bits for any thread count, on a frame with still, uniformly moving
// (fast path) and randomly moving (full path) regions and a width that leaves tails.
TEST(PostMotionBlur, SimdAndThreadsGiveTheSameBits) {
  Frame f = plane_frame(133, 71, 0.0f);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-30.0f, 30.0f);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      f.color.at(x, y, 1) = float((x * 5 + y * 3) % 13) / 3.0f;
      f.depth.at(x, y, 0) = 2.0f + float((x / 7 + y / 11) % 3) * 4.0f;
      if (x >= 90) continue;  // still
      f.motion.at(x, y, 0) = x < 45 ? -14.0f : u(rng);
      f.motion.at(x, y, 1) = x < 45 ? 3.0f : u(rng);
    }
  for (const float jitter : {0.0f, 0.25f}) {
    MotionBlurSettings s;
    s.max_radius = 12;
    s.tile_jitter = jitter;
    const ImageF ref = post::motion_blur(f, f.color, s, Exec{1, false});
    EXPECT_NE(ref, f.color);
    EXPECT_EQ(post::motion_blur(f, f.color, s, Exec{1, true}), ref) << jitter;
    EXPECT_EQ(post::motion_blur(f, f.color, s, Exec{2, true}), ref) << jitter;
    EXPECT_EQ(post::motion_blur(f, f.color, s, Exec{2, false}), ref) << jitter;
  }
}

// The pass's output (settings s, previous camera `previous`) equals the plain reference,
// motion_blur_reference, bit for bit: the fast schedule on one and two threads, --simd off (the
// reference itself) on two, and the reference on two threads.
void expect_reference_bits(const Frame& f, const MotionBlurSettings& s,
                           const FrameHeader* previous = nullptr) {
  const ImageF expected = post::motion_blur_reference(f, f.color, s, previous, Exec{1});
  ASSERT_NE(expected, f.color);
  for (const Exec& ex : {Exec{1, true}, Exec{2, true}, Exec{2, false}}) {
    const ImageF out = post::motion_blur(f, f.color, s, previous, ex);
    test::expect_same_bits(
        out, expected,
        "threads " + std::to_string(ex.threads) + " simd " + std::to_string(ex.simd));
  }
  EXPECT_EQ(post::motion_blur_reference(f, f.color, s, previous, Exec{2}), expected);
}

// Every path (copy, box filter, full filter, blocks that mix them) against the plain reference
// bit for bit, with the settings that change the arithmetic: tile jitter, no mirrored weights,
// all samples on the fast path, no fast path, pair counts that are and are not powers of two,
// a clamp that shortens vectors; depths at 0, infinite and NaN, non-finite motion; a width
// that leaves lane tails and straddles tiles.
TEST(PostMotionBlur, FastPassIsThePlainReference) {
  Frame f = plane_frame(133, 71, 0.0f);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-30.0f, 30.0f);
  const float odd_depth[] = {0.0f, INFINITY, NAN, 1e10f};
  const float odd_motion[] = {NAN, INFINITY, -INFINITY, 1e30f};
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      f.color.at(x, y, 1) = float((x * 5 + y * 3) % 13) / 3.0f;
      f.depth.at(x, y, 0) = 2.0f + float((x / 7 + y / 11) % 3) * 4.0f;
      if ((x * 7 + y * 3) % 61 == 0) f.depth.at(x, y, 0) = odd_depth[size_t(x + y) % 4];
      if (x >= 100) continue;  // still
      f.motion.at(x, y, 0) = x < 45 ? -14.0f : x < 60 ? 2.25f : u(rng);
      f.motion.at(x, y, 1) = x < 45 ? 3.0f : x < 60 ? -1.0f : u(rng);
      if (x >= 60 && (x * 3 + y * 5) % 97 == 0) f.motion.at(x, y, 0) = odd_motion[size_t(y) % 4];
    }
  std::vector<MotionBlurSettings> settings(9);
  settings[1].max_radius = 12;
  settings[1].tile_jitter = 0.25f;
  settings[2].mirror_weights = false;
  settings[3].fast_tap_spacing = 0.0f;
  settings[4].uniform_tolerance = 0.0f;
  settings[5].samples = 9;  // 4 pairs
  settings[5].shutter = 1.0f;
  settings[6].samples = 5;
  settings[6].max_radius = 7;
  settings[6].uniform_tolerance = 2.0f;
  settings[7].shutter = 0.2f;
  settings[7].soft_depth = 0.5f;
  settings[8].samples = 31;
  settings[8].tile_jitter = 0.5f;
  settings[8].fast_tap_spacing = 0.25f;
  for (size_t i = 0; i < settings.size(); ++i) {
    SCOPED_TRACE(i);
    expect_reference_bits(f, settings[i]);
  }
}

// ---- The pass before the sequence options, copied verbatim (commit e7bcc2b; its jitter is
// legacy_pixel_jitter above) ---------------------------------------------------------------

double legacy_length(Vec2d v) {
  return std::sqrt(v.x * v.x + v.y * v.y);
}
ImageF legacy_motion_blur(const Frame& f, const ImageF& color, const MotionBlurSettings& s) {
  using namespace post;
  const int w = color.width(), h = color.height(), k = s.max_radius;
  const size_t n = size_t(w) * size_t(h);
  std::vector<Vec2d> v(n);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      v[size_t(y) * size_t(w) + size_t(x)] =
          blur_half_vector(f.motion.at(x, y, 0), f.motion.at(x, y, 1), s.shutter, k);
  const int tw = (w + k - 1) / k, th = (h + k - 1) / k;
  std::vector<Vec2d> tile(size_t(tw) * size_t(th), Vec2d{0, 0}), neighbor(tile.size());
  for (int ty = 0; ty < th; ++ty)
    for (int tx = 0; tx < tw; ++tx) {
      Vec2d best{0, 0};
      for (int y = ty * k; y < std::min(h, (ty + 1) * k); ++y)
        for (int x = tx * k; x < std::min(w, (tx + 1) * k); ++x) {
          const Vec2d c = v[size_t(y) * size_t(w) + size_t(x)];
          if (legacy_length(c) > legacy_length(best)) best = c;
        }
      tile[size_t(ty) * size_t(tw) + size_t(tx)] = best;
    }
  for (int ty = 0; ty < th; ++ty)
    for (int tx = 0; tx < tw; ++tx) {
      Vec2d best{0, 0};
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int ux = tx + dx, uy = ty + dy;
          if (ux < 0 || uy < 0 || ux >= tw || uy >= th) continue;
          const Vec2d c = tile[size_t(uy) * size_t(tw) + size_t(ux)];
          if (legacy_length(c) > legacy_length(best)) best = c;
        }
      neighbor[size_t(ty) * size_t(tw) + size_t(tx)] = best;
    }
  ImageF out = color;
  const int pairs = (s.samples - 1) / 2;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Vec2d vn = neighbor[size_t(y / k) * size_t(tw) + size_t(x / k)];
      if (legacy_length(vn) <= 0.5) continue;
      const size_t ix = size_t(y) * size_t(w) + size_t(x);
      const double lx = std::max(legacy_length(v[ix]), 0.5), zx = f.depth.at(x, y, 0);
      double weight = 1.0 / lx, sum[3];
      for (int c = 0; c < 3; ++c) sum[c] = color.at(x, y, c) * weight;
      const double j = legacy_pixel_jitter(x, y);
      for (int p = 0; p < pairs; ++p) {
        const double t = (p + 0.5 + 0.5 * j) / pairs;
        for (double sign : {-1.0, 1.0}) {
          const int yx = std::clamp(int(std::floor(x + sign * t * vn.x + 0.5)), 0, w - 1);
          const int yy = std::clamp(int(std::floor(y + sign * t * vn.y + 0.5)), 0, h - 1);
          if (yx == x && yy == y) continue;
          const size_t iy = size_t(yy) * size_t(w) + size_t(yx);
          const double ly = std::max(legacy_length(v[iy]), 0.5), zy = f.depth.at(yx, yy, 0);
          const double dist = std::hypot(double(yx - x), double(yy - y));
          const double a = soft_depth_compare(zy, zx, s.soft_depth) * cone_weight(dist, ly) +
                           soft_depth_compare(zx, zy, s.soft_depth) * cone_weight(dist, lx) +
                           2.0 * cylinder_weight(dist, ly) * cylinder_weight(dist, lx);
          if (a <= 0.0) continue;
          weight += a;
          for (int c = 0; c < 3; ++c) sum[c] += a * color.at(yx, yy, c);
        }
      }
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = float(sum[c] / weight);
    }
  return out;
}

// ---- Synthetic frames with cameras ----------------------------------------------------------

constexpr double kVfov = 40.0;
constexpr double kDeg = kPi / 180.0;

double focal_px(int h) {
  return 0.5 * h / std::tan(0.5 * kVfov * kDeg);
}

// A camera at `eye` turned by `yaw` degrees about +y from looking down -Z.
Mat4 view_at(Vec3d eye, double yaw_deg) {
  const double a = yaw_deg * kDeg;
  return look_at(eye, eye + Vec3d{-std::sin(a), 0.0, -std::cos(a)}, {0, 1, 0});
}

// The header of a w x h frame seen by `view` (unjittered perspective, kVfov).
void set_camera(Frame& f, const Mat4& view) {
  Camera c;
  c.vfov_degrees = kVfov;
  c.view = view;
  f.view = view;
  f.projection = c.projection(f.width, f.height);
}

// Motion (p_prev - p_curr) of the still point seen at pixel (x, y) at depth d by frame `f`'s
// camera, under the previous camera `prev_view`: the point from the pinhole model in closed
// form, its previous position by project_to_pixel.
Vec2d still_point_motion(const Frame& f, const Mat4& prev_view, int x, int y, double d) {
  const double fp = focal_px(f.height);
  const Vec3d pv{(x + 0.5 - 0.5 * f.width) / fp * d, -(y + 0.5 - 0.5 * f.height) / fp * d, -d};
  const Vec3d world = f.view.inverse().transform_point(pv);
  Camera c;
  c.vfov_degrees = kVfov;
  const Vec2d prev =
      project_to_pixel(c.projection(f.width, f.height) * prev_view, world, f.width, f.height);
  return {prev.x - (x + 0.5), prev.y - (y + 0.5)};
}

// A striped wall at depth `d` everywhere, its motion that of still points under `prev_view`.
Frame camera_frame(int w, int h, const Mat4& view, const Mat4& prev_view, double d) {
  Frame f = plane_frame(w, h, 0.0f);
  set_camera(f, view);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.depth.at(x, y, 0) = float(d);
      const Vec2d m = still_point_motion(f, prev_view, x, y, d);
      f.motion.at(x, y, 0) = float(m.x);
      f.motion.at(x, y, 1) = float(m.y);
    }
  return f;
}

TEST(PostMotionBlurSequence, DefaultsAreThePassBeforeTheOptions) {
  // Motion of every kind: opposing, longer than max_radius, diagonal, non-finite; two depths.
  Frame f = plane_frame(131, 67, 0.0f);
  set_camera(f, view_at({0.3, 0, 0}, 1.0));
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-60.0f, 60.0f);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      f.color.at(x, y, 1) = float((x * 7 + y * 3) % 11) / 11.0f;
      f.depth.at(x, y, 0) = (x / 9 + y / 5) % 2 ? 3.0f : 12.0f;
      if ((x / 13 + y / 7) % 3 == 0) {
        f.motion.at(x, y, 0) = u(rng);
        f.motion.at(x, y, 1) = u(rng);
      } else {
        f.motion.at(x, y, 0) = (x < 65 ? 25.0f : -25.0f);
      }
    }
  f.motion.at(3, 3, 0) = std::nanf("");
  for (const int radius : {20, 7}) {
    MotionBlurSettings s;
    s.max_radius = radius;
    // The legacy pass: the full path everywhere, McGuire's unmirrored weights.
    s.uniform_tolerance = 0.0f;
    s.mirror_weights = false;
    EXPECT_FALSE(post::keeps_frames(s));
    // The legacy pass is the double-precision scalar form of the pass's float lanes: the same
    // image up to float rounding (a tap position rounding to another pixel would show here).
    const ImageF old = legacy_motion_blur(f, f.color, s);
    const ImageF pass = post::motion_blur(f, f.color, s, Exec{2});
    int off = 0;
    double worst = 0;
    for (size_t i = 0; i < old.data().size(); ++i) {
      const double e = std::abs(double(pass.data()[i]) - old.data()[i]);
      worst = std::max(worst, e);
      off += e > 1e-4;
    }
    std::printf(
        "radius %d: float lanes vs the double legacy pass: %d of %zu values off by > 1e-4, "
        "worst %.2e\n",
        radius, off, old.data().size(), worst);
    EXPECT_EQ(off, 0) << radius;
    EXPECT_LT(worst, 1e-5) << radius;
    // The sequence form with a previous camera known: exactly the pass.
    post::MotionBlurSequence seq;
    Frame prev = f;
    set_camera(prev, view_at({0, 0, 0}, 0.0));
    seq.process(prev, prev.color, s);
    EXPECT_EQ(seq.process(f, f.color, s), pass) << radius;
  }
}

// The camera translates sideways by 16 px of wall motion per frame; an object region moves
// 20 px per frame the other way on top of it (its motion: 16 - 20 = -4 px). 360-degree
// shutter: camera half vector -8 px, object half vector +10 px.
TEST(PostMotionBlurSequence, CameraAndObjectClampsActSeparately) {
  const int w = 160, h = 64;
  const double d = 10.0, tx = 16.0 * d / focal_px(h);
  const Mat4 view = view_at({0, 0, 0}, 0.0), prev_view = view_at({-tx, 0, 0}, 0.0);
  Frame f = camera_frame(w, h, view, prev_view, d);
  ASSERT_NEAR(f.motion.at(10, 10, 0), 16.0f, 1e-3f);
  const auto in_object = [](int x, int y) { return x >= 60 && x < 100 && y >= 20 && y < 44; };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (in_object(x, y)) {
        f.motion.at(x, y, 0) -= 20.0f;
        for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = c == 0 ? 1.0f : 0.1f;
      }
  FrameHeader prev = f;
  prev.view = prev_view;

  const auto expect_vectors = [&](const MotionBlurSettings& s, const FrameHeader* previous,
                                  double background, double object) {
    const ImageF v = post::motion_blur_half_vectors(f, s, previous);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        ASSERT_NEAR(v.at(x, y, 0), in_object(x, y) ? object : background, 1e-3) << x << "," << y;
        ASSERT_NEAR(v.at(x, y, 1), 0.0, 1e-3) << x << "," << y;
      }
  };
  MotionBlurSettings s;
  s.shutter = 1.0f;
  expect_vectors(s, &prev, -8.0, 2.0);  // no split: the total, (-4) * -0.5
  s.camera_max_radius = 2;
  EXPECT_TRUE(post::keeps_frames(s));
  expect_vectors(s, &prev, -2.0, -2.0 + 10.0);  // only the camera part is clamped
  expect_vectors(s, nullptr, -8.0, 2.0);        // no previous camera: all object motion
  s.camera_max_radius = 0;
  s.object_max_radius = 3;
  expect_vectors(s, &prev, -8.0, -8.0 + 3.0);  // only the object part is clamped
  s.camera_max_radius = 2;
  expect_vectors(s, &prev, -2.0, -2.0 + 3.0);

  // The image: with the camera clamped to 2 px the wall far from the object (other tiles'
  // neighbourhoods) is exactly the wall blurred by a uniform 2 px half vector, much less
  // than the 8 px of the unsplit pass.
  s = {};
  s.shutter = 1.0f;
  s.camera_max_radius = 2;
  const ImageF split = post::motion_blur(f, f.color, s, &prev);
  Frame uniform = f;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) uniform.motion.at(x, y, 0) = 4.0f;
  MotionBlurSettings plain;
  plain.shutter = 1.0f;
  const ImageF expected = post::motion_blur(uniform, uniform.color, plain);
  const ImageF unsplit = post::motion_blur(f, f.color, plain);
  double diff_unsplit = 0;
  for (int y = 0; y < h; ++y)
    for (const int x : {5, 17, 30, 125, 140, 152}) {
      EXPECT_EQ(split.at(x, y, 1), expected.at(x, y, 1)) << x << "," << y;
      diff_unsplit =
          std::max(diff_unsplit, double(std::abs(unsplit.at(x, y, 1) - split.at(x, y, 1))));
    }
  EXPECT_GT(diff_unsplit, 0.05);
}

// The camera / object split (separate clamps, rotation excluded, no previous camera) against
// the plain reference bit for bit.
TEST(PostMotionBlurSequence, SplitIsThePlainReference) {
  const int w = 101, h = 53;
  const double d = 10.0, tx = 16.0 * d / focal_px(h);
  const Mat4 view = view_at({0, 0, 0}, 2.0), prev_view = view_at({-tx, 0, 0}, 0.0);
  Frame f = camera_frame(w, h, view, prev_view, d);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.depth.at(x, y, 0) = float(d) * (1.0f + 0.1f * float((x / 9 + y / 5) % 4));
      if (x >= 40 && x < 70 && y >= 15 && y < 40) {
        f.motion.at(x, y, 0) -= 20.0f;
        f.motion.at(x, y, 1) += 5.0f;
        f.color.at(x, y, 0) = 1.0f;
      }
    }
  FrameHeader prev = f;
  prev.view = prev_view;
  for (int i = 0; i < 3; ++i) {
    MotionBlurSettings s;
    s.shutter = 1.0f;
    s.camera_max_radius = i == 0 ? 2 : 0;
    s.object_max_radius = i == 1 ? 3 : 0;
    s.camera_rotation = i != 2;
    SCOPED_TRACE(i);
    expect_reference_bits(f, s, &prev);
    expect_reference_bits(f, s, nullptr);
  }
}

TEST(PostMotionBlurSequence, RotationExclusionRemovesATurnKeepsATranslation) {
  const int w = 128, h = 64;
  MotionBlurSettings s;
  s.shutter = 1.0f;
  // A pure turn of 5 degrees (about 7.7 px at the center), walls at two depths.
  {
    const Mat4 view = view_at({0, 0, 0}, 5.0), prev_view = view_at({0, 0, 0}, 0.0);
    Frame f = camera_frame(w, h, view, prev_view, 4.0);
    ASSERT_GT(std::abs(f.motion.at(64, 32, 0)), 7.0f);
    FrameHeader prev = f;
    prev.view = prev_view;
    EXPECT_NE(post::motion_blur(f, f.color, s, &prev), f.color);  // rotation included: blurs
    s.camera_rotation = false;
    const ImageF v = post::motion_blur_half_vectors(f, s, &prev);
    for (float c : v.data()) ASSERT_NEAR(c, 0.0f, 1e-4f);
    EXPECT_EQ(post::motion_blur(f, f.color, s, &prev), f.color);  // no blur left at all
    // No previous camera: nothing can be told apart, the motion blurs as object motion.
    EXPECT_NE(post::motion_blur(f, f.color, s, nullptr), f.color);
  }
  // A pure translation: the same blur as with rotation included.
  {
    const double d = 10.0, tx = 12.0 * d / focal_px(h);
    const Mat4 view = view_at({0, 0, 0}, 0.0), prev_view = view_at({-tx, 0, 0}, 0.0);
    Frame f = camera_frame(w, h, view, prev_view, d);
    FrameHeader prev = f;
    prev.view = prev_view;
    s.camera_rotation = false;
    const ImageF v = post::motion_blur_half_vectors(f, s, &prev);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) ASSERT_NEAR(v.at(x, y, 0), -6.0f, 1e-3f);
    const ImageF a = post::motion_blur(f, f.color, s, &prev), b = post::motion_blur(f, f.color, {});
    MotionBlurSettings all = s;
    all.camera_rotation = true;
    const ImageF c = post::motion_blur(f, f.color, all, &prev);
    for (size_t i = 0; i < a.data().size(); ++i) {
      ASSERT_NEAR(a.data()[i], c.data()[i], 1e-5f) << i;
      ASSERT_NE(a.data()[i], 0.0f);
    }
    EXPECT_NE(b, f.color);
  }
  // Turn and translation together: what is left is the translation, in closed form
  // (12 px of wall motion -> half vector -6 px with the 360-degree shutter).
  {
    const double d = 10.0, tx = 12.0 * d / focal_px(h);
    const Mat4 view = view_at({0, 0, 0}, 4.0);
    // The previous camera: 12 px of translation to the left along this frame's x axis, and
    // turned 4 degrees back.
    const double a = 4.0 * kDeg;
    const Mat4 prev_view = view_at({-tx * std::cos(a), 0, tx * std::sin(a)}, 0.0);
    Frame f = camera_frame(w, h, view, prev_view, d);
    FrameHeader prev = f;
    prev.view = prev_view;
    s.camera_rotation = false;
    const ImageF v = post::motion_blur_half_vectors(f, s, &prev);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        ASSERT_NEAR(v.at(x, y, 0), -6.0f, 1e-3f) << x << "," << y;
        ASSERT_NEAR(v.at(x, y, 1), 0.0f, 1e-3f) << x << "," << y;
      }
  }
}

// A 3x3 dot of HDR value 8 moving 3 px per frame over a background of 0.25 (values whose sums
// are exact in double): the trail is the box average of the last N inputs, bit for bit.
TEST(PostMotionBlurSequence, TrailIsTheBoxAverageOfTheLastFrames) {
  const int w = 64, h = 16, n = 4;
  std::vector<Frame> frames;
  for (int t = 0; t < 12; ++t) {
    Frame f = plane_frame(w, h, 0.0f);
    f.index = t;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          const bool dot = std::abs(x - (5 + 3 * t)) <= 1 && std::abs(y - 8) <= 1;
          f.color.at(x, y, c) = dot ? 8.0f : 0.25f;
          f.motion.at(x, y, 0) = dot ? -3.0f : 0.0f;
        }
    frames.push_back(std::move(f));
  }
  MotionBlurSettings s;
  s.trail_frames = n;
  s.shutter = 0.0f;  // the pure accumulation of seed 004: no per-frame blur
  EXPECT_TRUE(post::keeps_frames(s));
  post::MotionBlurSequence seq;
  for (int t = 0; t < int(frames.size()); ++t) {
    const ImageF out = seq.process(frames[size_t(t)], frames[size_t(t)].color, s);
    const int first = std::max(0, t - n + 1);
    ImageF expected(w, h, 3);
    for (size_t i = 0; i < expected.data().size(); ++i) {
      double sum = 0;
      for (int u = first; u <= t; ++u) sum += frames[size_t(u)].color.data()[i];
      expected.data()[i] = float(sum / (t - first + 1));
    }
    ASSERT_EQ(out, expected) << "frame " << t;
  }
  // A camera cut starts the window again.
  Frame cut = frames[3];
  cut.camera_cut = true;
  EXPECT_EQ(seq.process(cut, cut.color, s), cut.color);
  seq.reset();
  EXPECT_EQ(seq.process(frames[7], frames[7].color, s), frames[7].color);
  // A constant sequence is unchanged.
  post::MotionBlurSequence still;
  for (int t = 0; t < 10; ++t)
    EXPECT_EQ(still.process(frames[0], frames[0].color, s), frames[0].color);
}

// Arbitrary values over a long sequence: adding and subtracting does not drift away from the
// window's mean (the sum is rebuilt each time the window turns over).
TEST(PostMotionBlurSequence, RunningSumStaysTheWindowMean) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1000.0f);
  const int n = 5;
  std::vector<ImageF> images;
  post::RunningSumTrail trail;
  for (int t = 0; t < 60; ++t) {
    ImageF im(7, 5, 3);
    for (float& v : im.data()) v = t % 7 == 0 ? u(rng) * 1e-3f : u(rng);
    images.push_back(im);
    const ImageF out = trail.push(im, n, Exec{2});
    EXPECT_EQ(trail.size(), std::min(t + 1, n));
    const int first = std::max(0, t - n + 1);
    for (size_t i = 0; i < im.data().size(); ++i) {
      double sum = 0;
      for (int k = first; k <= t; ++k) sum += images[size_t(k)].data()[i];
      ASSERT_NEAR(out.data()[i], sum / (t - first + 1), 1e-4) << t << " " << i;
    }
  }
}

TEST(PostMotionBlurSequence, TileJitterIsDeterministicAndKeepsStillPixels) {
  Frame f = plane_frame(97, 41, -9.0f);
  for (int y = 0; y < 41; ++y) f.motion.at(50, y, 1) = 3.0f;
  MotionBlurSettings s;
  s.tile_jitter = 0.25f;
  const ImageF a = post::motion_blur(f, f.color, s, Exec{1});
  EXPECT_EQ(a, post::motion_blur(f, f.color, s, Exec{2}));
  EXPECT_NE(a, post::motion_blur(f, f.color, {}));
  Frame g = plane_frame(64, 32, 0.0f);
  EXPECT_EQ(post::motion_blur(g, g.color, s), g.color);
}

}  // namespace
}  // namespace afterimage
