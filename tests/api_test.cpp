// The public C++ API (include/afterimage/afterimage.hpp), used as a program would: only the
// public header, against the CLI's outputs on the same files, bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "afterimage/afterimage.hpp"
#include "cli_util.h"
#include "test_util.h"

namespace {

namespace fs = std::filesystem;
using afterimage::BufferView;
using afterimage::DataType;

// A temporary folder of the test that makes it, removed when every test passed.
struct TempDir {
  fs::path path;
  afterimage::test::RemoveIfPassed remove;
  explicit TempDir(const std::string& tag)
      : path(afterimage::test::fresh_temp_dir("api_test_" + tag)), remove{path} {}
  std::string operator/(const std::string& s) const { return (path / s).string(); }
};

void cli(const std::string& args) {
  const auto r = afterimage::test::run(args);
  ASSERT_EQ(r.code, 0) << args << "\n" << r.err;
}

// The color planes of frame i of a sequence folder, as read through the API.
std::vector<float> color_of(const std::string& dir, size_t i) {
  afterimage::FrameReader reader(dir);
  const afterimage::FrameData f = reader.read(i);
  const BufferView c = f.channel("color");
  const float* p = static_cast<const float*>(c.data);
  return std::vector<float>(p, p + size_t(c.width) * c.height * 3);
}

// A shared rendered sequence (rendered once for the suite).
const std::string& motion_sequence() {
  static const std::string dir = [] {
    const std::string d = afterimage::test::fresh_temp_dir("api_test_motion").string();
    const auto r = afterimage::test::run("render --scene motion --frames 6 --size 64x36 --out " +
                                         d + " --motion-next");
    EXPECT_EQ(r.code, 0) << r.err;
    return d;
  }();
  return dir;
}

// Runs `method` over every frame of `dir` into interleaved RGBA f32 outputs.
std::vector<std::vector<float>> run_rgba(afterimage::Method& method, const std::string& dir) {
  afterimage::FrameReader reader(dir);
  std::vector<std::vector<float>> outs;
  for (size_t i = 0; i < reader.size(); ++i) {
    const afterimage::FrameData f = reader.read(i);
    const auto [w, h] = method.output_size(f.width(), f.height());
    std::vector<float> out(size_t(w) * h * 4, -1.0f);
    method.process(f.input(), BufferView::interleaved(out.data(), w, h, 4));
    outs.push_back(std::move(out));
  }
  return outs;
}

// The RGB planes of an interleaved RGBA buffer.
std::vector<float> planes_of_rgba(const std::vector<float>& rgba) {
  const size_t n = rgba.size() / 4;
  std::vector<float> p(n * 3);
  for (size_t c = 0; c < 3; ++c)
    for (size_t i = 0; i < n; ++i) p[c * n + i] = rgba[i * 4 + c];
  return p;
}

TEST(Api, VersionIsTheHeadersAndTheClis) {
  EXPECT_STREQ(afterimage::version(), AFTERIMAGE_VERSION_STRING);
  const auto r = afterimage::test::run("--version");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out.rfind(std::string("afterimage ") + AFTERIMAGE_VERSION_STRING, 0), 0u) << r.out;
  EXPECT_NE(r.out.find(afterimage::simd_target()), std::string::npos) << r.out;
}

TEST(Api, RegistriesListTheMethodsStagesAndChannels) {
  const auto m = afterimage::method_names();
  for (const char* name : {"taa:afterimage", "taa:hdrp", "taau:quality", "svgf:afterimage"})
    EXPECT_NE(std::find(m.begin(), m.end(), name), m.end()) << name;
  const auto s = afterimage::post_stage_names();
  EXPECT_NE(std::find(s.begin(), s.end(), "bloom"), s.end());
  const auto c = afterimage::channel_names();
  EXPECT_EQ(c.front(), "color");
  EXPECT_NE(afterimage::describe_settings("taa:hdrp").find("alpha"), std::string::npos);
}

