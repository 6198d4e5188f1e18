// Depth of field pass (issue 12): the focus field is unchanged, the near field spreads over the
// sharp background while the far field does not spread over a sharp foreground, and on the
// `focus` scene the pass applied to the pinhole reference comes closer to the ray-traced
// thin-lens reference than the pinhole image (the gather and the diffusion mode).
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <utility>
#include <vector>

#include "camera/camera.h"
#include "core/error.h"
#include "display_util.h"
#include "metrics/display.h"
#include "metrics/flip.h"
#include "post/dof.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "test_util.h"

namespace afterimage {
namespace {

// 50 mm f/2 on a 36 mm sensor, focused at 3 m.
ThinLens lens() {
  ThinLens l;
  l.focal_length_mm = 50.0;
  l.f_number = 2.0;
  l.focus_distance = 3.0;
  return l;
}

Frame two_planes(int w, int h, float left_depth, float right_depth) {
  Frame f = Frame::allocate(w, h);
  f.lens = lens();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool left = x < w / 2;
      f.depth.at(x, y, 0) = left ? left_depth : right_depth;
      f.color.at(x, y, 0) = left ? 1.0f : 0.2f + 0.2f * float((x / 3) % 2);
      f.color.at(x, y, 1) = left ? 0.0f : f.color.at(x, y, 0);
      f.color.at(x, y, 2) = left ? 0.0f : f.color.at(x, y, 0);
    }
  return f;
}

// A frame with no lens (another renderer's file) is blurred only by a lens the settings give
// in full, or by artist ranges; the pass refuses it otherwise, where it had blurred by
// ThinLens's defaults (a 50 mm lens focused at 5 m, nobody's camera) or left it as a pinhole.
TEST(PostDof, AFrameWithoutALensNeedsOneFromTheSettings) {
  Frame f = two_planes(40, 12, 1.0f, 20.0f);
  f.lens = ThinLens{};
  f.lens_known = false;
  post::DofSettings s;
  EXPECT_THROW(post::depth_of_field(f, f.color, s), InputError);
  s.f_number = 2.0f;
  s.focal_length = 50.0f;
  EXPECT_THROW(post::checked_dof_lens(f, s), InputError);  // still no focus distance
  s.focus_distance = 3.0f;
  EXPECT_EQ(post::checked_dof_lens(f, s), lens());
  Frame known = f;
  known.lens = lens();
  known.lens_known = true;
  EXPECT_EQ(post::depth_of_field(f, f.color, s),
            post::depth_of_field(known, known.color, post::DofSettings{}));
  post::DofSettings ranges;
  ranges.coc = post::DofCoc::ranges;
  EXPECT_NE(post::depth_of_field(f, f.color, ranges), f.color);
  // A known pinhole is left as it is, and said to be.
  known.lens.f_number = 0.0;
  std::string said;
  post::checked_dof_lens(known, post::DofSettings{}, [&](const std::string& m) { said = m; });
  EXPECT_NE(said.find("pinhole"), std::string::npos) << said;
  EXPECT_EQ(post::depth_of_field(known, known.color, post::DofSettings{}), known.color);
}

TEST(PostDof, WeightsAndSettings) {
  EXPECT_EQ(aggregate_member_count<post::DofSettings>(), post::DofSettings::params().size());
  EXPECT_FLOAT_EQ(post::disc_coverage(4.0f, 3.0f), 1.0f);
  EXPECT_FLOAT_EQ(post::disc_coverage(4.0f, 4.25f), 0.25f);
  EXPECT_FLOAT_EQ(post::disc_coverage(4.0f, 5.0f), 0.0f);
  // tap_coverage is count times disc_coverage (one FMA: equal up to rounding).
  for (const float count : {1.0f, 2.0f, 3.0f})
    for (const float r : {0.5f, 1.7f, 4.0f, 9.25f})
      for (const float dist : {1.0f, 1.4142135f, 4.25f, 5.0f, 9.9f})
        EXPECT_NEAR(post::tap_coverage(count, r, post::tap_edge(count, dist)),
                    count * post::disc_coverage(r, dist), 1e-5f)
            << count << " " << r << " " << dist;
  EXPECT_FLOAT_EQ(post::effective_radius(6.0f, 10.0f, 1.0f, 3.0f), 1.0f);  // behind: p's radius
  EXPECT_FLOAT_EQ(post::effective_radius(6.0f, 1.0f, 1.0f, 3.0f), 6.0f);   // in front: its own
  post::DofSettings s;
  EXPECT_THROW(s.set_assignment("taps=2"), SettingsError);
}

// The pass's radii are circle_of_confusion_px's within a few float ulps (of the radius, or of
// the lens's radius scale h near the focus plane, where 1 - s / z cancels), the same bits on
// lanes and at one lane, for depths near, far, on the focus plane, at the background depth and
// degenerate (0, negative, infinite, NaN: 0 where the double CoC is not finite); monotone on
// each side of the focus plane (the gather's depth classes rest on it) down to adjacent floats
// and out to the largest float.
TEST(PostDof, GatherRadiusIsTheLensCoc) {
  const ThinLens l = lens();
  const int w = 1919, k = 16;
  const post::CocLens c(l, w, k);
  std::vector<float> depths = {0.0f, -1.0f,  1e-30f, 0.05f,    0.5f,      2.999f,
                               3.0f, 3.001f, 1e10f,  INFINITY, -INFINITY, NAN};
  for (int i = 0; i < 200; ++i) depths.push_back(0.3f + 0.137f * float(i) * float(i % 7));
  while (depths.size() % 16 != 0) depths.push_back(1.5f);
  std::vector<float> lanes(depths.size());
  const FullTag d;
  for (size_t i = 0; i + hn::Lanes(d) <= depths.size(); i += hn::Lanes(d))
    hn::StoreU(post::gather_radius_lanes(d, hn::LoadU(d, depths.data() + i), c), d,
               lanes.data() + i);
  for (size_t i = 0; i < depths.size(); ++i) {
    const double coc = circle_of_confusion_px(l, depths[i], w);
    const double expected = std::isfinite(coc) ? std::min(0.5 * std::abs(coc), double(k)) : 0.0;
    const float r = post::gather_radius(depths[i], c);
    EXPECT_NEAR(r, expected, 4.0 * FLT_EPSILON * (expected + c.h)) << depths[i];
    if (expected == 0.0) {
      EXPECT_EQ(r, 0.0f) << depths[i];
    }
    EXPECT_EQ(std::bit_cast<uint32_t>(lanes[i]), std::bit_cast<uint32_t>(r)) << depths[i];
  }
  // Monotone: float steps across the focus plane, and growing depths far behind and in front.
  const float s = float(l.focus_distance);
  float z = s, prev = post::gather_radius(z, c);
  for (int i = 0; i < 20000; ++i) {
    z = std::nextafter(z, INFINITY);
    const float r = post::gather_radius(z, c);
    ASSERT_GE(r, prev) << z;
    prev = r;
  }
  prev = 0.0f;
  for (z = s; z < 3e38f; z *= 1.37f) {
    const float r = post::gather_radius(z, c);
    ASSERT_GE(r, prev) << z;
    prev = r;
  }
  z = s;
  prev = post::gather_radius(z, c);
  for (int i = 0; i < 20000; ++i) {
    z = std::nextafter(z, 0.0f);
    const float r = post::gather_radius(z, c);
    ASSERT_GE(r, prev) << z;
    prev = r;
  }
  for (; z > 1e-44f; z *= 0.71f) {  // on from the last step
    const float r = post::gather_radius(z, c);
    ASSERT_GE(r, prev) << z;
    prev = r;
  }
  EXPECT_EQ(prev, float(k));  // the clamp, also where s / z overflows
}

// One bright pixel on a plane of uniform CoC radius r spreads with about the disc's variance,
// r^2 / 4 per axis (the thin-lens reference is that disc filtered by the pixel footprint the
// input already has), never more. At small radii most of the spiral's taps round to the pixel
// itself: counting them as its weight (as every other pixel's merged taps count) keeps it;
// counting them once had given r = 0.75 px 3.2x the disc's variance.
TEST(PostDof, BlurOfAPointHasTheDiscsVariance) {
  const int n = 41, cx = 20;
  const ThinLens l = lens();
  const post::CocLens c(l, n, 16);
  for (const float r : {0.75f, 1.0f, 1.5f, 2.0f, 3.0f, 4.5f}) {
    // The depth behind the focus plane with 0.5 |CoC| = r: r = 0.5 k (z - s) / z.
    const double z = l.focus_distance / (1.0 - 2.0 * double(r) / c.k);
    Frame f = Frame::allocate(n, n);
    f.lens = l;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) f.depth.at(x, y, 0) = float(z);
    ASSERT_NEAR(post::gather_radius(float(z), c), r, 1e-4f);
    f.color.at(cx, cx, 0) = 1.0f;
    const ImageF out = post::depth_of_field(f, f.color, {}, Exec{1, true});
    double sum = 0, mx = 0;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        sum += out.at(x, y, 0);
        mx += out.at(x, y, 0) * double(x - cx) * double(x - cx);
      }
    // Measured: 0.55, 0.95, 0.91, 0.88, 0.90, 0.90 of the disc's (the taps at the disc's edge
    // lose half their weight to the one-pixel soft edge); with the pixel's own spiral taps
    // counted once, 3.2, 2.0, 1.11, 0.95, 0.93, 0.91.
    const double disc = double(r) * double(r) / 4.0;
    EXPECT_LE(mx / sum, 1.05 * disc) << r;
    EXPECT_GE(mx / sum, (r < 1.0f ? 0.5 : 0.85) * disc) << r;
  }
}

