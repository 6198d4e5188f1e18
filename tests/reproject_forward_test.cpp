// Forward reprojection (reproject/forward.h) and frame extrapolation (run/extrapolate.h),
// issue 13: exactness of the splat on a case with a known answer, the hole mask and the depth
// test as properties, and the measurement that picks the default hole fill.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "reproject/forward.h"
#include "run/extrapolate.h"

using namespace afterimage;
using reproject::DisplacementKind;
using reproject::ForwardSplat;
using reproject::HoleFill;

namespace {

constexpr double kDeg = kPi / 180.0;

// A checker plane facing the camera at depth 9 under a sun, seen through a 90 degree vertical
// field of view at 64x36: one pixel is 0.5 units on the plane, and the camera translates
// parallel to it by 1 unit (2 pixels) per frame to the right. Checker cells are 2 units, with
// edges on pixel edges, so every sample lies 0.25 units inside a cell and a flat, unshadowed,
// Lambert-only surface gives each cell one exact color.
render::Scene translating_plane_scene() {
  render::Scene sc;
  sc.name = "translating plane";
  sc.camera.vfov_degrees = 90.0;
  sc.fps = 1.0;
  const int plane = sc.add_mesh(render::make_plane(64.0, 64.0));
  render::Material m;
  m.texture = render::Texture::Checker;
  m.frequency = 32.0;
  m.albedo = {0.8f, 0.6f, 0.3f};
  m.albedo2 = {0.1f, 0.2f, 0.5f};
  render::Transform xf;
  xf.translation = {0, 0, -9};
  xf.rotation = Quat::from_axis_angle({1, 0, 0}, 90 * kDeg);
  sc.add_object("plane", plane, m, render::Animation::fixed(xf));
  render::Light sun;
  sun.type = render::LightType::Directional;
  sun.position = normalize(Vec3d{0.3, 0.4, 1.0});
  sun.color = {2.0f, 1.9f, 1.8f};
  sc.lights.push_back(sun);
  sc.camera_motion.keys = {render::camera_keyframe(0.0, {0, 0, 0}, {0, 0, -9}),
                           render::camera_keyframe(8.0, {8, 0, 0}, {8, 0, -9})};
  return sc;
}

render::RenderSettings small_settings(int w, int h, const std::string& jitter) {
  render::RenderSettings rs;
  rs.width = w;
  rs.height = h;
  rs.jitter = parse_jitter(jitter);
  rs.motion_next = true;
  return rs;
}

std::vector<Frame> render_frames(const render::Scene& sc, int count,
                                 const render::RenderSettings& rs) {
  render::SceneRenderer r(sc, rs, Exec{});
  std::vector<Frame> frames;
  for (int k = 0; k < count; ++k) frames.push_back(r.gbuffer(k));
  return frames;
}

ForwardSplat splat(const Frame& src, const FrameHeader& dst, DisplacementKind kind) {
  ForwardSplat s = ForwardSplat::empty(dst.width, dst.height);
  reproject::splat_frame(src, reproject::displacement_field(src, dst, kind), dst.jitter, s);
  return s;
}

// Display-space error of one pixel: mean over channels of |r(a) - r(b)|, r(x) = x / (1 + x)
// (the metrics' Reinhard), so that HDR highlights do not dominate the means.
double pixel_error(const ImageF& a, const ImageF& b, int x, int y) {
  double e = 0;
  for (int c = 0; c < 3; ++c) {
    const double u = std::max(0.0f, a.at(x, y, c)), v = std::max(0.0f, b.at(x, y, c));
    e += std::abs(u / (1 + u) - v / (1 + v));
  }
  return e / 3;
}

struct Errors {
  double holes_sum = 0, all_sum = 0;
  size_t holes = 0, all = 0;
  void add(const ImageF& out, const ImageF& truth, const Image<uint8_t>& hole) {
    for (int y = 0; y < out.height(); ++y)
      for (int x = 0; x < out.width(); ++x) {
        const double e = pixel_error(out, truth, x, y);
        all_sum += e;
        ++all;
        if (hole.at(x, y, 0)) holes_sum += e, ++holes;
      }
  }
  double hole_mean() const { return holes ? holes_sum / double(holes) : 0.0; }
  double mean() const { return all ? all_sum / double(all) : 0.0; }
};

}  // namespace

