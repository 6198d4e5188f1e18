// TemporalResolver on synthetic sequences with exact motion vectors (DESIGN.md §3): scalar
// vs SIMD, thread counts, robustness, state files, Eq.1/Eq.2 accumulation, rejection and
// ghosting. Odd sizes exercise the SIMD tails.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "camera/camera.h"
#include "core/error.h"
#include "core/state_file.h"
#include "taa/presets.h"
#include "taa/resolver.h"
#include "taa/taa_kernels.h"
#include "test_util.h"

using namespace afterimage;
using namespace afterimage::taa;

namespace {

// A textured plane panning at `pan` px/frame (depth 10, id 1) with a square of `sq_size`
// moving at `sq_vel` px/frame in front (depth 2, id 7). Colors, depth and id are taken at
// the jittered sample position, motion vectors are exact: motion = -velocity.
struct SceneSpec {
  int w = 37, h = 23;
  Vec2f pan{0.37f, -0.21f};
  Vec2f sq_pos{6.0f, 5.0f};
  Vec2f sq_vel{1.3f, 0.6f};
  float sq_size = 9.0f;
  float sq_value = 4.0f;  // HDR
  bool textured = true;
  float bg_value = 0.5f;
  bool jitter = true;
};

float texture(float x, float y) {
  return 0.5f + 0.3f * std::sin(0.9f * x) * std::cos(0.7f * y) +
         0.1f * std::sin(0.31f * x + 0.2f * y);
}

Frame render(const SceneSpec& sc, int t) {
  Frame f = Frame::allocate(sc.w, sc.h);
  Vec2d j = sc.jitter ? JitterSequence{}.at(t) : Vec2d{0, 0};
  f.jitter = j;
  f.index = t;
  const float sx0 = sc.sq_pos.x + sc.sq_vel.x * float(t),
              sy0 = sc.sq_pos.y + sc.sq_vel.y * float(t);
  for (int y = 0; y < sc.h; ++y)
    for (int x = 0; x < sc.w; ++x) {
      float px = float(x) + 0.5f + float(j.x), py = float(y) + 0.5f + float(j.y);
      bool in_sq = px >= sx0 && px < sx0 + sc.sq_size && py >= sy0 && py < sy0 + sc.sq_size;
      if (in_sq) {
        for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = sc.sq_value * (0.6f + 0.2f * float(c));
        f.depth.at(x, y, 0) = 2.0f;
        f.id.at(x, y, 0) = 7;
        f.motion.at(x, y, 0) = -sc.sq_vel.x;
        f.motion.at(x, y, 1) = -sc.sq_vel.y;
      } else {
        float u = px - sc.pan.x * float(t), v = py - sc.pan.y * float(t);
        float base = sc.textured ? texture(u, v) : sc.bg_value;
        for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = base * (0.8f + 0.15f * float(c));
        f.depth.at(x, y, 0) = 10.0f;
        f.id.at(x, y, 0) = 1;
        f.motion.at(x, y, 0) = -sc.pan.x;
        f.motion.at(x, y, 1) = -sc.pan.y;
      }
    }
  return f;
}

Exec exec(bool simd, int threads) {
  Exec e;
  e.simd = simd;
  e.threads = threads;
  return e;
}

float max_abs_diff(const ImageF& a, const ImageF& b) {
  EXPECT_TRUE(a.same_shape(b));
  float m = 0;
  for (size_t i = 0; i < a.data().size(); ++i) m = std::max(m, std::abs(a.data()[i] - b.data()[i]));
  return m;
}

bool all_finite(const ImageF& a) {
  for (float v : a.data())
    if (!std::isfinite(v)) return false;
  return true;
}

// Settings variants beyond the presets, to cover every option in the agreement tests.
std::vector<std::pair<std::string, TaaSettings>> all_variants() {
  std::vector<std::pair<std::string, TaaSettings>> v;
  for (const auto& n : preset_names()) v.push_back({n, make_preset(n)});
  TaaSettings s = preset_afterimage();
  s.rectify = Rectify::ConvexHull;
  v.push_back({"convex_hull", s});
  s = preset_afterimage();
  s.confidence = true;  // history confidence: 4 more state planes, the moments
  v.push_back({"confidence", s});
  s = preset_afterimage();
  s.history = HistorySampler::Bicubic16;
  s.dilation = VelocityDilation::LargestMotion;
  s.velocity_reject = Rejection::Reduce;
  v.push_back({"bicubic16_largest", s});
  s = preset_ue4();
  s.history = HistorySampler::CatmullRom9;
  s.adaptive_depth = true;
  s.depth_alpha_distance = 3.0f;
  s.current_filter = CurrentFilter::Gaussian;
  s.filter_luma_weight = true;
  s.neighborhood = Neighborhood::Cross5;
  s.rectify = Rectify::Clamp;
  v.push_back({"cr9_depth_alpha_cross", s});
  s = preset_inside();
  s.static_mode = true;
  s.sample_count = true;
  v.push_back({"static_count", s});
  return v;
}

}  // namespace