TEST(PostDof, PinholeAndFocusFieldAreUnchanged) {
  Frame f = two_planes(96, 24, 1.0f, 10.0f);
  f.lens.f_number = 0.0;
  EXPECT_EQ(post::depth_of_field(f, f.color, {}), f.color);
  Frame g = two_planes(96, 24, 3.0f, 3.0f);  // everything on the focus plane
  EXPECT_EQ(post::depth_of_field(g, g.color, {}), g.color);
  Frame h = Frame::allocate(8, 8, ChannelSet{Channel::color});
  h.lens = lens();
  EXPECT_THROW(post::depth_of_field(h, h.color, {}), InputError);
  // A lens focused nearer than its focal length (a 1-pixel-wide render's long lens): the
  // frame's data, so an InputError naming the frame.
  Frame k = two_planes(8, 8, 1.0f, 10.0f);
  k.index = 7;
  k.lens.focal_length_mm = 4000.0;
  try {
    post::depth_of_field(k, k.color, {});
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("frame 7"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("focal length"), std::string::npos) << e.what();
  }
}

TEST(PostDof, NearFieldSpreadsOverSharpBackgroundFarFieldDoesNot) {
  const int w = 320, h = 32;
  const double coc_near = circle_of_confusion_px(lens(), 1.0, w);  // about -7.5 px
  ASSERT_LT(coc_near, -6.0);
  // Near red plane on the left (1 m), in-focus stripes on the right (3 m).
  {
    const Frame f = two_planes(w, h, 1.0f, 3.0f);
    const ImageF out = post::depth_of_field(f, f.color, {});
    const int r = int(std::ceil(0.5 * std::abs(coc_near)));
    // Right of the edge within the near disc: red has spread over the sharp stripes.
    EXPECT_GT(out.at(w / 2 + 1, 16, 0) - out.at(w / 2 + 1, 16, 1), 0.1f);
    // Farther than the near disc: the stripes are exactly as they were (focus field).
    for (int x = w / 2 + r + 2; x < w; ++x) EXPECT_EQ(out.at(x, 16, 1), f.color.at(x, 16, 1)) << x;
  }
  // In-focus red plane on the left (3 m), far stripes on the right (30 m, blurred): the far
  // field's blur does not spread over the sharp red plane.
  {
    const Frame f = two_planes(w, h, 3.0f, 30.0f);
    const ImageF out = post::depth_of_field(f, f.color, {});
    for (int x = 0; x < w / 2; ++x) {
      EXPECT_FLOAT_EQ(out.at(x, 16, 0), 1.0f) << x;
      EXPECT_FLOAT_EQ(out.at(x, 16, 1), 0.0f) << x;
    }
    // The far stripes themselves are blurred (their contrast drops).
    EXPECT_LT(std::abs(out.at(240, 16, 1) - out.at(243, 16, 1)), 0.1f);
  }
  const Frame f = two_planes(97, 31, 1.0f, 30.0f);
  EXPECT_EQ(post::depth_of_field(f, f.color, {}, Exec{1}),
            post::depth_of_field(f, f.color, {}, Exec{2}));
}

