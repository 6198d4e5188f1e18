// The built-in scenes of the failure modes TAA users hit (issue 10): each test measures the
// property the scene exists for, at the small sizes the scenes are meant to be fast at, so a
// scene edit that loses its point fails here. Numbers are printed for the log.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "core/color.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "render/scene.h"

namespace afterimage::render {
namespace {

RenderSettings settings(int w, int h, const char* jitter) {
  RenderSettings rs;
  rs.width = w;
  rs.height = h;
  rs.jitter = parse_jitter(jitter);
  return rs;
}

// Object id (index + 1) of the first object called `name`; 0 if there is none.
uint32_t object_id(const Scene& sc, const std::string& name) {
  for (size_t k = 0; k < sc.objects.size(); ++k)
    if (sc.objects[k].name == name) return uint32_t(k + 1);
  return 0;
}

float lum(const Frame& f, int x, int y) {
  return luminance(f.color_at(x, y));
}

float max_abs_motion(const Frame& f) {
  float m = 0;
  for (float v : f.motion.data()) m = std::max(m, std::abs(v));
  return m;
}

// World point of pixel (x, y)'s sample (jitter included) from its linear depth.
Vec3d world_point(const Frame& f, int x, int y) {
  const double sx = x + 0.5 + f.jitter.x, sy = y + 0.5 + f.jitter.y;
  const double nx = 2.0 * sx / f.width - 1.0, ny = 1.0 - 2.0 * sy / f.height;
  const Vec4d q = f.projection.inverse() * Vec4d(nx, ny, 1.0, 1.0);
  const Vec3d far = q.xyz() / q.w;
  const Vec3d view = far * (double(f.depth.at(x, y, 0)) / -far.z);
  return f.view.inverse().transform_point(view);
}

// light: nothing moves (motion exactly zero, ids and depth fixed) while the sweeping light's
// shadow of the plate moves across the floor every frame.
TEST(FailureScenes, LightShadowMovesWithZeroMotion) {
  const Scene sc = make_builtin_scene("light");
  // The same scene with the plate sunk below the floor: the floor's unshadowed lighting.
  Scene open = sc;
  const uint32_t plate = object_id(sc, "plate"), floor = object_id(sc, "floor");
  ASSERT_GT(plate, 0u);
  ASSERT_GT(floor, 0u);
  open.objects[plate - 1].animation = Animation::fixed({{0, -50, 0}, Quat{}, {1, 1, 1}});
  const RenderSettings rs = settings(129, 73, "none");
  const int frames = 16;
  std::vector<Frame> f;
  std::vector<std::vector<bool>> shadow(frames);
  std::vector<double> centroid;
  for (int k = 0; k < frames; ++k) {
    f.push_back(render_gbuffer(sc, k, rs, Exec{}));
    const Frame lit = render_gbuffer(open, k, rs, Exec{});
    EXPECT_EQ(max_abs_motion(f[k]), 0.0f) << "frame " << k;
    EXPECT_EQ(f[k].id, f[0].id);
    EXPECT_EQ(f[k].depth, f[0].depth);
    EXPECT_EQ(f[k].view, f[0].view);
    double sx = 0;
    int n = 0;
    shadow[k].assign(size_t(rs.width * rs.height), false);
    for (int y = 0; y < rs.height; ++y)
      for (int x = 0; x < rs.width; ++x)
        if (f[k].id.at(x, y, 0) == floor && lit.id.at(x, y, 0) == floor &&
            lum(f[k], x, y) < 0.6f * lum(lit, x, y)) {
          shadow[k][size_t(y * rs.width + x)] = true;
          sx += x;
          ++n;
        }
    EXPECT_GT(n, 40) << "shadow area at frame " << k;
    centroid.push_back(n ? sx / n : 0.0);
  }
  int min_changed = 1 << 30;
  for (int k = 1; k < frames; ++k) {
    int changed = 0;
    for (size_t i = 0; i < shadow[k].size(); ++i) changed += shadow[k][i] != shadow[k - 1][i];
    min_changed = std::min(min_changed, changed);
    // The light moves toward +x for the first 2 s, so the shadow moves toward -x.
    EXPECT_LT(centroid[k], centroid[k - 1]) << "frame " << k;
  }
  std::printf(
      "light: shadow centroid x %.1f -> %.1f px over %d frames, >= %d px change per frame\n",
      centroid.front(), centroid.back(), frames, min_changed);
  EXPECT_GT(min_changed, 5);
  EXPECT_LT(centroid.back() - centroid.front(), -8.0);
}

// light: the panel's emission is on for 4 frames and off for 4, as its description says.
TEST(FailureScenes, LightPanelBlinksFourOnFourOff) {
  const Scene sc = make_builtin_scene("light");
  const uint32_t panel = object_id(sc, "blinking panel");
  ASSERT_GT(panel, 0u);
  const Material& m = sc.objects[panel - 1].material;
  EXPECT_DOUBLE_EQ(m.emission_blink.period * sc.fps, 8.0);
  const RenderSettings rs = settings(97, 55, "halton16");
  const float on_level = luminance(m.emission);
  for (int k = 0; k < 20; ++k) {
    const Frame f = render_gbuffer(sc, k, rs, Exec{});
    double sum = 0;
    int n = 0;
    for (int y = 0; y < rs.height; ++y)
      for (int x = 0; x < rs.width; ++x)
        if (f.id.at(x, y, 0) == panel) {
          sum += lum(f, x, y);
          ++n;
        }
    ASSERT_GT(n, 10);
    const bool on = k % 8 < 4;
    EXPECT_EQ(m.emission_blink.on(sc.eval_time(k)), on);
    if (on)
      EXPECT_GE(sum / n, on_level) << "frame " << k;
    else
      EXPECT_LT(sum / n, 0.05 * on_level) << "frame " << k;
  }
}

// cut: camera_cut is set exactly on the first frame of each shot (frame 8, then every 16),
// whose motion is zero (it refers to itself); the frames around it keep their motion.
TEST(FailureScenes, CutFlagsFirstFrameOfEachShot) {
  const Scene sc = make_builtin_scene("cut");
  for (int k = 0; k < 80; ++k)
    EXPECT_EQ(sc.camera_cut_at(k), k >= 8 && (k - 8) % 16 == 0) << "frame " << k;
  const Scene frozen = make_builtin_scene("cut", true);
  for (int k = 0; k < 80; ++k) EXPECT_FALSE(frozen.camera_cut_at(k));

  const RenderSettings rs = settings(97, 55, "halton16");
  std::map<int, Frame> f;
  for (int k = 6; k <= 10; ++k) f[k] = render_gbuffer(sc, k, rs, Exec{});
  for (int k = 6; k <= 10; ++k) {
    EXPECT_EQ(f[k].camera_cut, k == 8) << "frame " << k;
    if (k == 8)
      EXPECT_EQ(max_abs_motion(f[k]), 0.0f);
    else
      EXPECT_GT(max_abs_motion(f[k]), 0.05f) << "frame " << k;
  }
  EXPECT_TRUE(render_reference(sc, 8, 4, rs, Exec{}).camera_cut);
  // A real cut: most pixels see another surface (object, or depth off by > 10%) after it
  // (all but the sky, about a third of the frame), few within a shot.
  auto changed = [&](int a, int b) {
    int n = 0;
    const size_t count = f[a].id.data().size();
    for (size_t i = 0; i < count; ++i) {
      const float da = f[a].depth.data()[i], db = f[b].depth.data()[i];
      n += f[a].id.data()[i] != f[b].id.data()[i] || std::abs(da - db) > 0.1f * std::min(da, db);
    }
    return double(n) / double(count);
  };
  std::printf(
      "cut: pixels seeing another surface: %.2f across the cut, %.2f and %.2f within "
      "shots\n",
      changed(7, 8), changed(6, 7), changed(9, 10));
  EXPECT_GT(changed(7, 8), 0.5);
  EXPECT_LT(changed(6, 7), 0.1);
  EXPECT_LT(changed(9, 10), 0.1);
}

// blades: every blade is narrower than a pixel at 128x72 (sub-pixel geometry), blade pixels
// move (object motion; the camera is still, so nothing else does), and under jitter alone
// the blades cover different pixels from frame to frame.
TEST(FailureScenes, BladesAreSubPixelAndMove) {
  const Scene sc = make_builtin_scene("blades");
  const RenderSettings rs = settings(128, 72, "halton16");
  std::vector<bool> is_blade(sc.objects.size() + 1, false);
  for (size_t k = 0; k < sc.objects.size(); ++k) is_blade[k + 1] = sc.objects[k].name == "blade";
  const Mesh& blade_mesh = sc.meshes[size_t(sc.objects[object_id(sc, "blade") - 1].mesh)];
  float mesh_width = 0;
  for (Vec3f p : blade_mesh.positions) mesh_width = std::max(mesh_width, 2 * std::abs(p.x));

  const double focal_px = rs.height / (2.0 * std::tan(sc.camera.vfov_degrees * kPi / 360.0));
  for (int k = 1; k <= 3; ++k) {
    const Frame f = render_gbuffer(sc, k, rs, Exec{});
    int blade_px = 0, moving = 0, visible = 0;
    double sum_motion = 0, widest = 0;
    std::vector<float> nearest(sc.objects.size() + 1, 1e30f);
    for (int y = 0; y < rs.height; ++y)
      for (int x = 0; x < rs.width; ++x) {
        const uint32_t id = f.id.at(x, y, 0);
        const double m = std::hypot(f.motion.at(x, y, 0), f.motion.at(x, y, 1));
        if (!is_blade[id]) {
          ASSERT_EQ(m, 0.0) << "non-blade pixel " << x << "," << y << " moves";
          continue;
        }
        ++blade_px;
        moving += m > 0;
        sum_motion += m;
        nearest[id] = std::min(nearest[id], f.depth.at(x, y, 0));
      }
    for (size_t id = 1; id < nearest.size(); ++id) {
      if (nearest[id] > 1e29f) continue;
      ++visible;
      const double width = mesh_width * sc.objects[id - 1].animation.at(sc.eval_time(k)).scale.x;
      widest = std::max(widest, width * focal_px / nearest[id]);
    }
    std::printf("blades frame %d: %d visible, widest base %.2f px, %d blade px, mean motion %.2f\n",
                k, visible, widest, blade_px, sum_motion / std::max(blade_px, 1));
    EXPECT_GT(visible, 60);
    EXPECT_LT(widest, 1.0);
    EXPECT_GT(moving, 0.95 * blade_px);
    EXPECT_GT(sum_motion / blade_px, 0.25);
  }

  // Static: only the jitter changes, yet most pixels the blades touch are covered in some
  // frames and not in others.
  const Scene frozen = make_builtin_scene("blades", true);
  std::vector<int> hits(size_t(rs.width * rs.height), 0);
  for (int k = 0; k < 16; ++k) {
    const Frame f = render_gbuffer(frozen, k, rs, Exec{});
    for (size_t i = 0; i < hits.size(); ++i) hits[i] += is_blade[f.id.data()[i]];
  }
  int ever = 0, always = 0;
  for (int h : hits) {
    ever += h > 0;
    always += h == 16;
  }
  std::printf("blades static: %d px ever covered, %d in all 16 jittered frames\n", ever, always);
  EXPECT_GT(ever, 300);
  EXPECT_LT(always, ever / 4);
}

// moire: near the horizon the ground's checker has many cells per pixel (above Nyquist: one
// cell per pixel), and there the 1-spp image differs strongly from the 16-spp reference,
// which averages to grey; near the camera the checker is resolved and both agree.
TEST(FailureScenes, MoireGroundIsAboveNyquistTowardTheHorizon) {
  const Scene sc = make_builtin_scene("moire", true);
  const RenderSettings rs = settings(129, 73, "none");
  const Frame g = render_gbuffer(sc, 0, rs, Exec{});
  const Frame ref = render_reference(sc, 0, 16, rs, Exec{});
  const uint32_t ground = object_id(sc, "ground");
  const Object& obj = sc.objects[ground - 1];
  float lo = 1e30f, hi = -1e30f;
  for (Vec3f p : sc.meshes[size_t(obj.mesh)].positions) {
    lo = std::min(lo, p.x);
    hi = std::max(hi, p.x);
  }
  const double cell = (hi - lo) / obj.material.frequency;

  struct Band {
    int n = 0;
    double err = 0, ref_sum = 0;
    std::vector<float> noaa, reference;
  } near, far;
  for (int y = 0; y + 1 < rs.height; ++y)
    for (int x = 0; x < rs.width; ++x) {
      if (g.id.at(x, y, 0) != ground || g.id.at(x, y + 1, 0) != ground) continue;
      // Ground distance between vertically adjacent samples, in checker cells.
      const double cells = length(world_point(g, x, y) - world_point(g, x, y + 1)) / cell;
      Band* b = cells > 2.0 ? &far : cells < 0.5 ? &near : nullptr;
      if (!b) continue;
      ++b->n;
      b->err += std::abs(lum(g, x, y) - lum(ref, x, y));
      b->ref_sum += lum(ref, x, y);
      b->noaa.push_back(lum(g, x, y));
      b->reference.push_back(lum(ref, x, y));
    }
  auto stddev = [](const std::vector<float>& v) {
    double m = 0, s = 0;
    for (float a : v) m += a;
    m /= double(v.size());
    for (float a : v) s += (a - m) * (a - m);
    return std::sqrt(s / double(v.size()));
  };
  ASSERT_GT(near.n, 300);
  ASSERT_GT(far.n, 300);
  const double e_near = near.err / near.ref_sum, e_far = far.err / far.ref_sum;
  std::printf(
      "moire: |1spp - ref| / ref: near (< 0.5 cell/px, %d px) %.3f, far (> 2 cells/px, %d px) "
      "%.3f; far contrast 1spp %.3f, ref %.3f\n",
      near.n, e_near, far.n, e_far, stddev(far.noaa), stddev(far.reference));
  EXPECT_GT(e_far, 0.5);
  EXPECT_LT(e_near, 0.5 * e_far);
  EXPECT_LT(stddev(far.reference), 0.3 * stddev(far.noaa));
}

// Per-pixel temporal standard deviation of luminance over frames, averaged over the pixels
// that show object `id` in every frame, relative to their mean luminance.
double relative_flicker(const std::vector<Frame>& frames, uint32_t id) {
  const Frame& f0 = frames.front();
  double sum_sd = 0, sum_mean = 0;
  for (int y = 0; y < f0.height; ++y)
    for (int x = 0; x < f0.width; ++x) {
      double s = 0, s2 = 0;
      bool all = true;
      for (const Frame& f : frames) {
        all = all && f.id.at(x, y, 0) == id;
        const double l = lum(f, x, y);
        s += l;
        s2 += l * l;
      }
      if (!all) continue;
      const double n = double(frames.size()), m = s / n;
      sum_sd += std::sqrt(std::max(0.0, s2 / n - m * m));
      sum_mean += m;
    }
  return sum_sd / sum_mean;
}

// sparkle: with the camera frozen, jitter alone makes the flake floor's 1-spp luminance
// flicker far more than the same floor without its bumps (the references of a static scene
// do not flicker at all), and the firefly emitter is in some frames' pixels and not others.
TEST(FailureScenes, SparkleFlickersUnderJitter) {
  const Scene sc = make_builtin_scene("sparkle", true);
  Scene smooth = sc;
  const uint32_t floor = object_id(sc, "flake floor"), firefly = object_id(sc, "firefly");
  ASSERT_GT(floor, 0u);
  ASSERT_GT(firefly, 0u);
  smooth.objects[floor - 1].material.bump = Bump::None;
  const RenderSettings rs = settings(128, 72, "halton16");
  std::vector<Frame> bumped, flat;
  for (int k = 0; k < 16; ++k) {
    bumped.push_back(render_gbuffer(sc, k, rs, Exec{}));
    flat.push_back(render_gbuffer(smooth, k, rs, Exec{}));
  }
  const double flicker = relative_flicker(bumped, floor), base = relative_flicker(flat, floor);
  EXPECT_EQ(render_reference(sc, 0, 4, rs, Exec{}).color,
            render_reference(sc, 9, 4, rs, Exec{}).color);

  // The pixels the firefly touches: blazing in some frames, ordinary in others.
  float brightest = 0, darkest_of_those = 1e30f;
  for (int y = 0; y < rs.height; ++y)
    for (int x = 0; x < rs.width; ++x) {
      float hi = 0, lo = 1e30f;
      bool touched = false;
      for (const Frame& f : bumped) {
        touched = touched || f.id.at(x, y, 0) == firefly;
        hi = std::max(hi, lum(f, x, y));
        lo = std::min(lo, lum(f, x, y));
      }
      if (touched && hi > brightest) {
        brightest = hi;
        darkest_of_those = lo;
      }
    }
  std::printf(
      "sparkle: relative temporal sd of the floor under jitter %.3f (without bumps %.3f); "
      "firefly pixel %.0f at most, %.2f in its darkest frame\n",
      flicker, base, brightest, darkest_of_those);
  EXPECT_GT(flicker, 0.5);
  EXPECT_GT(flicker, 4.0 * base);
  EXPECT_GT(brightest, 1000.0f);
  EXPECT_LT(darkest_of_those, 0.01f * brightest);

  // The animated scene's camera move is slow: under 1 px per frame at this size.
  const Frame moving = render_gbuffer(make_builtin_scene("sparkle"), 5, rs, Exec{});
  EXPECT_GT(max_abs_motion(moving), 0.01f);
  EXPECT_LT(max_abs_motion(moving), 1.0f);
}

}  // namespace
}  // namespace afterimage::render