// --simd off runs every pixel as a block of one: a pixel's result must not depend on the other
// lanes of its block (a block-wide shortcut such as the fresh filter's handover must give each
// lane what it gives alone), so the two agree bit for bit.
// The second scene is larger, faster and noisy: disocclusions leave blocks where some lanes'
// fresh history has handed over and others' has not, with colours whose blends round.
TEST(TaaResolver, ScalarAndSimdAgreeOverFramesWithMotion) {
  SceneSpec noisy;
  noisy.w = 101;
  noisy.h = 57;
  noisy.sq_size = 17.0f;
  noisy.sq_vel = {2.3f, 1.1f};
  for (const auto& [scene, sc] : {std::pair{"small", SceneSpec{}}, std::pair{"noisy", noisy}})
    for (const auto& [name, s] : all_variants()) {
      TemporalResolver simd(s, exec(true, 1)), scalar(s, exec(false, 1));
      std::mt19937 rng(5);
      std::uniform_real_distribution<float> grain(0.8f, 1.2f);
      for (int t = 0; t < 10; ++t) {
        Frame f = render(sc, t);
        if (scene == std::string("noisy"))
          for (float& v : f.color.data()) v *= grain(rng);
        ImageF a = simd.process(f), b = scalar.process(f);
        test::expect_same_bits(a, b,
                               std::string(scene) + " " + name + " frame " + std::to_string(t));
      }
    }
}

TEST(TaaResolver, IdenticalForOneAndTwoThreads) {
  SceneSpec sc;
  for (const auto& [name, s] : all_variants()) {
    TemporalResolver one(s, exec(true, 1)), two(s, exec(true, 2));
    for (int t = 0; t < 4; ++t) {
      Frame f = render(sc, t);
      EXPECT_EQ(one.process(f), two.process(f)) << name << " frame " << t;
    }
    EXPECT_EQ(one.sample_count(), two.sample_count()) << name;
  }
}

TEST(TaaResolver, FirstFrameCameraCutAndResizeStartFromCurrent) {
  SceneSpec sc;
  TemporalResolver r(preset_none());
  Frame f0 = render(sc, 0);
  EXPECT_EQ(r.process(f0), f0.color);
  r.process(render(sc, 1));
  Frame f2 = render(sc, 2);
  EXPECT_NE(r.process(f2), f2.color);  // history blended in
  Frame f3 = render(sc, 3);
  f3.camera_cut = true;
  EXPECT_EQ(r.process(f3), f3.color);
  SceneSpec small = sc;
  small.w = 19;
  small.h = 11;
  Frame g = render(small, 4);
  EXPECT_EQ(r.process(g), g.color);
  r.reset();
  Frame g5 = render(small, 5);
  EXPECT_EQ(r.process(g5), g5.color);
}