// The gather runs in SIMD lane blocks with a 1-lane tail; --simd off runs the plain gather
// (dof_reference): the same bits, for any thread count, on depths that vary per pixel (near,
// focus, far) and a width that leaves tails in every tile.
TEST(PostDof, SimdAndThreadsGiveTheSameBits) {
  Frame f = two_planes(133, 45, 1.0f, 30.0f);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      f.depth.at(x, y, 0) = 0.8f + 0.35f * float((x * 7 + y * 13) % 41);
      f.color.at(x, y, 1) = float((x * x + 3 * y) % 17) / 4.0f;  // HDR values up to 4
    }
  const ImageF ref = post::depth_of_field(f, f.color, {}, Exec{1, false});
  EXPECT_NE(ref, f.color);
  EXPECT_EQ(post::depth_of_field(f, f.color, {}, Exec{1, true}), ref);
  EXPECT_EQ(post::depth_of_field(f, f.color, {}, Exec{2, true}), ref);
  EXPECT_EQ(post::depth_of_field(f, f.color, {}, Exec{2, false}), ref);
}

// The pass's output (settings `s`, default) equals `expected` bit for bit: the fast schedule
// on one and two threads (SIMD on), and --simd off (the plain statement, dof_reference) on one
// and two threads.
void expect_plain_gather_bits(const Frame& f, const ImageF& expected,
                              const post::DofSettings& s = {}) {
  for (const Exec& ex : {Exec{1, true}, Exec{2, true}, Exec{1, false}, Exec{2, false}}) {
    const ImageF out = post::depth_of_field(f, f.color, s, ex);
    test::expect_same_bits(
        out, expected,
        "threads " + std::to_string(ex.threads) + " simd " + std::to_string(ex.simd));
  }
}

// The plain gather (dof_reference, one thread) of f with settings s.
ImageF plain_gather(const Frame& f, const post::DofSettings& s = {}) {
  return post::dof_reference(f, f.color, s, Exec{1});
}

// The pass equals the plain gather (dof_reference) bit for bit where the neighbourhoods lie all in
// front of the focus plane, all behind it (both skip the depth test of effective_radius) or on both
// sides, with degenerate depths (0, negative, infinite, NaN, beyond the far class's limit). Wider
// than two of the gather's strips (224 px at max_radius 16, gather_tiles).
TEST(PostDof, GatherIsThePlainGatherInEveryDepthClass) {
  const int w = 483, h = 77;
  Frame f = two_planes(w, h, 1.0f, 30.0f);
  f.lens.f_number = 1.0;  // radii up to the clamp
  const float odd[] = {0.0f, -1.0f, INFINITY, NAN, 3.0f, 3.5e7f, 1e30f, 2.9999998f, 3.0000002f};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int v = (x * 7 + y * 13) % 41;
      float z = x < 64    ? 0.4f + 0.064f * float(v)  // in front: 0.4 .. 3.0 m
                : x < 128 ? 3.0f + 0.9f * float(v)    // behind: 3 .. 39 m
                          : 0.8f + 0.35f * float(v);  // both sides
      if (x >= 150 && (x + y) % 23 == 0) z = odd[size_t(x + y) % 9];
      f.depth.at(x, y, 0) = z;
      f.color.at(x, y, 1) = float((x * x + 3 * y) % 17) / 4.0f;  // HDR values up to 4
    }
  const ImageF expected = plain_gather(f);
  EXPECT_NE(expected, f.color);
  expect_plain_gather_bits(f, expected);
}

