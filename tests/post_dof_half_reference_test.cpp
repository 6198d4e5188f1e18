// Depth of field at half resolution (dof.resolution=half): the fast schedule's half path
// (dof_gather_fast.cpp: the CoC-aware downsample, the layers' gather, the tiles that take them
// and the composite) equals its plain statement (dof_reference.cpp, composite_half_res) bit for
// bit, for both CoC sources, disc and polygon bokeh, half_from 0 and above, the focus plane near
// and far, odd and tiny sizes, degenerate depths and non-finite colors; --simd off runs it.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "camera/camera.h"
#include "core/error.h"
#include "core/parallel.h"
#include "post/dof.h"
#include "test_util.h"

namespace afterimage {
namespace dof_half_reference_test {  // (the test binary is unity-built: names kept apart)
namespace {

// A frame of view depths by a quarter of the width each: close to the focus plane s (radii under
// half a pixel), 0.3 .. 2.3 m, 0.3 .. 38 m spread, 4 .. 40 m; with `odd`, degenerate depths
// sprinkled (0, negative, infinite, NaN, s and its float neighbours, 1e30). The lens blurs alike
// at every width: 100 mm, its sensor 36 mm at 64 px, f/1 (f/0.25 for a focus beyond 10 m, so
// that the near field's radii reach the clamp). Colors HDR up to 4, none negative.
Frame depth_bands(int w, int h, float s, bool odd) {
  Frame f = Frame::allocate(w, h);
  f.lens.focal_length_mm = 100.0;
  f.lens.f_number = s > 10.0f ? 0.25 : 1.0;
  f.lens.focus_distance = s;
  f.lens.sensor_width_mm = 36.0 * w / 64.0;
  const float degenerate[] = {0.0f,
                              -1.0f,
                              std::numeric_limits<float>::infinity(),
                              std::nanf(""),
                              s,
                              std::nextafter(s, 0.0f),
                              std::nextafter(s, 1e30f),
                              1e30f};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int v = (x * 7 + y * 13) % 41, band = 4 * x / w;
      float z = band == 0   ? s * (0.97f + 0.0015f * float(v))
                : band == 1 ? 0.3f + 0.05f * float(v)
                : band == 2 ? 0.3f * std::exp2(float(v) / 5.7f)
                            : 4.0f + 0.9f * float(v);
      if (odd && (x + 2 * y) % 13 == 0) z = degenerate[size_t(x * 3 + y) % 8];
      f.depth.at(x, y, 0) = z;
      f.color.at(x, y, 0) = 0.25f + 0.75f * float((x / 3 + y / 2) % 2);
      f.color.at(x, y, 1) = float((x * x + 3 * y) % 17) / 4.0f;
      f.color.at(x, y, 2) = float((5 * x + y * y) % 7) / 2.0f;
    }
  return f;
}

post::DofSettings half_settings(float half_from) {
  post::DofSettings s;
  s.resolution = post::DofResolution::half;
  s.half_from = half_from;
  return s;
}

// coc=ranges, the ranges scaled to the focus distance s of depth_bands.
post::DofSettings half_ranges(float half_from, float s) {
  post::DofSettings r = half_settings(half_from);
  r.coc = post::DofCoc::ranges;
  r.near_start = 0.4f * s;
  r.near_end = 0.9f * s;
  r.far_start = 1.2f * s;
  r.far_end = 3.0f * s;
  r.near_radius = 12.0f;
  r.far_radius = 9.0f;
  return r;
}

// The fast half path (SIMD on, two threads) equals the plain statement on one and three threads
// and the pass with --simd off, bit for bit; returns the fast one's output.
ImageF expect_half_reference_bits(const Frame& f, const post::DofSettings& s,
                                  const std::string& what) {
  const ImageF fast = post::depth_of_field(f, f.color, s, Exec{2, true});
  for (const int threads : {1, 3})
    test::expect_same_bits(post::dof_reference(f, f.color, s, Exec{threads}), fast,
                           what + ", dof_reference threads " + std::to_string(threads));
  test::expect_same_bits(post::depth_of_field(f, f.color, s, Exec{2, false}), fast,
                         what + ", --simd off");
  return fast;
}

const std::pair<int, int> kSizes[] = {{64, 36}, {33, 17}, {7, 5}, {1, 1}, {2, 3}};

std::string size_name(int w, int h) {
  return std::to_string(w) + "x" + std::to_string(h);
}

// The lens's CoC with the focus plane near (1 m: most of the frame behind it), in the middle
// and far (20 m: most in front), a disc and polygons of odd (front and back differ) and even blade
// counts, every blurred tile at half resolution (half_from 0) or only the large blurs (4).
TEST(PostDofHalfReference, LensCocIsThePlainHalfPath) {
  for (const auto& [w, h] : kSizes)
    for (const float focus : {1.0f, 3.0f, 20.0f}) {
      const Frame f = depth_bands(w, h, focus, true);
      for (const int blades : {0, 5, 6})
        for (const float from : {0.0f, 4.0f}) {
          post::DofSettings s = half_settings(from);
          s.blades = blades;
          s.blade_rotation = 20.0f;
          const std::string what = size_name(w, h) + " focus " + std::to_string(focus) +
                                   " blades " + std::to_string(blades) + " half_from " +
                                   std::to_string(from);
          const ImageF fast = expect_half_reference_bits(f, s, what);
          if (w >= 33) {  // the half path ran: not the full-resolution gather's image
            post::DofSettings full = s;
            full.resolution = post::DofResolution::full;
            EXPECT_NE(fast, post::depth_of_field(f, f.color, full)) << what;
          }
        }
    }
}

// coc=ranges (artist depth ranges, no lens), disc and pentagon.
TEST(PostDofHalfReference, ArtistRangesAreThePlainHalfPath) {
  for (const auto& [w, h] : kSizes) {
    Frame f = depth_bands(w, h, 3.0f, true);
    f.lens.f_number = 0.0;  // the ranges need no lens
    for (const int blades : {0, 5})
      for (const float from : {0.0f, 4.0f}) {
        post::DofSettings s = half_ranges(from, 3.0f);
        s.blades = blades;
        const ImageF fast = expect_half_reference_bits(f, s,
                                                       size_name(w, h) + " ranges blades " +
                                                           std::to_string(blades) + " half_from " +
                                                           std::to_string(from));
        if (w >= 33) {
          EXPECT_NE(fast, f.color);
        }
      }
  }
}

// Other tile sizes (max_radius 6 and 5: half tiles of 6 x 3 half pixels, an odd max_radius
// rounded up), fewer taps, and half_from between the tiles' radii.
TEST(PostDofHalfReference, TileSizesAndTapsAreThePlainHalfPath) {
  for (const auto& [w, h] : {std::pair{64, 36}, std::pair{33, 17}}) {
    const Frame f = depth_bands(w, h, 3.0f, true);
    for (const int k : {6, 5})
      for (const float from : {0.0f, 2.5f, 5.0f}) {
        post::DofSettings s = half_settings(from);
        s.max_radius = k;
        s.taps = 24;
        expect_half_reference_bits(f, s,
                                   size_name(w, h) + " max_radius " + std::to_string(k) +
                                       " half_from " + std::to_string(from));
      }
  }
}

// Radii that grow across the frame without reaching the clamp (a depth ramp behind a focus
// plane at 1 m: 0.5 .. ~7 px), so that each tile's neighbourhood radius, its taps and whether it
// reaches half_from follow the tiles' shape and size (the half image's tiles are twice as wide
// as tall).
TEST(PostDofHalfReference, RampsAreThePlainHalfPath) {
  for (const auto& [w, h] : {std::pair{96, 40}, std::pair{33, 17}}) {
    Frame f = depth_bands(w, h, 1.0f, false);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        f.depth.at(x, y, 0) = 1.05f + 2.5f * float(x) / float(w) + 0.4f * float(y) / float(h) +
                              0.002f * float((x * 7 + y * 13) % 41);
    for (const int k : {16, 6})
      for (const float from : {0.0f, 3.0f, 4.5f}) {
        post::DofSettings s = half_settings(from);
        s.max_radius = k;
        expect_half_reference_bits(f, s,
                                   size_name(w, h) + " ramp max_radius " + std::to_string(k) +
                                       " half_from " + std::to_string(from));
      }
  }
}

// Frame f with colors replaced from `odd` at about one pixel in 211.
Frame with_odd_colors(Frame f, const std::vector<float>& odd) {
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x)
      if ((x * 5 + y * 11) % 211 == 0)
        f.color.at(x, y, (x + y) % 3) = odd[size_t(x + y) % odd.size()];
  return f;
}

// Some of the image finite, some not.
void expect_some_non_finite(const ImageF& out, const std::string& what) {
  size_t finite = 0;
  for (const float v : out.data()) finite += std::isfinite(v);
  EXPECT_GT(finite, out.data().size() / 2) << what;
  EXPECT_LT(finite, out.data().size()) << what;
}

// Non-finite colors: the downsample averages them in whatever their weight (0 times an infinity
// is NaN), the layers' gather adds a tap's colors only where its weight is positive (the fast
// one recomputes a block masked where a sum turned NaN), the composite keeps a sharp pixel's own
// color where no layer reaches it. Bit for bit with infinities and the largest finite colors
// (every NaN the invalid operations' default NaN) and with NaNs (every NaN the input's).
TEST(PostDofHalfReference, NonFiniteColorsAreThePlainHalfPath) {
  const float inf = std::numeric_limits<float>::infinity();
  for (const auto& [w, h] : {std::pair{64, 36}, std::pair{33, 17}, std::pair{7, 5}})
    for (const float focus : {1.0f, 20.0f})
      for (const bool nan : {false, true}) {
        const Frame f = with_odd_colors(
            depth_bands(w, h, focus, false),
            nan ? std::vector<float>{std::nanf("")} : std::vector<float>{inf, -inf, 1e38f, -1e38f});
        for (const float from : {0.0f, 4.0f}) {
          const std::string what = size_name(w, h) + (nan ? " NaN" : " infinite") + " focus " +
                                   std::to_string(focus) + " half_from " + std::to_string(from);
          const ImageF fast = expect_half_reference_bits(f, half_settings(from), what);
          if (w >= 33) expect_some_non_finite(fast, what);
        }
      }
}

// NaN and infinite colors together: where an input NaN (positive) and a default NaN (negative,
// from 0 times an infinity) meet in one addition, the sign of the resulting NaN is the first
// operand's, and which operand is first the compiler chooses (an addition commutes), in the
// fast schedule's vector code and its one-lane code alike. So here a NaN equals any NaN; every
// other value bit for bit.
TEST(PostDofHalfReference, MixedNaNsAreThePlainHalfPathButForTheirSign) {
  const float inf = std::numeric_limits<float>::infinity();
  for (const float focus : {1.0f, 20.0f}) {
    const Frame f =
        with_odd_colors(depth_bands(64, 36, focus, false), {inf, -inf, std::nanf(""), 1e38f});
    for (const float from : {0.0f, 4.0f}) {
      const post::DofSettings s = half_settings(from);
      const ImageF fast = post::depth_of_field(f, f.color, s, Exec{2, true});
      expect_some_non_finite(fast, "mixed");
      for (const int threads : {1, 3}) {
        const ImageF plain = post::dof_reference(f, f.color, s, Exec{threads});
        for (int y = 0; y < f.height; ++y)
          for (int x = 0; x < f.width; ++x)
            for (int c = 0; c < 3; ++c) {
              const float p = plain.at(x, y, c), q = fast.at(x, y, c);
              ASSERT_TRUE(std::isnan(p) ? std::isnan(q)
                                        : std::bit_cast<uint32_t>(p) == std::bit_cast<uint32_t>(q))
                  << x << " " << y << " " << c << " focus " << focus << " half_from " << from;
            }
      }
    }
  }
}

// The plain statement states the gather only.
TEST(PostDofHalfReference, DiffusionHasNoPlainStatement) {
  const Frame f = depth_bands(16, 8, 3.0f, false);
  post::DofSettings s = half_settings(4.0f);
  s.mode = post::DofMode::diffusion;
  EXPECT_THROW(post::dof_reference(f, f.color, s), SettingsError);
}

}  // namespace
}  // namespace dof_half_reference_test
}  // namespace afterimage