// Seed 000 Eq.1: with alpha = 1/N a pixel holds the exact box average of its N frames.
TEST(TaaResolver, SampleCountGivesExactBoxAverage) {
  TaaSettings s = preset_none();
  s.sample_count = true;
  s.alpha_min = 0.001f;
  for (bool simd : {true, false}) {
    TemporalResolver r(s, exec(simd, 0));
    std::mt19937 rng(2);
    std::uniform_real_distribution<float> u(0.0f, 5.0f);
    double sum[3] = {0, 0, 0};
    for (int n = 1; n <= 12; ++n) {
      Frame f = Frame::allocate(37, 23);
      f.jitter = JitterSequence{}.at(n);
      float x[3] = {u(rng), u(rng), u(rng)};
      for (int c = 0; c < 3; ++c) {
        for (int i = 0; i < 37 * 23; ++i) f.color.plane(c)[i] = x[c];
        sum[c] += x[c];
      }
      ImageF out = r.process(f);
      for (int c = 0; c < 3; ++c) {
        const double mean = sum[c] / n;
        for (int i = 0; i < 37 * 23; ++i)
          ASSERT_NEAR(out.plane(c)[i], mean, 2e-6 * std::max(1.0, mean)) << "N " << n;
      }
      for (float v : r.sample_count().data()) ASSERT_NEAR(v, float(n), 1e-4f);
    }
  }
}

// fresh_filter_sigma: while the history holds fewer than fresh_filter_frames frames the shown
// color blends the wide Gaussian of the jittered 3x3, handed over linearly to the current
// filter, into the history, which itself stays the running mean of the current filter's colors
// (alpha = 1/N): both computed here from the sample positions alone (DESIGN.md §3: neighbour
// (dx, dy) sampled at (dx, dy) + jitter).
TEST(TaaResolver, FreshHistoryBlendsTheWideGaussianThenHandsOver) {
  TaaSettings s = preset_none();
  s.sample_count = true;
  s.alpha_min = 0.001f;
  s.current_filter = CurrentFilter::Gaussian;
  s.filter_sigma = 0.3f;
  s.blend_filtered = true;
  s.fresh_filter_sigma = 0.6f;
  s.fresh_filter_frames = 4.0f;
  const int w = 21, h = 13;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 3.0f);
  Frame still = Frame::allocate(w, h);
  for (float& v : still.color.data()) v = u(rng);
  auto gaussian = [&](int x, int y, int c, float sigma, Vec2d j) {
    double acc = 0, wsum = 0;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const double sx = dx + j.x, sy = dy + j.y;
        const double wt = std::exp(-(sx * sx + sy * sy) / (2.0 * sigma * sigma));
        acc += wt * still.color.at(x + dx, y + dy, c);
        wsum += wt;
      }
    return acc / wsum;
  };
  for (bool simd : {true, false}) {
    TemporalResolver r(s, exec(simd, 0));
    std::vector<double> mean(size_t(w * h * 3), 0.0);
    for (int n = 1; n <= 7; ++n) {
      Frame f = still;
      f.jitter = JitterSequence{}.at(n);
      const ImageF out = r.process(f);
      const double t = std::min(1.0, (n - 1) / 4.0);  // frames kept / fresh_filter_frames
      for (int y = 1; y < h - 1; ++y)
        for (int x = 1; x < w - 1; ++x)
          for (int c = 0; c < 3; ++c) {
            const double wide = gaussian(x, y, c, 0.6f, f.jitter);
            const double narrow = gaussian(x, y, c, 0.3f, f.jitter);
            double& m = mean[size_t((c * h + y) * w + x)];
            const double shown = m + (wide + t * (narrow - wide) - m) / n;
            m += (narrow - m) / n;
            ASSERT_NEAR(out.at(x, y, c), shown, 2e-5) << "frame " << n << " simd " << simd;
            ASSERT_NEAR(r.history().at(x, y, c), m, 2e-5) << "frame " << n << " simd " << simd;
          }
    }
  }
}

// Seed 000 Eq.2 with a fixed alpha.
TEST(TaaResolver, FixedAlphaIsTheExponentialFilter) {
  TaaSettings s = preset_none();
  s.alpha = 0.1f;
  TemporalResolver r(s);
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(0.0f, 5.0f);
  double st = 0;
  for (int t = 0; t < 10; ++t) {
    Frame f = Frame::allocate(37, 23);
    float x = u(rng);
    f.color.fill(x);
    st = t == 0 ? x : 0.1 * x + 0.9 * st;
    ImageF out = r.process(f);
    for (float v : out.data()) ASSERT_NEAR(v, st, 1e-5);
  }
}