// Non-finite colors reach only the pixels that give them a positive weight, as in the plain
// gather (which adds a tap's colors only then): the pass adds its taps unmasked and recomputes
// a block masked where a sum turned NaN (0 times an infinity; gather_sources_sums).
TEST(PostDof, NonFiniteColorsSpreadAsInThePlainGather) {
  const int w = 203, h = 77;
  Frame f = two_planes(w, h, 1.0f, 30.0f);
  f.lens.f_number = 1.0;
  const float odd[] = {INFINITY, -INFINITY, NAN, 1e38f};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int v = (x * 7 + y * 13) % 41;
      f.depth.at(x, y, 0) = x < 64    ? 0.4f + 0.064f * float(v)
                            : x < 128 ? 3.0f + 0.9f * float(v)
                                      : 0.8f + 0.35f * float(v);
      f.color.at(x, y, 1) = float((x * x + 3 * y) % 17) / 4.0f;
      if ((x * 5 + y * 11) % 397 == 0) f.color.at(x, y, (x + y) % 3) = odd[size_t(x + y) % 4];
    }
  const ImageF expected = plain_gather(f);
  const auto finite_at = [](const ImageF& im, int x, int y) {
    return std::isfinite(im.at(x, y, 0)) && std::isfinite(im.at(x, y, 1)) &&
           std::isfinite(im.at(x, y, 2));
  };
  // Finite outputs, and those of them with a non-finite color within 16 px (in the taps' reach:
  // their zero-weight taps read it).
  size_t finite = 0, beside = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!finite_at(expected, x, y)) continue;
      ++finite;
      bool near = false;
      for (int qy = std::max(0, y - 16); qy <= std::min(h - 1, y + 16) && !near; ++qy)
        for (int qx = std::max(0, x - 16); qx <= std::min(w - 1, x + 16) && !near; ++qx)
          near = !finite_at(f.color, qx, qy);
      beside += near;
    }
  EXPECT_GT(finite, size_t(w * h / 2));
  EXPECT_LT(finite, size_t(w * h));
  EXPECT_GT(beside, 1000u);
  expect_plain_gather_bits(f, expected);
}

// The same where the gather takes its shortcuts: tiles whose 3x3 tiles hold one radius (here
// the max_radius clamp: gather_block_uniform's constant weights) and tiles of wide radii
// (10..16 px, in front of the focus plane: the inner taps cover every pixel fully, no radius
// or depth read), beside tiles of small and mixed radii in front of and behind it.
TEST(PostDof, GatherIsThePlainGatherOnUniformAndWideTiles) {
  const int w = 150, h = 100;
  Frame f = two_planes(w, h, 1.0f, 30.0f);
  f.lens.f_number = 1.0;
  const post::CocLens c(f.lens, w, 16);
  // Depths of a given gather radius in front of the focus plane: r = 0.5 k (s - z) / z.
  const auto depth_of_radius = [&](double r) {
    return float(f.lens.focus_distance / (1.0 + 2.0 * r / c.k));
  };
  int uniform = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int v = (x * 7 + y * 13) % 41;
      float z;
      if (x < 70)
        z = depth_of_radius(20.0 + 0.1 * v);  // every radius at the clamp: uniform tiles
      else if (x < 110)
        z = depth_of_radius(10.0 + 0.15 * v);  // 10 .. 16 px: wide tiles
      else
        z = (y / 8) % 2 ? 0.8f + 0.05f * float(v) : 3.0f + 0.5f * float(v);  // near / far
      uniform += x < 70 && post::gather_radius(z, c) == 16.0f;
      f.depth.at(x, y, 0) = z;
      f.color.at(x, y, 1) = float((x * x + 3 * y) % 17) / 4.0f;
    }
  ASSERT_EQ(uniform, 70 * h);
  expect_plain_gather_bits(f, plain_gather(f));
}

// coc=ranges (artist near / far ranges): range_radius on hand values, and the gather over its
// radii equals the plain gather bit for bit in every depth class (the classes rest on the
// radius being monotone on each side, CocRanges).
post::DofSettings ranges_settings() {
  post::DofSettings s;
  s.coc = post::DofCoc::ranges;
  s.near_start = 1.0f;
  s.near_end = 3.0f;
  s.far_start = 5.0f;
  s.far_end = 9.0f;
  s.near_radius = 6.0f;
  s.far_radius = 10.0f;
  return s;
}

TEST(PostDof, ArtistRangesGiveTheRadiusOfEachDepth) {
  post::DofSettings s = ranges_settings();
  const post::CocRanges c(s);
  EXPECT_EQ(post::range_radius(0.5f, c), 6.0f);  // nearer than near_start
  EXPECT_EQ(post::range_radius(2.0f, c), 3.0f);  // half way down the near ramp
  EXPECT_EQ(post::range_radius(3.0f, c), 0.0f);
  EXPECT_EQ(post::range_radius(4.0f, c), 0.0f);  // between the ranges: in focus
  EXPECT_EQ(post::range_radius(7.0f, c), 5.0f);  // half way up the far ramp
  EXPECT_EQ(post::range_radius(9.0f, c), 10.0f);
  EXPECT_EQ(post::range_radius(1e10f, c), 10.0f);  // background
  EXPECT_EQ(post::range_radius(NAN, c), 0.0f);
  s.far_radius = 30.0f;
  EXPECT_EQ(post::range_radius(20.0f, post::CocRanges(s)), 16.0f);  // max_radius clamp
  EXPECT_DOUBLE_EQ(post::SignedCoc(s, {})(2.0, 100), -6.0);
  EXPECT_DOUBLE_EQ(post::SignedCoc(s, {})(20.0, 100), 60.0);  // not clamped
  s.near_end = 6.0f;                                          // past far_start
  EXPECT_THROW(s.validate(), SettingsError);
  EXPECT_THROW(s.set_assignment("coc=artist"), SettingsError);
}

