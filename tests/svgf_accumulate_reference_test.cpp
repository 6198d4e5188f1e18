// SvgfDenoiser's reprojection and accumulation stated plainly (svgf/reference.h
// reproject_and_accumulate, what --simd off runs) against its lane blocks (denoiser.cpp
// accumulate_block), bit for bit, over whole sequences: a camera pan with sub-pixel motion and
// jitter, a moving square (disocclusions), an object that appears, a frame with NaN / Inf /
// negative inputs, a camera cut and a state file whose history holds NaN and Inf; both presets,
// every signal split and each history option the pass reads. Lanes on 2 threads, plain on 1
// and 3.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/state_file.h"
#include "svgf/denoiser.h"
#include "svgf/filter.h"
#include "svgf/settings.h"
#include "test_util.h"

namespace afterimage::svgf {
namespace {

// The optional channels a frame of acc_ref_frame carries.
struct AccRefChannels {
  bool emission = false;
  bool direct_indirect = false;
  bool diffuse_specular = false;
  bool gradient = false;        // A-SVGF gradient samples
  bool depth_gradient = false;  // the channel instead of the gradient of the depth
};

// Frame t of a w x h scene: a background (depth and normal varying across it, so that the
// consistency tests reject some taps) panned by (0.37, -0.23) px per frame, a square moving by
// (3, 1) px per frame, a disc appearing at frame 3, jitter changing every frame, noise with a
// few fireflies and albedo below eps. Frame 4 carries bad inputs, frame 6 is a camera cut.
Frame acc_ref_frame(int w, int h, int t, const AccRefChannels& ch) {
  Frame f = Frame::allocate(w, h);
  f.index = t;
  f.time = t / 30.0;
  f.jitter = {0.3 * std::sin(1.7 * t), -0.25 * std::cos(2.3 * t)};
  f.camera_cut = t == 6;
  for (Channel c : {Channel::emission, Channel::direct, Channel::indirect, Channel::diffuse,
                    Channel::specular, Channel::gradient})
    if ((c == Channel::emission && ch.emission) ||
        ((c == Channel::direct || c == Channel::indirect) && ch.direct_indirect) ||
        ((c == Channel::diffuse || c == Channel::specular) && ch.diffuse_specular) ||
        (c == Channel::gradient && ch.gradient))
      f.allocate_channel(c);
  std::mt19937 rng(500 + unsigned(t));
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float vx = 0.37f, vy = -0.23f;
  const int sx = 5 + 3 * t, sy = 4 + t, side = 10;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float cu = float(x) + 0.5f - vx * float(t), cv = float(y) + 0.5f - vy * float(t);
      const bool square = x >= sx && x < sx + side && y >= sy && y < sy + side;
      const bool disc = t >= 3 && (x - 40) * (x - 40) + (y - 17) * (y - 17) < 20;
      float z, n[3], base, albedo, mx, my;
      uint32_t id;
      if (square) {
        z = 2.0f + 0.01f * float(x - sx);
        n[0] = 0.1f, n[1] = 0.0f, n[2] = 0.995f;
        base = 2.0f, albedo = 0.8f, id = 2;
        mx = t > 0 ? -3.0f : 0.0f, my = t > 0 ? -1.0f : 0.0f;
      } else if (disc) {
        z = 3.5f;
        n[0] = 0.0f, n[1] = 0.3f, n[2] = 0.954f;
        base = 4.0f, albedo = 0.3f, id = 3, mx = 0.0f, my = 0.0f;
      } else {
        z = 6.0f + 0.05f * cu + 0.02f * cv;
        const float a = 0.4f * std::sin(0.3f * cu), b = 0.3f * std::cos(0.2f * cv);
        const float len = std::sqrt(a * a + b * b + 1.0f);
        n[0] = a / len, n[1] = b / len, n[2] = 1.0f / len;
        base = 0.5f + 0.3f * std::sin(0.2f * cu) * std::cos(0.15f * cv);
        albedo = u(rng) < 0.03f ? 1e-4f : 0.5f + 0.2f * std::sin(0.5f * cv);
        id = 1, mx = -vx, my = -vy;
      }
      const float spike = u(rng) < 0.01f ? 50.0f : 1.0f;
      f.depth.at(x, y, 0) = z;
      f.id.at(x, y, 0) = id;
      f.motion.at(x, y, 0) = mx;
      f.motion.at(x, y, 1) = my;
      for (int c = 0; c < 3; ++c) {
        f.normal.at(x, y, c) = n[c];
        f.albedo.at(x, y, c) = albedo * (c == 1 ? 0.9f : 1.0f);
        const float radiance = base * (1.0f + 0.2f * float(c)) * (0.6f + 0.8f * u(rng)) * spike;
        const float e = ch.emission && (x + y) % 7 == 0 ? 0.1f * base : 0.0f;
        f.color.at(x, y, c) = radiance + e;
        if (ch.emission) f.emission.at(x, y, c) = e;
        if (ch.direct_indirect) {
          f.direct.at(x, y, c) = 0.6f * radiance;
          f.indirect.at(x, y, c) = 0.4f * radiance;
        }
        if (ch.diffuse_specular) {
          f.diffuse.at(x, y, c) = 0.7f * radiance / std::max(f.albedo.at(x, y, c), 1e-3f);
          f.specular.at(x, y, c) = 0.3f * radiance;
        }
      }
    }
  if (ch.gradient)
    for (int y = 1; y < h; y += 3)
      for (int x = 1; x < w; x += 3) {
        const float delta = 0.4f * (u(rng) - 0.5f);
        f.gradient.at(x, y, 0) = delta;
        f.gradient.at(x, y, 1) = 1.0f + u(rng);
        f.gradient.at(x, y, 2) = u(rng) < 0.9f ? 1.0f : 0.0f;
      }
  if (ch.depth_gradient) {
    f.allocate_channel(Channel::depth_gradient);
    depth_gradient(f.depth, f.depth_gradient);
  }
  if (t == 4) {
    // Placed where the image has them (the small sizes have fewer).
    auto put = [&](ImageF& img, int x, int y, int c, float v) {
      if (x < w && y < h) img.at(x, y, c) = v;
    };
    put(f.color, 7, 3, 1, NAN);
    put(f.color, 20, 12, 0, INFINITY);
    put(f.color, w - 1, h - 1, 2, -0.5f);
    put(f.albedo, 30, 20, 2, NAN);
    put(f.depth, 11, 17, 0, NAN);
    put(f.depth, 2, 2, 0, -1.0f);
    put(f.normal, 33, 9, 0, INFINITY);
    put(f.motion, 14, 14, 0, NAN);
    put(f.motion, 1, 1, 1, 1e30f);
    if (ch.emission) put(f.emission, 3, 3, 0, -INFINITY);
    if (ch.direct_indirect) put(f.direct, 12, 5, 1, NAN);
    if (ch.diffuse_specular) put(f.specular, 44, 8, 0, -2.0f);
    if (ch.gradient) put(f.gradient, 10, 10, 0, NAN);
    if (ch.depth_gradient) put(f.depth_gradient, 9, 9, 1, NAN);
  }
  return f;
}

std::vector<char> acc_ref_file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// `in` rewritten to `out` with NaN and Inf in the history's color, moments, length and fast
// history (a corrupted state file): the reprojection must drop them wherever a tap reads them.
void acc_ref_corrupt_state(const std::string& in, const std::string& out) {
  const StateReader rd(in, "svgf", 1);
  StateWriter wr("svgf", 1);
  for (const StateReader::Section& sec : rd.sections()) {
    std::vector<unsigned char> bytes(sec.bytes, sec.bytes + sec.count * elem_size(sec.type));
    const std::string& name = sec.name;
    if (name == "history" || name == "moments" || name == "length" || name == "fast_history") {
      float* v = reinterpret_cast<float*>(bytes.data());
      const size_t n = sec.count;
      v[(n / 3 + 17) % n] = NAN;
      v[(n / 2 + 5) % n] = INFINITY;
      v[(2 * n / 3 + 40) % n] = -INFINITY;
    }
    wr.put_raw(name, sec.type, sec.count, bytes.data());
  }
  wr.save(out);
}

// Runs `frames` frames of the scene through SvgfDenoiser with settings s on lanes (2 threads)
// and plainly (1 and 3 threads), comparing after every frame each output and the state file;
// the history is corrupted before frame 3.
void acc_ref_expect_same_sequences(const SvgfSettings& s, const AccRefChannels& ch,
                                   const std::string& what, int w = 53, int h = 29,
                                   int frames = 8) {
  const Exec execs[3] = {Exec{2, true}, Exec{1, false}, Exec{3, false}};
  std::vector<std::unique_ptr<SvgfDenoiser>> dens;
  for (const Exec& ex : execs) dens.push_back(std::make_unique<SvgfDenoiser>(s, ex));
  const auto dir = test::fresh_temp_dir("svgf_acc_ref");
  for (int t = 0; t < frames; ++t) {
    if (t == 3) {
      const std::string saved = (dir / "saved.state").string();
      const std::string bad = (dir / "corrupt.state").string();
      dens[0]->save_state(saved);
      acc_ref_corrupt_state(saved, bad);
      for (auto& d : dens) d->load_state(bad);
    }
    const Frame f = acc_ref_frame(w, h, t, ch);
    std::vector<Frame> out;
    for (auto& d : dens) out.push_back(d->process(f));
    for (size_t i = 1; i < dens.size(); ++i) {
      const std::string run = what + ", frame " + std::to_string(t) + ", threads " +
                              std::to_string(execs[i].threads) + " simd off";
      const SvgfDenoiser &a = *dens[0], &b = *dens[i];
      test::expect_same_bits(out[i].color, out[0].color, run + ": output");
      test::expect_same_bits(b.history_length(), a.history_length(), run + ": history length");
      test::expect_same_bits(b.moments(), a.moments(), run + ": moments");
      test::expect_same_bits(b.variance(), a.variance(), run + ": variance");
      test::expect_same_bits(b.color_history(), a.color_history(), run + ": color history");
      test::expect_same_bits(b.fast_history(), a.fast_history(), run + ": fast history");
      test::expect_same_bits(b.gradient_lambda(), a.gradient_lambda(), run + ": lambda");
      ASSERT_EQ(out[i].has(Channel::temporal_change), out[0].has(Channel::temporal_change));
      if (out[0].has(Channel::temporal_change))
        test::expect_same_bits(out[i].temporal_change, out[0].temporal_change, run + ": change");
      if (testing::Test::HasFatalFailure()) return;
      // The state: history, moments, length, the kept G-buffer (depth, normal, ids).
      const std::string pa = (dir / "a.state").string(), pb = (dir / "b.state").string();
      a.save_state(pa);
      b.save_state(pb);
      ASSERT_TRUE(acc_ref_file_bytes(pa) == acc_ref_file_bytes(pb)) << run << ": state file";
    }
  }
}

TEST(SvgfAccumulateReference, PlainPassEqualsTheLanesForBothPresets) {
  for (const char* preset : {"svgf-paper", "afterimage"}) {
    acc_ref_expect_same_sequences(make_preset(preset), {}, preset);
    // Odd sizes: every pixel a 1-lane tail, or one block and a tail per row.
    acc_ref_expect_same_sequences(make_preset(preset), {}, std::string(preset) + " 5x4", 5, 4, 5);
    acc_ref_expect_same_sequences(make_preset(preset), {}, std::string(preset) + " 11x7", 11, 7, 5);
  }
}

TEST(SvgfAccumulateReference, PlainPassEqualsTheLanesForEverySplit) {
  for (const char* preset : {"svgf-paper", "afterimage"}) {
    AccRefChannels emission;
    emission.emission = true;
    acc_ref_expect_same_sequences(make_preset(preset), emission,
                                  std::string(preset) + " combined with emission");
    AccRefChannels di = emission;
    di.direct_indirect = true;
    acc_ref_expect_same_sequences(make_preset(preset), di,
                                  std::string(preset) + " direct_indirect");
    AccRefChannels ds;
    ds.diffuse_specular = true;
    ds.depth_gradient = true;
    acc_ref_expect_same_sequences(make_preset(preset), ds,
                                  std::string(preset) + " diffuse_specular");
  }
}

TEST(SvgfAccumulateReference, PlainPassEqualsTheLanesWithEveryHistoryOption) {
  AccRefChannels gradient;
  gradient.gradient = true;
  gradient.emission = true;
  for (const char* preset : {"svgf-paper", "afterimage"}) {
    const SvgfSettings base = make_preset(preset);
    struct Variant {
      const char* name;
      void (*apply)(SvgfSettings&);
    };
    const Variant variants[] = {
        {"fast_history_clamp",
         [](SvgfSettings& s) {
           s.fast_history_clamp = true;
           s.fast_alpha_min = 0.3f;
           s.fast_clamp_radius = 2;
         }},
        {"temporal_gradient", [](SvgfSettings& s) { s.temporal_gradient = true; }},
        {"temporal_gradient keeping n",
         [](SvgfSettings& s) {
           s.temporal_gradient = true;
           s.gradient_shorten_history = false;
         }},
        {"gradient_relight",
         [](SvgfSettings& s) {
           s.temporal_gradient = true;
           s.gradient_relight = true;
           s.gradient_scale = 3.0f;
         }},
        {"firefly_rank", [](SvgfSettings& s) { s.firefly_rank = 2; }},
        {"seconds",
         [](SvgfSettings& s) {
           s.alpha_seconds = 0.1f;
           s.moments_alpha_seconds = 0.05f;
           s.history_cap_seconds = 0.1f;
         }},
        {"no id test, tight tests",
         [](SvgfSettings& s) {
           s.id_test = false;
           s.depth_tolerance = 0.001f;
           s.depth_slope = 0.5f;
           s.normal_cos = 0.99f;
           s.history_cap = 3;
         }},
        {"every option",
         [](SvgfSettings& s) {
           s.fast_history_clamp = true;
           s.temporal_gradient = true;
           s.gradient_relight = true;
           s.firefly_rank = 3;
           s.alpha_seconds = 0.2f;
         }},
    };
    for (const Variant& v : variants) {
      SvgfSettings s = base;
      v.apply(s);
      acc_ref_expect_same_sequences(s, gradient, std::string(preset) + " " + v.name);
      if (testing::Test::HasFatalFailure()) return;
    }
  }
}

}  // namespace
}  // namespace afterimage::svgf