TEST(TaaResolver, StaticModeLoadsHistoryWithoutBlur) {
  // Identical frames with a sub-pixel motion field: point sampling reads the pixel itself
  // (floor(p + 0.3)), bilinear blurs.
  Frame f = Frame::allocate(37, 23);
  f.color = test::random_image(37, 23, 3, 6, 0.0f, 2.0f);
  for (int i = 0; i < 37 * 23; ++i) {
    f.motion.plane(0)[i] = 0.3f;
    f.motion.plane(1)[i] = 0.2f;
  }
  TaaSettings s = preset_none();
  s.static_mode = true;
  TemporalResolver st(s);
  TemporalResolver bl(preset_none());
  ImageF a, b;
  for (int t = 0; t < 5; ++t) {
    a = st.process(f);
    b = bl.process(f);
  }
  EXPECT_EQ(a, f.color);
  EXPECT_GT(max_abs_diff(b, f.color), 1e-2f);
}

TEST(TaaResolver, OffScreenHistoryIsRejected) {
  Frame f0 = Frame::allocate(37, 23), f1 = Frame::allocate(37, 23);
  f0.color.fill(1.0f);
  f1.color.fill(3.0f);
  for (int i = 0; i < 37 * 23; ++i) f1.motion.plane(0)[i] = -3.2f;  // read 3.2 px to the left
  TemporalResolver r(preset_none());
  r.process(f0);
  ImageF out = r.process(f1);
  for (int y = 0; y < 23; ++y)
    for (int x = 0; x < 37; ++x) {
      float expect = x <= 2 ? 3.0f : 0.1f * 3.0f + 0.9f * 1.0f;  // x + 0.5 - 3.2 < 0
      ASSERT_NEAR(out.at(x, y, 0), expect, 1e-6f) << x;
    }
}

namespace {
// Frame 0: color 1, depth 10, id 1, motion 0. Frame 1: columns [10, 20) change to color 3
// and, depending on `what`, depth 2, id 2 or motion (4, 0).
ImageF rejection_run(const TaaSettings& s, const std::string& what) {
  Frame f0 = Frame::allocate(37, 23);
  f0.color.fill(1.0f);
  f0.depth.fill(10.0f);
  f0.id.fill(1);
  Frame f1 = f0;
  for (int y = 0; y < 23; ++y)
    for (int x = 10; x < 20; ++x) {
      for (int c = 0; c < 3; ++c) f1.color.at(x, y, c) = 3.0f;
      if (what == "depth") f1.depth.at(x, y, 0) = 2.0f;
      if (what == "id") f1.id.at(x, y, 0) = 2;
      if (what == "velocity") f1.motion.at(x, y, 0) = 4.0f;
    }
  TemporalResolver r(s);
  r.process(f0);
  return r.process(f1);
}
}  // namespace

TEST(TaaResolver, GeometryRejectionResetAndReduce) {
  for (std::string what : {"depth", "id", "velocity"}) {
    for (Rejection mode : {Rejection::Off, Rejection::Reset, Rejection::Reduce}) {
      TaaSettings s = preset_none();
      s.reject_keep = 0.25f;
      if (what == "depth") s.depth_reject = mode;
      if (what == "id") s.id_reject = mode;
      if (what == "velocity") s.velocity_reject = mode;
      ImageF out = rejection_run(s, what);
      // Inside the changed columns: history 1 (velocity: read 4 px right, still 1 or the
      // changed columns' previous value 1), current 3.
      const float keep = mode == Rejection::Off ? 1.0f : mode == Rejection::Reset ? 0.0f : 0.25f;
      const float alpha = 1.0f - 0.9f * keep;
      for (int x = 10; x < 20; ++x)
        EXPECT_NEAR(out.at(x, 11, 1), alpha * 3.0f + (1.0f - alpha) * 1.0f, 1e-5f)
            << what << " " << to_string(mode) << " x " << x;
      // Unchanged pixels keep their (identical) history.
      EXPECT_NEAR(out.at(3, 11, 0), 1.0f, 1e-6f);
      EXPECT_NEAR(out.at(30, 11, 0), 1.0f, 1e-6f);
    }
  }
}