TEST(PostDof, ArtistRangesGatherIsThePlainGatherInEveryDepthClass) {
  const int w = 203, h = 77;
  Frame f = two_planes(w, h, 1.0f, 30.0f);
  f.lens.f_number = 0.0;  // no lens: the ranges need none
  const float odd[] = {0.0f, -1.0f, INFINITY, NAN, 3.0f, 5.0f, 1e30f, 2.9999998f, 5.0000005f};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int v = (x * 7 + y * 13) % 41;
      float z = x < 64    ? 0.4f + 0.112f * float(v)  // near class: 0.4 .. 4.9
                : x < 128 ? 3.0f + 0.4f * float(v)    // far class: 3 .. 19
                          : 0.5f + 0.3f * float(v);   // both sides
      if (x >= 150 && (x + y) % 23 == 0) z = odd[size_t(x + y) % 9];
      f.depth.at(x, y, 0) = z;
      f.color.at(x, y, 1) = float((x * x + 3 * y) % 17) / 4.0f;
    }
  const post::DofSettings s = ranges_settings();
  const ImageF expected = plain_gather(f, s);
  EXPECT_NE(expected, f.color);
  expect_plain_gather_bits(f, expected, s);
  // The diffusion mode takes the same radii (it blurs, where the lens mode sees a pinhole).
  post::DofSettings diffusion = s;
  diffusion.mode = post::DofMode::diffusion;
  EXPECT_NE(post::depth_of_field(f, f.color, diffusion), f.color);
  EXPECT_EQ(post::depth_of_field(f, f.color, {}), f.color);
}

// A polygonal bokeh (the lens's blades): the gather equals the plain gather with the bokeh's
// distance bit for bit in every depth class, for odd (front and back differ) and even blade
// counts, also through the uniform and inner shortcuts.
TEST(PostDof, PolygonBokehGatherIsThePlainGather) {
  const int w = 203, h = 77;
  Frame f = two_planes(w, h, 1.0f, 30.0f);
  f.lens.f_number = 1.0;
  const post::CocLens c(f.lens, w, 16);
  const auto depth_of_radius = [&](double r) {  // in front of the focus plane
    return float(f.lens.focus_distance / (1.0 + 2.0 * r / c.k));
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int v = (x * 7 + y * 13) % 41;
      float z = x < 48    ? depth_of_radius(20.0 + 0.1 * v)  // clamped: uniform tiles
                : x < 96  ? 0.4f + 0.064f * float(v)         // in front
                : x < 150 ? 3.0f + 0.9f * float(v)           // behind
                          : 0.8f + 0.35f * float(v);         // both sides
      f.depth.at(x, y, 0) = z;
      f.color.at(x, y, 1) = float((x * x + 3 * y) % 17) / 4.0f;
    }
  for (const int blades : {5, 6}) {
    f.lens.blades = blades;
    f.lens.blade_rotation_deg = 20.0;
    const ImageF expected = plain_gather(f);
    expect_plain_gather_bits(f, expected);
    f.lens.blades = 0;
    EXPECT_NE(expected, plain_gather(f)) << blades;  // the shape changes the result
  }
}

// bokeh_distance on hand values: a pentagon with a vertex straight up (rotation 90 degrees,
// view y up, image y down): behind the focus plane p - q = (0, 8) up in the image reaches the
// vertex (gauge 8); straight down it meets an edge at the apothem cos 36 deg (8 / cos 36 deg);
// in front the two swap; a disc and an even polygon's opposite offsets agree.
TEST(PostDof, BokehDistanceIsThePolygonsGauge) {
  const post::Bokeh pentagon{5, 0.5 * kPi};
  const double apothem = std::cos(kPi / 5);
  // tap (dx, dy) = q - p: p above q is the tap (0, +8).
  EXPECT_NEAR(post::bokeh_distance(pentagon, 0, 8, false), 8.0, 1e-5);
  EXPECT_NEAR(post::bokeh_distance(pentagon, 0, -8, false), 8.0 / apothem, 1e-5);
  EXPECT_NEAR(post::bokeh_distance(pentagon, 0, 8, true), 8.0 / apothem, 1e-5);
  EXPECT_NEAR(post::bokeh_distance(pentagon, 0, -8, true), 8.0, 1e-5);
  EXPECT_EQ(post::bokeh_distance({}, 3, 4, false), 5.0f);
  const post::Bokeh hexagon{6, 0.0};  // vertices on the x axis, edges facing up and down
  EXPECT_NEAR(post::bokeh_distance(hexagon, 7, 0, false), 7.0, 1e-5);
  EXPECT_NEAR(post::bokeh_distance(hexagon, 0, 7, false), 7.0 / std::cos(kPi / 6), 1e-5);
  EXPECT_EQ(post::bokeh_distance(hexagon, 2, 5, false), post::bokeh_distance(hexagon, 2, 5, true));
  EXPECT_GE(post::bokeh_distance(pentagon, 1, 0, false), 1.0f);  // never below Euclidean
}

// The bokeh's orientation: one bright pixel on a plane behind the focus plane spreads over the
// aperture polygon as camera/aperture.h places it (a vertex at blade_rotation counter-clockwise
// from +x, y up: here straight up in the image), in front of it over the point-reflected
// polygon (as the thin-lens ray tracer images them, renderer.cpp thin_lens_ray).
TEST(PostDof, PolygonBokehIsTheApertureBehindAndReflectedInFront) {
  const int n = 61, c = 30;
  for (const bool behind : {true, false}) {
    Frame f = two_planes(n, n, 1.0f, 1.0f);
    f.lens.f_number = 1.0;
    f.lens.focal_length_mm = 200.0;  // a far field up to 12 px at this width
    f.lens.blades = 5;
    f.lens.blade_rotation_deg = 90.0;
    const post::CocLens coc(f.lens, n, 16);
    // radius 9 px: r = 0.5 k |z - s| / z
    const double s = f.lens.focus_distance, r = 9.0;
    const float z = float(behind ? s / (1.0 - 2.0 * r / coc.k) : s / (1.0 + 2.0 * r / coc.k));
    ASSERT_GT(z, 0.0f);
    ASSERT_NEAR(post::gather_radius(z, coc), 9.0f, 1e-3f);
    for (float& v : f.depth.data()) v = z;
    for (float& v : f.color.data()) v = 0.0f;
    f.color.at(c, c, 0) = 1000.0f;
    post::DofSettings dense;  // every pixel of the 9 px disc a tap
    dense.taps = 1024;
    const ImageF out = post::depth_of_field(f, f.color, dense);
    // Lit within the apex of the aperture's upward vertex (view +y = image up), dark there in
    // the reflection; the reverse toward the downward edge's far side.
    const float up = out.at(c, c - 8, 0), down = out.at(c, c + 8, 0);
    if (behind) {
      EXPECT_GT(up, 0.0f);
      EXPECT_EQ(down, 0.0f);
    } else {
      EXPECT_EQ(up, 0.0f);
      EXPECT_GT(down, 0.0f);
    }
  }
}