// Each method through the API gives the bits `afterimage resolve` / `denoise` / `run` writes.
TEST(Api, MethodsGiveTheClisBitsFromTheCallersBuffers) {
  const std::string& in = motion_sequence();
  TempDir t("bits");
  struct Case {
    std::string spec, cli;
  };
  const std::vector<Case> cases = {
      {"taa:hdrp", "resolve --preset hdrp"},
      {"taa:afterimage+alpha_min=0.1", "resolve --set alpha_min=0.1"},
      {"taau:quality", "resolve --upscale quality"},
      {"taa,bloom,tonemap", "run --pipeline taa,bloom,tonemap"},
      {"motion_blur", "run --pipeline motion_blur"},
  };
  for (size_t k = 0; k < cases.size(); ++k) {
    const std::string out = t / ("cli" + std::to_string(k));
    cli(cases[k].cli + " --in " + in + " --out " + out);
    afterimage::Method method(cases[k].spec);
    const auto outs = run_rgba(method, in);
    for (size_t i = 0; i < outs.size(); ++i) {
      EXPECT_EQ(planes_of_rgba(outs[i]), color_of(out, i)) << cases[k].spec << " frame " << i;
      for (size_t p = 3; p < outs[i].size(); p += 4) ASSERT_EQ(outs[i][p], 1.0f);
    }
  }
}

// Half bits of x >= 0 that half represents exactly (a multiple of 2^-24 below 65504).
uint16_t exact_half(float x) {
  if (x == 0.0f) return 0;
  int e;
  const float frac = std::frexp(x, &e);                 // x = frac * 2^e, frac in [0.5, 1)
  if (e - 1 < -14) return uint16_t(std::ldexp(x, 24));  // subnormal
  return uint16_t(((e - 1 + 15) << 10) | int(std::ldexp(frac * 2.0f - 1.0f, 10)));
}

// One sequence handed as planar f32, as interleaved RGBA f32 in rows padded to 80 pixels, and as
// interleaved f16: the same values give the same output bits.
TEST(Api, PlanarPaddedAndHalfBuffersGiveTheSameBits) {
  const std::string& in = motion_sequence();
  afterimage::FrameReader reader(in);
  afterimage::Method planar("taa:afterimage"), padded("taa:afterimage"), half("taa:afterimage");
  for (size_t i = 0; i < reader.size(); ++i) {
    const afterimage::FrameData f = reader.read(i);
    const int w = f.width(), h = f.height();
    const size_t n = size_t(w) * h;
    const auto* src = static_cast<const float*>(f.channel("color").data);
    // Values half holds exactly: multiples of 2^-8 below 2048.
    std::vector<float> q(n * 3);
    for (size_t k = 0; k < q.size(); ++k)
      q[k] = std::min(std::ldexp(std::round(std::ldexp(std::max(src[k], 0.0f), 8)), -8), 2047.0f);
    afterimage::FrameInput input = f.input();
    input.color = BufferView::planar(q.data(), w, h, 3);
    std::vector<float> out_planar(n * 3);
    planar.process(input, BufferView::planar(out_planar.data(), w, h, 3));

    std::vector<float> rows(size_t(80) * 4 * h, 0.0f);
    std::vector<uint16_t> h16(n * 4);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 4; ++c) {
          const float v = c < 3 ? q[size_t(c) * n + size_t(y) * w + x] : 1.0f;
          rows[(size_t(y) * 80 + x) * 4 + c] = v;
          h16[(size_t(y) * w + x) * 4 + c] = exact_half(v);
        }
    BufferView v = BufferView::interleaved(rows.data(), w, h, 4);
    v.row_stride = 80 * 4 * sizeof(float);
    input.color = v;
    std::vector<float> out_padded(n * 3);
    padded.process(input, BufferView::interleaved(out_padded.data(), w, h, 3));
    input.color = BufferView::interleaved(h16.data(), w, h, 4, DataType::f16);
    std::vector<float> out_half(n * 3);
    half.process(input, BufferView::interleaved(out_half.data(), w, h, 3));

    EXPECT_EQ(out_padded, out_half) << "frame " << i;
    for (size_t p = 0; p < n; ++p)
      for (size_t c = 0; c < 3; ++c)
        ASSERT_EQ(out_planar[c * n + p], out_padded[p * 3 + c]) << "frame " << i << " pixel " << p;
  }
}