// process() checks rows for NaN / Inf / negative color during the resolve and, if one needs
// sanitising, sanitises and resolves the frame again: that path must also be identical for
// any thread count and for the 1-lane reference path.
TEST(TaaResolver, DirtyFramesIdenticalForThreadsAndSimd) {
  SceneSpec sc;
  for (const char* preset : {"afterimage", "none"}) {
    TemporalResolver one(make_preset(preset), exec(true, 1)),
        two(make_preset(preset), exec(true, 2));
    TemporalResolver scalar(make_preset(preset), exec(false, 2));
    for (int t = 0; t < 5; ++t) {
      Frame g = render(sc, t);
      if (t % 2 == 1) {
        g.color.at(30, 3, 1) = std::numeric_limits<float>::quiet_NaN();
        g.color.at(3, 2 + t, 1) = -5.0f;
      }
      const ImageF a = one.process(g), b = two.process(g), c = scalar.process(g);
      EXPECT_EQ(a, b) << preset << " frame " << t;
      EXPECT_EQ(a, c) << preset << " frame " << t;  // --simd off is bit-identical
      EXPECT_EQ(one.sample_count(), two.sample_count()) << preset << " frame " << t;
    }
  }
}

TEST(TaaResolver, NonFiniteAndNegativeInputsNeverReachTheOutput) {
  SceneSpec sc;
  for (const char* preset : {"afterimage", "none", "ue4", "inside"}) {
    // The published presets' boxes have no floor: on this grey scene their clip is
    // discontinuous in the history's chroma (OnePixelChangedSlightlyChangesTheOutputSlightly),
    // so a clean and a dirty run can drift apart for reasons that have nothing to do with the
    // non-finite input. The floor isolates what this test is about.
    TaaSettings ts = make_preset(preset);
    ts.box_floor = std::max(ts.box_floor, 0.001f);
    TemporalResolver clean(ts), dirty(ts);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    float before = 0, after = 0, late = 0;
    for (int t = 0; t < 12; ++t) {
      Frame f = render(sc, t);
      Frame g = f;
      if (t == 3) {
        g.color.at(30, 3, 1) = nan;  // background, away from the square
        g.color.at(2, 20, 0) = inf;
        g.color.at(33, 18, 2) = -inf;
        g.color.at(3, 2, 1) = -5.0f;
        g.motion.at(20, 20, 0) = nan;
        g.depth.at(21, 20, 0) = nan;
      }
      ImageF a = clean.process(f), b = dirty.process(g);
      ASSERT_TRUE(all_finite(b)) << preset << " frame " << t;
      ASSERT_TRUE(all_finite(dirty.history())) << preset;
      for (float v : b.data()) ASSERT_GE(v, 0.0f);
      // The NaN pixel's neighbourhood converges back to the clean run: within 0.02 four
      // frames later, 0.01 eight frames later. (The held pixel counts one sample fewer, so
      // where alpha = 1 / N it blends a little differently for a few frames.)
      float diff = 0;
      for (int y = 1; y <= 5; ++y)
        for (int x = 28; x <= 32; ++x)
          for (int c = 0; c < 3; ++c)
            diff = std::max(diff, std::abs(a.at(x, y, c) - b.at(x, y, c)));
      if (t == 3) before = diff;
      if (t == 7) after = diff;
      if (t == 11) late = diff;
    }
    EXPECT_LE(after, 0.02f) << preset << " (at injection " << before << ")";
    EXPECT_LE(late, 0.01f) << preset;
  }
}