TEST(ForwardSplatTest, TargetPositionFollowsJitterConvention) {
  // Sample of pixel 3 at 3.5 + 0.25, moved by 2.0, read by a target jittered by -0.4:
  // 5.75 + 0.4 = 6.15 -> pixel 6. Off-screen and non-finite land nowhere.
  auto q = reproject::splat_target_position(3, 1, {0.25, 0.0}, {2.0, -1.0}, {-0.4, 0.3}, 10, 4);
  ASSERT_TRUE(q);
  EXPECT_EQ(q->x, 6);
  EXPECT_EQ(q->y, 0);  // 1.5 - 1.0 - 0.3 = 0.2
  EXPECT_FALSE(reproject::splat_target_position(0, 0, {0, 0}, {-0.6, 0}, {0, 0}, 10, 4));
  EXPECT_FALSE(reproject::splat_target_position(9, 0, {0, 0}, {0.5, 0}, {0, 0}, 10, 4));
  EXPECT_FALSE(reproject::splat_target_position(1, 1, {0, 0}, {NAN, 0}, {0, 0}, 10, 4));
}

// Issue 13 test 1: a camera translating parallel to a textured plane by 2 pixels per frame;
// the splat of frame 0 into frame 1 is frame 1 exactly (bit for bit) outside the holes, and
// the holes are the two columns entering on the right.
TEST(ForwardSplatTest, CameraTranslationOverPlaneReproducesRenderedFrame) {
  const render::Scene sc = translating_plane_scene();
  const std::vector<Frame> f = render_frames(sc, 2, small_settings(64, 36, "none"));
  for (DisplacementKind kind : {DisplacementKind::camera, DisplacementKind::motion_next}) {
    SCOPED_TRACE(reproject::displacement_kind_name(kind));
    const ForwardSplat s = splat(f[0], f[1], kind);
    size_t holes = 0;
    for (int y = 0; y < 36; ++y)
      for (int x = 0; x < 64; ++x) {
        const bool hole = s.hole.at(x, y, 0);
        EXPECT_EQ(hole, x >= 62) << x << "," << y;
        holes += hole;
        if (hole) continue;
        for (int c = 0; c < 3; ++c)
          ASSERT_EQ(s.color.at(x, y, c), f[1].color.at(x, y, c)) << x << "," << y << "," << c;
        EXPECT_NEAR(s.depth.at(x, y, 0), 9.0f, 1e-4f);
        EXPECT_EQ(s.sources.at(x, y, 0), 1u);
      }
    EXPECT_EQ(holes, 2u * 36u);
    // The scene is not trivially uniform: both checker colors occur.
    EXPECT_NE(f[1].color.at(0, 0, 0), f[1].color.at(4, 0, 0));
  }
}

// Issue 13 test 2: the hole mask is exactly the set of target pixels that no source sample
// lands in, computed here from the displacement field with the jitter convention.
TEST(ForwardSplatTest, HoleMaskIsExactlyTheUnreachedPixels) {
  const render::Scene sc = render::make_builtin_scene("motion");
  const std::vector<Frame> f = render_frames(sc, 4, small_settings(96, 54, "halton16"));
  struct Case {
    int src, dst;
    DisplacementKind kind;
  };
  for (const Case& c :
       {Case{0, 1, DisplacementKind::motion_next}, Case{0, 3, DisplacementKind::camera},
        Case{3, 2, DisplacementKind::motion}, Case{3, 0, DisplacementKind::camera}}) {
    SCOPED_TRACE(
        fmt::format("{} -> {} {}", c.src, c.dst, reproject::displacement_kind_name(c.kind)));
    const Frame& src = f[size_t(c.src)];
    const Frame& dst = f[size_t(c.dst)];
    const auto field = reproject::displacement_field(src, dst, c.kind);
    ForwardSplat s = ForwardSplat::empty(96, 54);
    reproject::splat_frame(src, field, dst.jitter, s);
    std::vector<int> count(96 * 54, 0);
    for (int y = 0; y < 54; ++y)
      for (int x = 0; x < 96; ++x) {
        const double dx = field.displacement.at(x, y, 0), dy = field.displacement.at(x, y, 1);
        if (!std::isfinite(dx) || !std::isfinite(dy)) continue;
        const double tx = std::floor(x + 0.5 + src.jitter.x + dx - dst.jitter.x);
        const double ty = std::floor(y + 0.5 + src.jitter.y + dy - dst.jitter.y);
        if (tx >= 0 && tx < 96 && ty >= 0 && ty < 54) ++count[size_t(ty) * 96 + size_t(tx)];
      }
    size_t holes = 0;
    for (int y = 0; y < 54; ++y)
      for (int x = 0; x < 96; ++x) {
        const int n = count[size_t(y) * 96 + size_t(x)];
        ASSERT_EQ(s.hole.at(x, y, 0), n == 0 ? 1 : 0) << x << "," << y;
        ASSERT_EQ(s.sources.at(x, y, 0), uint32_t(n)) << x << "," << y;
        holes += n == 0;
      }
    EXPECT_EQ(holes, s.hole_count());
    if (c.dst == 3 || c.dst == 0) {
      EXPECT_GT(holes, 0u);  // three frames apart: disocclusions
    }
  }
}