// coc=lens with the lens given by settings: a frame without one (f-number 0, as Blender's
// files) blurs as a frame carrying that lens.
TEST(PostDof, LensSettingsReplaceTheFramesLens) {
  Frame carried = two_planes(96, 40, 1.0f, 10.0f);
  Frame bare = carried;
  bare.lens = ThinLens{};  // pinhole, 50 mm, focus 5, 36 mm sensor
  carried.lens.focal_length_mm = 35.0;
  carried.lens.sensor_width_mm = 24.0;
  post::DofSettings s;
  s.f_number = float(carried.lens.f_number);
  s.focal_length = 35.0f;
  s.focus_distance = float(carried.lens.focus_distance);
  s.sensor_width = 24.0f;
  const ImageF out = post::depth_of_field(bare, bare.color, s);
  EXPECT_NE(out, bare.color);
  EXPECT_EQ(out, post::depth_of_field(carried, carried.color, {}));
  EXPECT_EQ(post::dof_lens(bare.lens, s), carried.lens);
  s.focus_distance = 0.01f;  // nearer than the focal length
  EXPECT_THROW(post::depth_of_field(bare, bare.color, s), InputError);
}

// Half resolution (dof.resolution=half): every blurred tile through the half-resolution layers
// (half_from=0) and the default split by neighbourhood radius.
post::DofSettings half_res(float from) {
  post::DofSettings s;
  s.resolution = post::DofResolution::half;
  s.half_from = from;
  return s;
}

TEST(PostDof, HalfResolutionBlendAndRadius) {
  // The blend is 0 in the focus field and 1 from r = 2 (the resampling's variance, 1 px^2,
  // equals the disc's r^2 / 4 there); the half-resolution radius adds the rest of the variance.
  EXPECT_EQ(post::half_res_blend(0.0f), 0.0f);
  EXPECT_EQ(post::half_res_blend(0.5f), 0.0f);
  EXPECT_NEAR(post::half_res_blend(1.0f), 0.75f / 3.75f, 1e-6f);
  EXPECT_EQ(post::half_res_blend(2.0f), 1.0f);
  EXPECT_EQ(post::half_res_blend(9.0f), 1.0f);
  EXPECT_EQ(post::half_res_radius(2.0f), 0.0f);
  EXPECT_NEAR(post::half_res_radius(10.0f), 0.5f * std::sqrt(96.0f), 1e-5f);
  post::DofSettings s;
  s.set_assignment("resolution=half");
  EXPECT_EQ(s.resolution, post::DofResolution::half);
  EXPECT_THROW(s.set_assignment("resolution=quarter"), SettingsError);
}

TEST(PostDof, HalfResolutionKeepsTheFocusFieldAndTheDepthOrder) {
  for (const float from : {0.0f, 4.0f}) {
    const post::DofSettings s = half_res(from);
    Frame g = two_planes(96, 24, 3.0f, 3.0f);  // everything on the focus plane
    EXPECT_EQ(post::depth_of_field(g, g.color, s), g.color);
    const int w = 320, h = 32;
    const int r = int(std::ceil(0.5 * std::abs(circle_of_confusion_px(lens(), 1.0, w))));
    {  // near red plane over in-focus stripes: red spreads; beyond its disc (and the two
       // pixels of the resampling) the stripes are exactly as they were
      const Frame f = two_planes(w, h, 1.0f, 3.0f);
      const ImageF out = post::depth_of_field(f, f.color, s);
      EXPECT_GT(out.at(w / 2 + 1, 16, 0) - out.at(w / 2 + 1, 16, 1), 0.1f) << from;
      for (int x = w / 2 + r + 4; x < w; ++x)
        for (int y = 0; y < h; ++y)
          ASSERT_EQ(out.at(x, y, 1), f.color.at(x, y, 1)) << from << " " << x << " " << y;
    }
    {  // in-focus red plane before far stripes: the red plane stays exactly red, the stripes
       // blur
      const Frame f = two_planes(w, h, 3.0f, 30.0f);
      const ImageF out = post::depth_of_field(f, f.color, s);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w / 2; ++x) {
          ASSERT_EQ(out.at(x, y, 0), 1.0f) << from << " " << x << " " << y;
          ASSERT_EQ(out.at(x, y, 1), 0.0f) << from << " " << x << " " << y;
        }
      // (unblurred: 0.2; the resampling of half_from=0 leaves a little more than the gather)
      EXPECT_LT(std::abs(out.at(240, 16, 1) - out.at(243, 16, 1)), 0.15f) << from;
    }
  }
}