// Continuity: one input pixel changed by 0.001 changes no output pixel by more than that, in
// this frame or any later one. The test scene is grey (Co = Cg = 0 in every sample), where a
// box without a floor is flat in chroma: a rounding-sized chroma deviation of the history then
// clipped it all the way to the filtered color (0.07 the next frame; settings.h box_floor).
TEST(TaaResolver, OnePixelChangedSlightlyChangesTheOutputSlightly) {
  SceneSpec sc;
  for (const char* preset : {"afterimage", "none"}) {
    TemporalResolver clean(make_preset(preset)), changed(make_preset(preset));
    float worst = 0;
    for (int t = 0; t < 10; ++t) {
      const Frame f = render(sc, t);
      Frame g = f;
      if (t == 3) g.color.at(30, 3, 1) += 0.001f;
      const ImageF a = clean.process(f), b = changed.process(g);
      for (size_t i = 0; i < a.data().size(); ++i)
        worst = std::max(worst, std::abs(a.data()[i] - b.data()[i]));
    }
    std::printf("%s: largest output change %.6f\n", preset, worst);
    EXPECT_LE(worst, 0.001f) << preset;
  }
}

// A non-finite history pixel (here planted in a state file) is reset, never propagated.
TEST(TaaResolver, NonFiniteHistoryPixelIsReset) {
  SceneSpec sc;
  const float kNaN = std::numeric_limits<float>::quiet_NaN();
  TemporalResolver r(preset_none());
  r.process(render(sc, 0));
  const std::string path = ::testing::TempDir() + "taa_nan_state.bin";
  r.save_state(path);
  {
    // Rewrite the file section by section (core/state_file.h), with one NaN in history.
    StateWriter w("taa", 1);
    const StateReader in(path, "taa", 1);
    for (const auto& sec : in.sections()) {
      std::vector<unsigned char> bytes(sec.bytes, sec.bytes + sec.count * elem_size(sec.type));
      if (sec.name == "history")
        std::memcpy(bytes.data() + (5 * sc.w + 5) * 4, &kNaN, 4);  // plane 0, pixel (5, 5)
      w.put_raw(sec.name, sec.type, sec.count, bytes.data());
    }
    w.save(path);
  }
  TemporalResolver q(preset_none());
  q.load_state(path);
  Frame f1 = render(sc, 1);
  f1.motion.fill(0.0f);  // read the poisoned pixel exactly
  ImageF out = q.process(f1);
  EXPECT_TRUE(all_finite(out));
  EXPECT_TRUE(all_finite(q.history()));
  EXPECT_EQ(out.at(5, 5, 0), f1.color.at(5, 5, 0));      // reset: the current color
  EXPECT_NE(out.at(30, 18, 0), f1.color.at(30, 18, 0));  // others blend as usual
  std::filesystem::remove(path);
}

TEST(TaaResolver, SaveLoadContinuesBitIdentically) {
  SceneSpec sc;
  for (const char* preset : {"afterimage", "ue4", "hdrp", "afterimage+confidence"}) {
    TaaSettings s = make_preset(std::string(preset).substr(0, std::string(preset).find('+')));
    s.confidence = std::string(preset).find("+confidence") != std::string::npos;
    TemporalResolver full(s), first(s), second(s);
    const std::string path = ::testing::TempDir() + "taa_state_" + preset + ".bin";
    for (int t = 0; t < 3; ++t) {
      Frame f = render(sc, t);
      EXPECT_EQ(full.process(f), first.process(f));
    }
    first.save_state(path);
    second.load_state(path);
    EXPECT_EQ(second.frames_processed(), 3);
    for (int t = 3; t < 7; ++t) {
      Frame f = render(sc, t);
      EXPECT_EQ(full.process(f), second.process(f)) << preset << " frame " << t;
    }
    std::filesystem::remove(path);
  }
}