// Issue 13 test 3: where two samples land on one pixel the nearer one wins, whichever is
// splatted first; through displacement_field with a motion_next channel (identity cameras:
// the target depth is the source depth).
TEST(ForwardSplatTest, NearerSampleWinsTheDepthTest) {
  Frame src = Frame::allocate(6, 1);
  src.allocate_channel(Channel::motion_next);
  const float depth[6] = {5.0f, 2.0f, 1.0f, 3.0f, 4.0f, kBackgroundDepth};
  const float move[6] = {3.0f, 2.0f, -2.0f, -3.0f, 1.0f, -4.0f};
  for (int x = 0; x < 6; ++x) {
    src.depth.at(x, 0, 0) = depth[x];
    src.motion_next.at(x, 0, 0) = move[x];
    for (int c = 0; c < 3; ++c) src.color.at(x, 0, c) = float(10 * x + c);
  }
  // Lands: 0 -> 3 (d 5), 1 -> 3 (d 2, later, nearer), 2 -> 0 (d 1, first, nearer),
  // 3 -> 0 (d 3), 4 -> 5 (d 4), 5 -> 1 (sky).
  const ForwardSplat s = splat(src, src, DisplacementKind::motion_next);
  EXPECT_EQ(s.color.at(3, 0, 0), 10.0f);  // pixel 1
  EXPECT_EQ(s.depth.at(3, 0, 0), 2.0f);
  EXPECT_EQ(s.color.at(0, 0, 0), 20.0f);  // pixel 2
  EXPECT_EQ(s.depth.at(0, 0, 0), 1.0f);
  EXPECT_EQ(s.color.at(5, 0, 1), 41.0f);
  EXPECT_EQ(s.color.at(1, 0, 2), 52.0f);
  EXPECT_EQ(s.depth.at(1, 0, 0), kBackgroundDepth);
  EXPECT_EQ(s.sources.at(3, 0, 0), 2u);
  EXPECT_EQ(s.sources.at(0, 0, 0), 2u);
  for (int x : {2, 4}) EXPECT_EQ(s.hole.at(x, 0, 0), 1) << x;
  EXPECT_EQ(s.hole_count(), 2u);
  // Two frames splatted into one target: the nearer sample wins across frames too.
  Frame near = src;
  for (int x = 0; x < 6; ++x) near.depth.at(x, 0, 0) = 0.5f, near.color.at(x, 0, 0) = -1.0f;
  ForwardSplat both = splat(src, src, DisplacementKind::motion_next);
  reproject::splat_frame(near,
                         reproject::displacement_field(near, src, DisplacementKind::motion_next),
                         src.jitter, both);
  EXPECT_EQ(both.color.at(3, 0, 0), -1.0f);
  EXPECT_EQ(both.sources.at(3, 0, 0), 4u);
}