// Half resolution beside an in-focus edge: a half pixel whose anchor is the blurred background
// behind the edge holds, in its near layer, what lies in front of that background (here the
// background's own nearer parts, its depth falling to the left), not in front of the sharp
// pixels; upsampled plainly it covered the sharp pixels next to the edge. At every edge phase
// (the 2x2 blocks straddling it or not) the in-focus plane keeps its pixels exactly.
TEST(PostDof, HalfResolutionNearLayerDoesNotCoverASharpEdge) {
  const int w = 320, h = 32;
  for (const float from : {0.0f, 4.0f})
    for (int edge = 160; edge <= 161; ++edge) {
      Frame f = two_planes(w, h, 3.0f, 30.0f);
      f.lens.f_number = 0.5;  // background radii ~7 px
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const bool left = x < edge;
          f.depth.at(x, y, 0) = left ? 3.0f : 20.0f + 0.05f * float(x - edge);
          for (int c = 0; c < 3; ++c)
            f.color.at(x, y, c) =
                left ? (c == 0 ? 1.0f : 0.0f) : 0.2f + 0.2f * float((x / 3 + y / 3) % 2);
        }
      const ImageF out = post::depth_of_field(f, f.color, half_res(from));
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < edge; ++x)
          for (int c = 0; c < 3; ++c)
            ASSERT_EQ(out.at(x, y, c), f.color.at(x, y, c))
                << "half_from " << from << " edge " << edge << " x " << x << " y " << y;
    }
}

// Half resolution: the same bits for any thread count and --simd off (the plain statement,
// dof_reference; post_dof_half_reference_test.cpp compares them more widely), at odd sizes
// (the last half row and column pair with themselves), with the tiles split between the two
// gathers.
TEST(PostDof, HalfResolutionSimdAndThreadsGiveTheSameBits) {
  for (const auto& [w, h] : {std::pair{133, 45}, std::pair{257, 91}}) {
    Frame f = two_planes(w, h, 1.0f, 30.0f);
    f.lens.f_number = 0.7;  // radii up to ~9 px: tiles on both sides of half_from = 4
    for (int y = 0; y < f.height; ++y)
      for (int x = 0; x < f.width; ++x) {
        f.depth.at(x, y, 0) = x < w / 3 ? 3.0f : 0.8f + 0.35f * float((x * 7 + y * 13) % 41);
        f.color.at(x, y, 1) = float((x * x + 3 * y) % 17) / 4.0f;  // HDR values up to 4
      }
    for (const float from : {0.0f, 4.0f}) {
      const post::DofSettings s = half_res(from);
      const ImageF ref = post::depth_of_field(f, f.color, s, Exec{1, false});
      ASSERT_EQ(ref.width(), w);
      ASSERT_EQ(ref.height(), h);
      EXPECT_NE(ref, f.color);
      const ImageF full = post::depth_of_field(f, f.color, {});
      EXPECT_NE(ref, full);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          for (int c = 0; c < 3; ++c) ASSERT_TRUE(std::isfinite(ref.at(x, y, c))) << x << " " << y;
      EXPECT_EQ(post::depth_of_field(f, f.color, s, Exec{1, true}), ref) << w << " " << from;
      EXPECT_EQ(post::depth_of_field(f, f.color, s, Exec{2, true}), ref) << w << " " << from;
      EXPECT_EQ(post::depth_of_field(f, f.color, s, Exec{2, false}), ref) << w << " " << from;
    }
  }
}

// A non-finite color at half resolution reaches the pixels to which it gives a positive weight
// (those whose output changes when a finite value replaces it: 1e30 against 0) and, through
// the 2x2 downsample and the upsample, at most their neighbours 2 px away; not the pixels
// whose taps read it with zero weight. The layers' gather adds its taps unmasked and recomputes
// a block masked where a sum turned NaN (gather_block_layers); without the recompute the
// pixels whose taps read it with zero weight turn NaN.
TEST(PostDof, HalfResolutionNonFiniteColorsStayWithTheirWeightedPixels) {
  const int w = 161, h = 67;
  Frame f = two_planes(w, h, 1.0f, 30.0f);
  f.lens.f_number = 0.7;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.depth.at(x, y, 0) = 0.8f + 0.35f * float((x * 7 + y * 13) % 41);
      f.color.at(x, y, 1) = float((x * x + 3 * y) % 17) / 4.0f;
    }
  const int px = 80, py = 33;
  f.depth.at(px, py, 0) = 3.2f;  // just behind the focus plane: a small disc among large ones
  const auto with = [&](float v) {
    Frame g = f;
    g.color.at(px, py, 1) = v;
    return post::depth_of_field(g, g.color, half_res(0.0f), Exec{2, true});
  };
  const ImageF inf = with(INFINITY), big = with(1e30f), zero = with(0.0f);
  std::vector<uint8_t> weighted(size_t(w) * size_t(h), 0);
  size_t n_weighted = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool wt = big.at(x, y, 1) != zero.at(x, y, 1);
      weighted[size_t(y) * size_t(w) + size_t(x)] = wt;
      n_weighted += wt;
      if (wt) {
        ASSERT_FALSE(std::isfinite(inf.at(x, y, 1))) << x << " " << y;
      }
    }
  const auto near_weighted = [&](int x, int y) {
    for (int v = std::max(0, y - 2); v <= std::min(h - 1, y + 2); ++v)
      for (int u = std::max(0, x - 2); u <= std::min(w - 1, x + 2); ++u)
        if (weighted[size_t(v) * size_t(w) + size_t(u)]) return true;
    return false;
  };
  size_t finite_near = 0;  // within the taps' reach of the infinity, finite
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool finite = std::isfinite(inf.at(x, y, 1));
      if (!finite) {
        ASSERT_TRUE(near_weighted(x, y)) << x << " " << y;
      }
      finite_near += finite && std::abs(x - px) <= 12 && std::abs(y - py) <= 12;
    }
  EXPECT_GT(n_weighted, 0u);
  EXPECT_GT(finite_near, 20u);
}