TEST(Api, StateContinuesBitForBit) {
  const std::string& in = motion_sequence();
  TempDir t("state");
  afterimage::Method whole("taa:afterimage");
  const auto all = run_rgba(whole, in);
  afterimage::FrameReader reader(in);
  afterimage::Method first("taa:afterimage");
  std::vector<float> out(size_t(64) * 36 * 4);
  for (size_t i = 0; i < 3; ++i)
    first.process(reader.read(i).input(), BufferView::interleaved(out.data(), 64, 36, 4));
  first.save_state(t / "taa.state");
  afterimage::Method second("taa:afterimage");
  second.load_state(t / "taa.state");
  for (size_t i = 3; i < reader.size(); ++i) {
    second.process(reader.read(i).input(), BufferView::interleaved(out.data(), 64, 36, 4));
    EXPECT_EQ(out, all[i]) << "frame " << i;
  }
}

TEST(Api, RunFilesWritesWhatTheCliWrites) {
  const std::string& in = motion_sequence();
  TempDir t("files");
  cli("run --pipeline taa,tonemap --in " + in + " --out " + t / "cli");
  size_t progress = 0;
  const afterimage::RunSummary s =
      afterimage::run_files("taa,tonemap", {}, in, t / "api", {},
                            [&](size_t done, size_t, const std::string&) { progress = done; });
  EXPECT_EQ(s.frames, 6u);
  EXPECT_EQ(progress, 6u);
  for (size_t i = 0; i < 6; ++i) EXPECT_EQ(color_of(t / "api", i), color_of(t / "cli", i));
  // Extrapolation, files to files and in a frame loop, against the CLI's.
  cli("extrapolate --skip 1 --in " + in + " --out " + t / "xcli");
  afterimage::ExtrapolateOptions xo;
  const auto xs = afterimage::extrapolate_files(in, t / "xapi", xo);
  EXPECT_EQ(xs.synthesized, 3u);
  afterimage::FrameReader reader(in);
  afterimage::Extrapolator x;
  for (size_t i = 0; i < 6; i += 2) {
    EXPECT_EQ(color_of(t / "xapi", i + 1), color_of(t / "xcli", i + 1));
    x.set_source(reader.read(i).input());
    std::vector<float> planar(size_t(64) * 36 * 3);
    const double holes =
        x.synthesize(reader.read(i + 1).camera(), BufferView::planar(planar.data(), 64, 36, 3));
    EXPECT_GE(holes, 0.0);
    EXPECT_LT(holes, 0.5);
    EXPECT_EQ(planar, color_of(t / "xcli", i + 1)) << "frame " << i + 1;
  }
  // Scores, as `afterimage eval` gives them.
  afterimage::EvaluateOptions eo;
  eo.warmup = 2;
  const auto scores = afterimage::evaluate({t / "api"}, in, eo);
  ASSERT_EQ(scores.size(), 1u);
  EXPECT_EQ(scores[0].frames, 6);
  EXPECT_EQ(scores[0].frames_measured, 4);
  EXPECT_GT(scores[0].psnr, 10.0);
}