// A surface stretched to twice its size (source sample x lands at 2x + 1, so the target's
// even pixels are holes inside warped quads): a hole pixel takes the color of the quad corner
// that landed nearest, clamped to the range of the other three corners, so that a
// single-sample glint or firefly (50 among 0.2) is not copied into the pixels around it.
TEST(ForwardSplatTest, StretchedQuadClampsAnIsolatedCornerToItsNeighbours) {
  constexpr int kN = 8;
  Frame src = Frame::allocate(kN, kN);
  for (int y = 0; y < kN; ++y)
    for (int x = 0; x < kN; ++x) {
      src.depth.at(x, y, 0) = 5.0f;
      for (int c = 0; c < 3; ++c) src.color.at(x, y, c) = 0.2f;
    }
  for (int c = 0; c < 3; ++c) {
    src.color.at(2, 2, c) = 50.0f;  // the firefly
    src.color.at(1, 2, c) = 0.4f;
    src.color.at(2, 1, c) = 0.0f;
  }
  reproject::DisplacementField field{ImageF(kN, kN, 2, 0.0f), ImageF(kN, kN, 1, 5.0f)};
  for (int y = 0; y < kN; ++y)
    for (int x = 0; x < kN; ++x) {
      field.displacement.at(x, y, 0) = float(x + 0.5);
      field.displacement.at(x, y, 1) = float(y + 0.5);
    }
  ForwardSplat s = ForwardSplat::empty(kN, kN);
  reproject::splat_frame(src, field, {0, 0}, s);
  for (int y = 0; y < kN; ++y)
    for (int x = 0; x < kN; ++x)
      ASSERT_EQ(s.hole.at(x, y, 0), uint8_t(x % 2 == 0 || y % 2 == 0)) << x;
  // (4, 4): the nearest corner is the firefly (landed at (5, 5)); the others are 0.2, 0.0
  // and 0.4 -> 0.4. (6, 6): all four corners equidistant, the first, (2, 2), is the firefly;
  // the others are all 0.2 -> 0.2. (2, 2): a quad of 0.2 only.
  const ImageF filled = reproject::fill_holes_background(s);
  for (const auto& [x, y, expect] : {std::tuple{4, 4, 0.4f}, {6, 6, 0.2f}, {2, 2, 0.2f}}) {
    ASSERT_EQ(s.stretch_valid.at(x, y, 0), 1) << x;
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(s.stretch_color.at(x, y, c), expect) << x;
      EXPECT_EQ(filled.at(x, y, c), expect) << x;
    }
  }
}

TEST(ForwardSplatTest, FillsKeepSamplesAndFillEveryHole) {
  const render::Scene sc = render::make_builtin_scene("motion");
  const std::vector<Frame> f = render_frames(sc, 4, small_settings(96, 54, "halton16"));
  const ForwardSplat s = splat(f[0], f[3], DisplacementKind::camera);
  ASSERT_GT(s.hole_count(), 0u);
  for (const auto& info : reproject::hole_fills()) {
    SCOPED_TRACE(info.name);
    const ImageF one = reproject::fill_holes(s, {info.fill}, Exec{1, true});
    const ImageF two = reproject::fill_holes(s, {info.fill}, Exec{2, true});
    EXPECT_TRUE(one == two);  // any thread count
    for (int y = 0; y < 54; ++y)
      for (int x = 0; x < 96; ++x)
        for (int c = 0; c < 3; ++c) {
          if (!s.hole.at(x, y, 0)) {
            ASSERT_EQ(one.at(x, y, c), s.color.at(x, y, c));
          }
          ASSERT_TRUE(std::isfinite(one.at(x, y, c)));
        }
  }
  // The naive fill is what it says: the nearest sample along the row, ties to the left.
  ForwardSplat row = ForwardSplat::empty(7, 2);
  for (int x : {1, 5}) {
    row.hole.at(x, 0, 0) = 0;
    row.color.at(x, 0, 0) = float(x);
  }
  const ImageF n = reproject::fill_holes_naive(row);
  const float expect[7] = {1, 1, 1, 1, 5, 5, 5};  // pixel 3: equidistant, left wins
  for (int x = 0; x < 7; ++x) {
    EXPECT_EQ(n.at(x, 0, 0), expect[x]) << x;
    EXPECT_EQ(n.at(x, 1, 0), expect[x]) << x;  // an empty row copies the nearest filled row
  }
}