double display_flip(const ImageF& reference, const ImageF& test) {
  const metrics::DisplaySettings ds;
  return metrics::ldr_flip(metrics::to_tonemapped_linear(reference, ds),
                           metrics::to_tonemapped_linear(test, ds))
      .mean;
}

// Frame 0 of a built-in scene at 320x180, 16 spp: the pinhole image (its frame carries the
// scene's lens) and the thin-lens reference.
std::pair<Frame, Frame> pinhole_and_thin_lens(const std::string& scene) {
  render::RenderSettings rs;
  rs.width = 320;
  rs.height = 180;
  const render::Scene sc = render::make_builtin_scene(scene);  // outlives the renderer
  render::SceneRenderer r(sc, rs, Exec{});
  Frame pinhole = r.reference(0, 16);
  render::CameraEffects fx;
  fx.depth_of_field = true;
  r.set_effects(fx);
  return {std::move(pinhole), r.reference(0, 16)};
}

TEST(PostDof, CloserToTheThinLensReferenceThanThePinholeImage) {
  const auto [pinhole, truth] = pinhole_and_thin_lens("focus");
  ASSERT_GT(pinhole.lens.f_number, 0.0);
  const ImageF out = post::depth_of_field(pinhole, pinhole.color, {});
  const double flip_none = display_flip(truth.color, pinhole.color),
               flip_dof = display_flip(truth.color, out);
  const double psnr_none = test::display_psnr(truth.color, pinhole.color),
               psnr_dof = test::display_psnr(truth.color, out);
  // Measured: pinhole FLIP 0.0683, PSNR 29.52 dB; dof FLIP 0.0233, PSNR 39.07 dB.
  std::printf("focus 320x180, 16 spp: pinhole FLIP %.4f PSNR %.2f dB; dof FLIP %.4f PSNR %.2f dB\n",
              flip_none, psnr_none, flip_dof, psnr_dof);
  EXPECT_LT(flip_dof, 0.8 * flip_none);
  EXPECT_GT(psnr_dof, psnr_none + 2.0);
  // Half resolution: the default split (tiles of neighbourhood radius >= 4 px at half
  // resolution) and every blurred tile at half resolution (half_from=0), whose resampling
  // cannot render the small blurs of this size (radii 2-4 px) as well.
  for (const float from : {4.0f, 0.0f}) {
    const ImageF o = post::depth_of_field(pinhole, pinhole.color, half_res(from));
    const double flip_h = display_flip(truth.color, o), psnr_h = test::display_psnr(truth.color, o);
    // Measured: half_from 4: FLIP 0.0242, PSNR 38.70 dB; half_from 0: 0.0352, 37.25 dB.
    std::printf("  half resolution, half_from %.0f: FLIP %.4f PSNR %.2f dB\n", from, flip_h,
                psnr_h);
    if (from > 0.0f) {
      EXPECT_LT(flip_h, flip_dof + 0.002);
      EXPECT_GT(psnr_h, psnr_dof - 1.0);
    } else {
      EXPECT_LT(flip_h, 0.9 * flip_none);
      EXPECT_GT(psnr_h, psnr_none + 4.0);
    }
  }
  // The diffusion mode (Kass et al. 2006), default steps; the single step of the paper.
  for (const int steps : {4, 1}) {
    post::DofSettings d;
    d.mode = post::DofMode::diffusion;
    d.diffusion_steps = steps;
    const ImageF o = post::depth_of_field(pinhole, pinhole.color, d);
    const double flip_d = display_flip(truth.color, o), psnr_d = test::display_psnr(truth.color, o);
    // Measured: 4 steps FLIP 0.0242, PSNR 38.22 dB; 1 step 0.0279, 37.16 dB (the gather's
    // 0.0233 / 39.07 dB stays ahead).
    std::printf("  diffusion, %d step(s): FLIP %.4f PSNR %.2f dB\n", steps, flip_d, psnr_d);
    EXPECT_LT(flip_d, 0.5 * flip_none) << steps;
    EXPECT_GT(psnr_d, psnr_none + 6.0) << steps;
  }
}

// The bladed lens (scene `bokeh`, five blades): the gather takes the frame's polygon by
// default and is closer to the bladed thin-lens reference than the disc gather, which is
// closer than the pinhole image.
TEST(PostDof, BladedLensPolygonBeatsTheDiscAgainstTheBladedReference) {
  const auto [pinhole, truth] = pinhole_and_thin_lens("bokeh");
  ASSERT_EQ(pinhole.lens.blades, 5);
  post::DofSettings disc;
  disc.blades = 0;
  const ImageF polygon_out = post::depth_of_field(pinhole, pinhole.color, {}),
               disc_out = post::depth_of_field(pinhole, pinhole.color, disc);
  const double flip_none = display_flip(truth.color, pinhole.color),
               flip_polygon = display_flip(truth.color, polygon_out),
               flip_disc = display_flip(truth.color, disc_out);
  // Measured: pinhole 0.0951, polygon 0.0395, disc 0.0487.
  std::printf("bokeh 320x180, 16 spp: pinhole FLIP %.4f, polygon %.4f, disc %.4f\n", flip_none,
              flip_polygon, flip_disc);
  EXPECT_LT(flip_polygon, 0.85 * flip_disc);
  EXPECT_LT(flip_disc, 0.7 * flip_none);
}

}  // namespace
}  // namespace afterimage