TEST(TaaResolver, CorruptedOrForeignStateIsAnInputError) {
  SceneSpec sc;
  TemporalResolver r(preset_afterimage());
  r.process(render(sc, 0));
  r.process(render(sc, 1));
  const std::string path = ::testing::TempDir() + "taa_state_corrupt.bin";
  r.save_state(path);
  std::vector<char> good;
  {
    std::ifstream in(path, std::ios::binary);
    good.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  auto write = [&](const std::vector<char>& bytes) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), std::streamsize(bytes.size()));
  };
  TemporalResolver q(preset_afterimage());
  std::vector<char> bad = good;
  bad[good.size() / 2] ^= 0x10;  // payload bit flip
  write(bad);
  EXPECT_THROW(q.load_state(path), InputError);
  bad = good;
  bad.resize(good.size() - 100);  // truncated
  write(bad);
  EXPECT_THROW(q.load_state(path), InputError);
  bad = good;
  bad[0] = 'X';  // magic
  write(bad);
  EXPECT_THROW(q.load_state(path), InputError);
  write(std::vector<char>(10, 'a'));
  EXPECT_THROW(q.load_state(path), InputError);
  EXPECT_THROW(q.load_state(path + ".does-not-exist"), InputError);
  try {
    write(std::vector<char>(10, 'a'));
    q.load_state(path);
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos);  // names the file
  }
  // Well-formed state files that are not this resolver's: other kind, newer version, a
  // section missing or of the wrong size.
  auto expect_rejected = [&](const char* kind, uint32_t version, auto&& fill, const char* why) {
    StateWriter w(kind, version);
    fill(w);
    w.save(path);
    try {
      q.load_state(path);
      ADD_FAILURE() << "accepted: " << why;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  auto header = [](StateWriter& w) {
    w.put_i64("width", 4);
    w.put_i64("height", 2);
    w.put_i64("valid", 1);
    w.put_i64("frames", 3);
  };
  expect_rejected("ssaa", 1, header, "it holds 'ssaa' state");
  expect_rejected("taa", 2, header, "taa version 2");
  expect_rejected("taa", 1, header, "missing section 'history'");
  expect_rejected(
      "taa", 1,
      [&](StateWriter& w) {
        header(w);
        w.put("history", ImageF(4, 2, 3));
        w.put("count", ImageF(4, 1, 1));
      },
      "section 'count' holds 4 f32, expected 8");
  expect_rejected(
      "taa", 1,
      [&](StateWriter& w) {
        w.put_i64("width", 1 << 20);
        w.put_i64("height", 1 << 20);
        w.put_i64("valid", 1);
        w.put_i64("frames", 3);
      },
      "impossible size");
  // The largest size allowed, with tiny sections: rejected before anything is allocated
  // (a 65536 x 65536 history would be 48 GiB; found by tests/fuzz/fuzz_state_loader).
  expect_rejected(
      "taa", 1,
      [&](StateWriter& w) {
        w.put_i64("width", 1 << 16);
        w.put_i64("height", 1 << 16);
        w.put_i64("valid", 1);
        w.put_i64("frames", 3);
        w.put("history", ImageF(1, 1, 3));
        w.put("count", ImageF(1, 1, 1));
      },
      "section 'history' holds 3 f32, expected 12884901888");
  EXPECT_FALSE(q.has_history());  // failed loads leave the resolver untouched
  write(good);
  q.load_state(path);
  EXPECT_TRUE(q.has_history());
  EXPECT_THROW(r.save_state(path + "/under-a-file.bin"), OutputError);  // cannot be written
  std::filesystem::remove(path);
}

TEST(TaaResolver, MismatchedChannelShapesAreInputErrors) {
  Frame f = Frame::allocate(37, 23);
  f.depth = ImageF(36, 23, 1);
  TemporalResolver r;
  EXPECT_THROW(r.process(f), InputError);
  Frame g;
  EXPECT_THROW(r.process(g), InputError);
  // Optional channels may be absent.
  Frame c;
  c.color = ImageF(37, 23, 3, 0.5f);
  TemporalResolver all(preset_afterimage());
  EXPECT_TRUE(all_finite(all.process(c)));
  EXPECT_TRUE(all_finite(all.process(c)));
}

// A bright square moving over a dark background, exact motion vectors: pixels uncovered at
// frame t (inside the square at t - 1, well outside it at t) must show the background by
// t + 4 with the default preset; without rectification the trail persists.
TEST(TaaResolver, MovingEdgeGhostingDisappearsWithDefaultPreset) {
  SceneSpec sc;
  sc.w = 61;
  sc.h = 37;
  sc.pan = {0, 0};
  sc.sq_pos = {4, 12};
  sc.sq_vel = {2, 0};
  sc.sq_size = 12;
  sc.sq_value = 1.0f;
  sc.textured = false;
  sc.bg_value = 0.05f;
  const float contrast = 1.0f * 0.6f - 0.05f * 0.8f;  // channel 0
  auto error_on_disoccluded = [&](const TaaSettings& s, int t_dis, int t_check) {
    TemporalResolver r(s);
    ImageF out;
    for (int t = 0; t <= t_check; ++t) out = r.process(render(sc, t));
    // Square at t: [x0, x0 + size) with x0 = 4 + 2t. Uncovered at t_dis: pixel centers in
    // [x0(t_dis - 1), x0(t_dis)); by t_check the square is 8 px further right.
    const float prev_x0 = 4.0f + 2.0f * float(t_dis - 1), cur_x0 = 4.0f + 2.0f * float(t_dis);
    float worst = 0;
    int n = 0;
    for (int y = 14; y <= 21; ++y)  // rows well inside the square's vertical extent
      for (int x = 0; x < sc.w; ++x) {
        float cx = float(x) + 0.5f;
        if (cx >= prev_x0 && cx < cur_x0) {
          worst = std::max(worst, std::abs(out.at(x, y, 0) - 0.05f * 0.8f));
          ++n;
        }
      }
    EXPECT_GT(n, 0);
    return worst / contrast;
  };
  for (int t_dis : {6, 8}) {
    EXPECT_GT(error_on_disoccluded(preset_none(), t_dis, t_dis + 4), 0.3f) << "none ghosts";
    for (const char* p : {"afterimage", "ue4", "inside", "hdrp", "variance", "uncharted4"})
      EXPECT_LT(error_on_disoccluded(make_preset(p), t_dis, t_dis + 4), 0.1f) << p;
  }
}

// last_traffic (the bench's floor, DESIGN.md §5): a frame writes every plane of the state it
// keeps (history 3, count 1, with confidence moments 7 + spreads 2, the previous depth / motion /
// id its rejection tests read: depth and id in the default, which has no velocity test) and
// the returned color (3); it reads the channels it uses and, with history, the state planes it
// streams.
TEST(TaaResolver, LastTrafficCountsTheStateAndChannels) {
  SceneSpec sc;
  const int confidence_state = kLumaMomentPlanes + kSpreadPlanes;
  {
    TemporalResolver r(preset_afterimage());
    EXPECT_EQ(r.last_traffic().read + r.last_traffic().write, 0);  // no frame yet
    r.process(render(sc, 0));
    // No history: color 3, depth 1, motion 2, id 1 read.
    EXPECT_EQ(r.last_traffic().read, 7);
    const int state = 3 + 1 + confidence_state + 1 + 1;
    EXPECT_EQ(r.last_traffic().write, state + 3);
    r.process(render(sc, 1));
    // + history 3, count 1, moments and spreads, previous depth and id.
    EXPECT_EQ(r.last_traffic().read, 7 + 4 + confidence_state + 2);
    EXPECT_EQ(r.last_traffic().write, state + 3);
  }
  {
    // Without ids: no id read, no previous id kept or read.
    TemporalResolver r(preset_afterimage());
    for (int t = 0; t < 2; ++t) {
      Frame f = render(sc, t);
      f.id = ImageU32();
      r.process(f);
    }
    EXPECT_EQ(r.last_traffic().read, 6 + 4 + confidence_state + 1);
    EXPECT_EQ(r.last_traffic().write, 3 + 1 + confidence_state + 1 + 3);
  }
  {
    // `none`: no confidence, no sample count, no rejection: the history and the returned color.
    TemporalResolver r(preset_none());
    for (int t = 0; t < 2; ++t) r.process(render(sc, t));
    EXPECT_EQ(r.last_traffic().read, 7 + 3);
    EXPECT_EQ(r.last_traffic().write, 3 + 1 + 3);
  }
}