// Issue 13 test 4: every moving built-in scene with Halton jitter, `count` frames after
// frame `base` synthesised from frame `base` (the first through motion_next, the others
// through the cameras: the holes grow with the distance) with each fill, against the truly
// rendered frames; display-space mean absolute error over the hole pixels and over the whole
// image. The default fill must beat the naive fill on every scene, over the holes and over
// the image, and have the lowest mean over the scenes of every fill.
namespace {

void compare_fills(int width, int height, int base, int count) {
  const Exec ex;
  std::map<HoleFill, double> hole_sum, all_sum;
  int scenes = 0, large = 0;
  std::string table = fmt::format("{:<8} {:>6} {:>6}", "scene", "holes%", "|mv|");
  for (const auto& info : reproject::hole_fills())
    table += fmt::format(" | {:>19}", fmt::format("{} hole/all", info.name));
  table += "\n";
  for (const std::string& name : render::builtin_scene_names()) {
    const render::Scene sc = render::make_builtin_scene(name);
    render::SceneRenderer renderer(sc, small_settings(width, height, "halton16"), Exec{});
    std::vector<Frame> f;
    for (int k = base; k <= base + count; ++k) f.push_back(renderer.gbuffer(k));
    // Extrapolation within frame `base`'s shot only: across a camera cut nothing is
    // reprojectable.
    for (size_t k = 1; k < f.size(); ++k)
      if (f[k].camera_cut) {
        f.resize(k);
        break;
      }
    const size_t frames = f.size();
    double max_motion = 0;
    for (const Frame& fr : f)
      for (float v : fr.motion_next.data()) max_motion = std::max(max_motion, double(std::abs(v)));
    ExtrapolateSettings st;
    st.skip = int(frames) - 1;
    std::vector<ForwardSplat> splats(frames);
    size_t holes = 0;
    for (size_t k = 1; k < frames; ++k) {
      SynthesisReport r;
      synthesize_frame(SourceFrame{&f[0], 0, true}, nullptr, f[k], k, st, ex, &r, &splats[k]);
      EXPECT_EQ(r.kind_a, k == 1 ? DisplacementKind::motion_next : DisplacementKind::camera);
      holes += splats[k].hole_count();
    }
    if (max_motion == 0 || holes == 0) {  // a still scene: nothing to fill
      fmt::print("{}: skipped (max |motion_next| {}, {} holes)\n", name, max_motion, holes);
      continue;
    }
    ++scenes;
    table += fmt::format("{:<8} {:>6.2f} {:>6.2f}", name,
                         100.0 * double(holes) / (double(frames - 1) * width * height), max_motion);
    std::map<HoleFill, Errors> err;
    for (const auto& info : reproject::hole_fills()) {
      for (size_t k = 1; k < frames; ++k)
        err[info.fill].add(reproject::fill_holes(splats[k], {info.fill}, ex), f[k].color,
                           splats[k].hole);
      hole_sum[info.fill] += err[info.fill].hole_mean();
      all_sum[info.fill] += err[info.fill].mean();
      table +=
          fmt::format(" | {:>9.5f}/{:>9.5f}", err[info.fill].hole_mean(), err[info.fill].mean());
    }
    table += "\n";
    const HoleFill def = reproject::FillSettings{}.fill;
    if (double(holes) >= 0.01 * double(frames - 1) * width * height) ++large;
    EXPECT_LT(err[def].hole_mean(), err[HoleFill::naive].hole_mean()) << name;
    EXPECT_LT(err[def].mean(), err[HoleFill::naive].mean()) << name;
  }
  table += fmt::format("{:<8} {:>6} {:>6}", "mean", "", "");
  for (const auto& info : reproject::hole_fills())
    table += fmt::format(" | {:>9.5f}/{:>9.5f}", hole_sum[info.fill] / scenes,
                         all_sum[info.fill] / scenes);
  fmt::print(
      "display-space mean abs error against the rendered frame, over hole pixels / all pixels "
      "(frames {}-{} from frame {}, {}x{}):\n{}\n",
      base + 1, base + count, base, width, height, table);
  EXPECT_GE(scenes, 5);
  EXPECT_GE(large, 3);
  const HoleFill def = reproject::FillSettings{}.fill;
  for (const auto& info : reproject::hole_fills()) {
    EXPECT_LE(hole_sum[def], hole_sum[info.fill]) << info.name;
    EXPECT_LE(all_sum[def], all_sum[info.fill]) << info.name;
  }
  EXPECT_LT(hole_sum[def], hole_sum[HoleFill::naive]);
  EXPECT_LT(all_sum[def], all_sum[HoleFill::naive]);
}

}  // namespace

// The development configuration: the fill steps were chosen on it.
TEST(ForwardSplatTest, FillComparisonOnBuiltinScenes) {
  compare_fills(192, 108, 0, 8);
}

// Held out (never looked at while choosing the fill steps): another size, so other sample
// spacings and stretches, and another stretch of each sequence (frames 13-20 from frame 12).
TEST(ForwardSplatTest, FillComparisonHeldOut) {
  compare_fills(256, 144, 12, 8);
}