TEST(Api, MetricsAreCompares) {
  const std::string& in = motion_sequence();
  TempDir t("metrics");
  const std::vector<float> a = color_of(in, 2), b = color_of(in, 3);
  const BufferView va = BufferView::planar(a.data(), 64, 36, 3);
  const BufferView vb = BufferView::planar(b.data(), 64, 36, 3);
  const afterimage::PairScores s = afterimage::compare(va, vb);
  EXPECT_STREQ(s.flip_kind, "HDR-FLIP");
  EXPECT_EQ(s.psnr, afterimage::psnr(va, vb));
  EXPECT_EQ(s.ssim, afterimage::ssim(va, vb));
  EXPECT_EQ(s.flip, afterimage::hdr_flip(va, vb));
  // `afterimage compare` on the same two files prints the same HDR-FLIP mean.
  afterimage::FrameReader reader(in);
  const auto r = afterimage::test::run("compare " + reader.path(2) + " " + reader.path(3));
  ASSERT_EQ(r.code, 0) << r.err;
  char flip[64];
  std::snprintf(flip, sizeof flip, "HDR-FLIP mean        %.6f", s.flip);
  EXPECT_NE(r.out.find(flip), std::string::npos) << flip << " in\n" << r.out;
  EXPECT_GT(s.flip, 0.0);
  const afterimage::PairScores same = afterimage::compare(va, va);
  EXPECT_TRUE(std::isinf(same.psnr));
  EXPECT_EQ(same.flip, 0.0);
  EXPECT_EQ(afterimage::temporal_error(va, vb, va, vb), 0.0);
  EXPECT_GT(afterimage::temporal_error(va, va, va, vb), 0.0);
  EXPECT_GT(afterimage::ldr_flip(va, vb), 0.0);
}

// What a caller gets wrong is a one-line exception of the right type, never a crash.
TEST(Api, MistakesAreOneLineExceptions) {
  const std::string& in = motion_sequence();
  const auto message = [](const std::function<void()>& fn) {
    return afterimage::test::error_of<afterimage::Error>(fn);
  };
  EXPECT_THROW(afterimage::Method("taa:nope"), afterimage::SettingsError);
  EXPECT_NE(message([] { afterimage::Method("taa:nope"); }).find("nope"), std::string::npos);
  EXPECT_THROW(afterimage::Method("taa:hdrp", {"alpha=7"}), afterimage::SettingsError);
  EXPECT_THROW(afterimage::Method("bloom", {"tonemap.exposure=2"}), afterimage::SettingsError);
  afterimage::FrameReader reader(in);
  const afterimage::FrameData f = reader.read(0);
  std::vector<float> out(size_t(64) * 36 * 3);
  const BufferView o = BufferView::planar(out.data(), 64, 36, 3);
  afterimage::Method taa("taa:afterimage");
  afterimage::FrameInput no_depth = f.input();
  no_depth.depth = {};
  const std::string m = message([&] { taa.process(no_depth, o); });
  EXPECT_NE(m.find("depth"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  EXPECT_THROW(taa.process(f.input(), BufferView::planar(out.data(), 32, 36, 3)),
               afterimage::InputError);
  afterimage::FrameInput bad = f.input();
  bad.motion_convention = "sideways";
  EXPECT_THROW(taa.process(bad, o), afterimage::SettingsError);
  bad.motion = {};  // named wrong even where there is no motion to convert
  EXPECT_NE(message([&] { taa.process(bad, o); }).find("sideways"), std::string::npos);
  bad = f.input();
  bad.color.data = nullptr;
  EXPECT_THROW(taa.process(bad, o), afterimage::InputError);
  taa.process(f.input(), o);
  std::vector<float> small(size_t(32) * 18 * 3);
  std::vector<float> small_color(size_t(32) * 18 * 3, 0.5f), small_depth(size_t(32) * 18, 5.0f),
      small_motion(size_t(32) * 18 * 2, 0.0f);
  afterimage::FrameInput other;
  other.color = BufferView::planar(small_color.data(), 32, 18, 3);
  other.depth = BufferView::planar(small_depth.data(), 32, 18, 1);
  other.motion = BufferView::planar(small_motion.data(), 32, 18, 2);
  const BufferView so = BufferView::planar(small.data(), 32, 18, 3);
  EXPECT_NE(message([&] { taa.process(other, so); }).find("reset()"), std::string::npos);
  taa.reset();
  EXPECT_NO_THROW(taa.process(other, so));
  EXPECT_THROW(afterimage::FrameReader("/nonexistent/afterimage/dir"), afterimage::Error);
  EXPECT_THROW(afterimage::run_files("taa", {}, in, in), afterimage::InputError);
}

}  // namespace