// Issue 13 test 5a: with exact motion (skip 1), interpolating from both sides is at least as
// good as extrapolating from the previous frame, on `motion` (the box disoccludes the wall):
// fewer holes in every frame, and a lower error over the sequence. Not in every frame: with
// Halton jitter a one-frame reprojection's error is mostly the sub-pixel distance between the
// source's and the target's samples on aliased texture (which jitter phases meet decides a
// frame); without jitter, the next frame's samples of the fast box land off the pixels'
// sample positions at its silhouette and win the depth test over the wall there (a point
// splat dilates the foreground by up to a pixel), which costs frames 5 and 7 a little.
TEST(ForwardSplatTest, InterpolationAtLeastAsGoodAsExtrapolation) {
  const render::Scene sc = render::make_builtin_scene("motion");
  for (const std::string jitter : {"none", "halton16"}) {
    SCOPED_TRACE(jitter);
    const std::vector<Frame> f = render_frames(sc, 9, small_settings(96, 54, jitter));
    ExtrapolateSettings ext;
    ext.skip = 1;
    ExtrapolateSettings inter = ext;
    inter.interpolate = true;
    const Exec ex;
    const ExtrapolationResult re = extrapolate_sequence(f, ext, ex);
    const ExtrapolationResult ri = extrapolate_sequence(f, inter, ex);
    double sum_e = 0, sum_i = 0;
    for (size_t k = 1; k < f.size(); k += 2) {
      ASSERT_TRUE(re.synthesized[k] && ri.synthesized[k]);
      EXPECT_EQ(re.reports[k].kind_a, DisplacementKind::motion_next);
      ASSERT_TRUE(ri.reports[k].b);
      EXPECT_EQ(ri.reports[k].kind_b, DisplacementKind::motion);
      Errors e, i;
      const Image<uint8_t> none(96, 54, 1, uint8_t(0));
      e.add(re.color[k], f[k].color, none);
      i.add(ri.color[k], f[k].color, none);
      fmt::print(
          "jitter {} frame {}: extrapolated {:.5f} (holes {:.2f}%), interpolated {:.5f} "
          "(holes {:.2f}%)\n",
          jitter, k, e.mean(), 100 * re.reports[k].hole_fraction, i.mean(),
          100 * ri.reports[k].hole_fraction);
      EXPECT_LE(ri.reports[k].hole_fraction, re.reports[k].hole_fraction) << k;
      sum_e += e.mean();
      sum_i += i.mean();
    }
    EXPECT_LE(sum_i, sum_e);
    for (size_t k = 0; k < f.size(); k += 2) {
      EXPECT_FALSE(re.synthesized[k]);
      EXPECT_TRUE(re.color[k] == f[k].color);
    }
    // Bit-identical for any thread count.
    const ExtrapolationResult r1 = extrapolate_sequence(f, inter, Exec{1, true});
    const ExtrapolationResult r2 = extrapolate_sequence(f, inter, Exec{2, true});
    for (size_t k = 0; k < f.size(); ++k) EXPECT_TRUE(r1.color[k] == r2.color[k]) << k;
  }
}

// Issue 13 test 5b: with camera motion only, the camera-only transfer through depth is the
// renderer's motion_next (to float tolerance), and the two splats agree.
TEST(ForwardSplatTest, CameraTransferMatchesMotionNextWithoutObjectMotion) {
  for (const std::string name : {"thin", "moire"}) {
    SCOPED_TRACE(name);
    const render::Scene sc = render::make_builtin_scene(name);
    const std::vector<Frame> f = render_frames(sc, 2, small_settings(96, 54, "halton16"));
    const auto cam = reproject::displacement_field(f[0], f[1], DisplacementKind::camera);
    const auto mot = reproject::displacement_field(f[0], f[1], DisplacementKind::motion_next);
    double max_diff = 0, max_motion = 0;
    for (int y = 0; y < 54; ++y)
      for (int x = 0; x < 96; ++x)
        for (int c = 0; c < 2; ++c) {
          max_diff = std::max(max_diff, double(std::abs(cam.displacement.at(x, y, c) -
                                                        mot.displacement.at(x, y, c))));
          max_motion = std::max(max_motion, double(std::abs(mot.displacement.at(x, y, c))));
        }
    EXPECT_GT(max_motion, 0.01);
    EXPECT_LT(max_diff, 2e-3) << "max |motion_next| " << max_motion;
    EXPECT_TRUE(cam.target_depth == mot.target_depth);
    const ForwardSplat a = splat(f[0], f[1], DisplacementKind::camera);
    const ForwardSplat b = splat(f[0], f[1], DisplacementKind::motion_next);
    size_t differ = 0;
    for (int y = 0; y < 54; ++y)
      for (int x = 0; x < 96; ++x)
        differ +=
            a.hole.at(x, y, 0) != b.hole.at(x, y, 0) || a.color.at(x, y, 0) != b.color.at(x, y, 0);
    // Only samples within max_diff of a pixel edge can land differently.
    EXPECT_LE(differ, size_t(96 * 54 / 200)) << differ;
  }
}
