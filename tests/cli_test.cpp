// End-to-end tests of the `afterimage` command: the README's workflow on a tiny sequence, and
// bad input giving one clear line and a non-zero exit code without touching inputs.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <OpenImageIO/imageio.h>
#include "cli_util.h"

#include "core/color.h"
#include "io/io.h"
#include "test_util.h"

using namespace afterimage;
using test::CliRun;
using test::expect_one_line_error;
using test::run;
namespace fs = std::filesystem;

namespace {

class CliTest : public ::testing::Test {
 protected:
  static void TearDownTestSuite() { test::remove_if_passed(root_); }
  static void SetUpTestSuite() {
    root_ = test::fresh_temp_dir("cli_test");
    CliRun r = run("render --scene motion --frames 6 --size 48x32 --out " +
                   (root_ / "seq").string() + " --reference 16 --ssaa 4");
    ASSERT_EQ(r.code, 0) << r.err;
  }
  static fs::path root_;
};
fs::path CliTest::root_;

}  // namespace

TEST_F(CliTest, RenderWritesFramesReferencesAndSsaa) {
  for (int t = 0; t < 6; ++t) {
    EXPECT_TRUE(fs::exists(io::frame_path((root_ / "seq").string(), t)));
    EXPECT_TRUE(fs::exists(io::frame_path((root_ / "seq/reference").string(), t)));
    EXPECT_TRUE(fs::exists(io::frame_path((root_ / "seq/ssaa4").string(), t)));
  }
  CliRun r = run("info " + io::frame_path((root_ / "seq").string(), 3));
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("motion.X"), std::string::npos);
  EXPECT_NE(r.out.find("afterimage:projection"), std::string::npos);
}

TEST_F(CliTest, ResolveEvalAndCompareWork) {
  const std::string seq = (root_ / "seq").string(), out = (root_ / "taa").string();
  CliRun r = run("resolve --in " + seq + " --out " + out + " --preset afterimage");
  ASSERT_EQ(r.code, 0) << r.err;
  // --layout auto names its choice for our own files too: in the summary, not as a note.
  EXPECT_NE(r.out.find("(layout afterimage (recognised))"), std::string::npos) << r.out;
  EXPECT_EQ(r.err.find("layout"), std::string::npos) << r.err;
  // The default output is the resolved color (R G B) with the input's camera metadata.
  Frame in = io::read_frame(io::frame_path(seq, 4));
  Frame o = io::read_frame(io::frame_path(out, 4));
  EXPECT_TRUE(o.view == in.view);
  EXPECT_TRUE(o.projection == in.projection);
  EXPECT_EQ(o.jitter, in.jitter);
  EXPECT_EQ(o.index, in.index);
  EXPECT_FALSE(o.color == in.color);
  for (const ChannelInfo& c : kChannelTable)
    EXPECT_EQ(o.has(c.key), c.key == Channel::color) << c.name;
  {
    auto img = OIIO::ImageInput::open(io::frame_path(out, 4));
    ASSERT_TRUE(img);
    EXPECT_EQ(img->spec().nchannels, 3);
  }

  const std::string json = (root_ / "eval.json").string(), html = (root_ / "eval.html").string();
  r = run("eval --out " + out + " --out " + seq + "/ssaa4 --label taa --label ssaa4 --ref " + seq +
          "/reference --gbuffer " + seq + " --warmup 2 --json " + json + " --report " + html);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("taa"), std::string::npos);
  EXPECT_NE(r.out.find("(layout afterimage (recognised))"), std::string::npos) << r.out;
  auto j = nlohmann::json::parse(std::ifstream(json));
  ASSERT_EQ(j["methods"].size(), 2u);
  EXPECT_EQ(j["methods"][0]["label"], "taa");
  EXPECT_EQ(j["methods"][0]["frames"].size(), 6u);
  EXPECT_TRUE(j["methods"][1]["summary"]["psnr"].is_number());
  EXPECT_TRUE(fs::exists(html));

  r = run("compare " + io::frame_path(seq + "/reference", 5) + " " + io::frame_path(out, 5) +
          " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  auto c = nlohmann::json::parse(r.out);
  EXPECT_TRUE(c.contains("psnr"));
}

// The README's workflow: eval of a default (color-only) output without --gbuffer takes the
// ghosting masks from the reference frames, and says so.
TEST_F(CliTest, EvalOfColorOnlyOutputUsesTheReferenceGbuffer) {
  const std::string seq = (root_ / "seq").string(), out = (root_ / "taa_c").string(),
                    json = (root_ / "eval_c.json").string();
  ASSERT_EQ(run("resolve --in " + seq + " --out " + out).code, 0);
  CliRun r = run("eval --out " + out + " --ref " + seq + "/reference --warmup 1 --json " + json);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("uses the reference frames' G-buffer"), std::string::npos) << r.err;
  auto j = nlohmann::json::parse(std::ifstream(json));
  EXPECT_GT(j["methods"][0]["summary"]["ghosting"]["samples_by_age"][0].get<int>(), 0) << j.dump();
}

// --keep-gbuffer: the same color plus every input channel, bit-exact.
TEST_F(CliTest, KeepGbufferRoundTrips) {
  const std::string seq = (root_ / "seq").string(), out = (root_ / "taa_g").string(),
                    plain = (root_ / "taa_plain").string();
  ASSERT_EQ(run("resolve --in " + seq + " --out " + out + " --keep-gbuffer").code, 0);
  ASSERT_EQ(run("resolve --in " + seq + " --out " + plain).code, 0);
  for (int t = 0; t < 6; ++t) {
    const Frame in = io::read_frame(io::frame_path(seq, t));
    const Frame g = io::read_frame(io::frame_path(out, t), core_channels(), "test");
    const Frame p = io::read_frame(io::frame_path(plain, t));
    EXPECT_TRUE(g.color == p.color) << t;
    EXPECT_TRUE(g.depth == in.depth && g.normal == in.normal && g.albedo == in.albedo &&
                g.motion == in.motion && g.id == in.id)
        << t;
  }
}

// Reading, resolving and writing overlap by default; the files equal a one-frame-at-a-time
// run's (pixels and metadata; OpenImageIO stamps DateTime at write time).
TEST_F(CliTest, PipelinedOutputEqualsSequential) {
  const std::string seq = (root_ / "seq").string(), a = (root_ / "pipe").string(),
                    b = (root_ / "seq1").string();
  ASSERT_EQ(run("resolve --in " + seq + " --out " + a + " --keep-gbuffer").code, 0);
  ASSERT_EQ(
      run("--threads 1 resolve --in " + seq + " --out " + b + " --keep-gbuffer --sequential").code,
      0);
  for (int t = 0; t < 6; ++t) {
    const Frame fa = io::read_frame(io::frame_path(a, t)),
                fb = io::read_frame(io::frame_path(b, t));
    EXPECT_EQ(fa.color.data().size(), fb.color.data().size());
    EXPECT_EQ(std::memcmp(fa.color.data().data(), fb.color.data().data(),
                          fa.color.data().size() * sizeof(float)),
              0)
        << t;
    EXPECT_TRUE(fa.view == fb.view && fa.jitter == fb.jitter && fa.depth == fb.depth) << t;
  }
}

// PNG / JPEG outputs are display images: 8-bit sRGB of the tonemapped resolved color.
TEST_F(CliTest, PngOutputIsTheTonemappedColor) {
  const std::string seq = (root_ / "seq").string(), exr = (root_ / "png_ref").string(),
                    png = (root_ / "png").string(), jpg = (root_ / "jpg").string();
  ASSERT_EQ(run("resolve --in " + seq + " --out " + exr).code, 0);
  CliRun r = run("resolve --in " + seq + " --out " + png + " --out-format png --exposure 2");
  ASSERT_EQ(r.code, 0) << r.err;
  for (int t : {0, 5}) {
    const std::string p = (fs::path(png) / fmt::format("frame.{:04d}.png", t)).string();
    auto in = OIIO::ImageInput::open(p);
    ASSERT_TRUE(in) << p;
    const OIIO::ImageSpec spec = in->spec();
    EXPECT_EQ(spec.width, 48);
    EXPECT_EQ(spec.height, 32);
    EXPECT_EQ(spec.nchannels, 3);
    EXPECT_EQ(spec.format, OIIO::TypeDesc::UINT8);
    std::vector<uint8_t> px(size_t(48) * 32 * 3);
    ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, px.data()));
    const Frame lin = io::read_frame(io::frame_path(exr, t));
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 48; ++x)
        for (int c = 0; c < 3; ++c) {
          const float want = srgb_encode(tonemap_reinhard(lin.color.at(x, y, c), 2.0f)) * 255.0f;
          ASSERT_LE(std::abs(float(px[(size_t(y) * 48 + x) * 3 + c]) - want), 0.5f + 1e-3f)
              << x << "," << y << "," << c;
        }
  }
  r = run("resolve --in " + seq + " --out " + jpg + " --out-format jpg --tonemap clamp");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(fs::path(jpg) / "frame.0003.jpg"));
  // eval scores display images as display-referred: the PNG written at exposure 2 scores as
  // the linear output does at eval --exposure 2, up to its 8-bit rounding (a PNG scored at
  // another exposure, or the clamp tonemap's JPEG, would not); linear PSNR is undefined.
  const std::string json = (root_ / "png_eval.json").string();
  r = run("eval --out " + exr + " --out " + png + " --ref " + seq +
          "/reference --warmup 1 --exposure 2 --json " + json);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("display images"), std::string::npos) << r.err;
  const auto j = nlohmann::json::parse(std::ifstream(json));
  const auto &lin = j["methods"][0]["summary"], &disp = j["methods"][1]["summary"];
  EXPECT_NEAR(disp["psnr"].get<double>(), lin["psnr"].get<double>(), 0.1) << j.dump();
  EXPECT_NEAR(disp["flip"].get<double>(), lin["flip"].get<double>(), 0.003) << j.dump();
  EXPECT_NEAR(disp["temporal_error"].get<double>(), lin["temporal_error"].get<double>(), 0.002);
  EXPECT_TRUE(lin["psnr_linear"].is_number());
  EXPECT_TRUE(disp["psnr_linear"].is_null()) << j.dump();
  r = run("eval --out " + png + " --ref " + seq + "/reference --warmup 1 --json " + json);
  ASSERT_EQ(r.code, 0) << r.err;
  const double wrong_exposure =
      nlohmann::json::parse(std::ifstream(json))["methods"][0]["summary"]["psnr"].get<double>();
  EXPECT_LT(wrong_exposure, disp["psnr"].get<double>() - 3.0);
  // Input frames stay EXR: resolve refuses display images in one line.
  expect_one_line_error(run("resolve --in " + png + " --out " + png + "4"), "display images");
  expect_one_line_error(run("resolve --in " + seq + " --out " + png +
                            "2 --out-format png "
                            "--keep-gbuffer"),
                        "--keep-gbuffer");
  expect_one_line_error(run("resolve --in " + seq + " --out " + png + "3 --compression zipp"),
                        "zipp");
  expect_one_line_error(
      run("resolve --in " + seq + " --out " + png + "5 --out-format png --compression piz"),
      "--compression");
  expect_one_line_error(run("resolve --in " + seq + " --out " + png + "5 --out-format jpg --half"),
                        "--half");
}

// demo --out-format writes each main-table row's frames and the reference where a person (and
// eval) can read them: eval of the PNG rows reproduces the demo's own table up to 8-bit
// rounding, and the EXR rows exactly.
TEST_F(CliTest, DemoWritesTheRowsFramesInTheOutputFormat) {
  const std::string sections =
      " --size 32x18 --frames 4 --warmup 1 --scenes motion --methods taa:afterimage "
      "--taau-scale 0 --cache-scenes \"\" --extrapolate-scenes \"\" --effect-sections \"\" "
      "--light-sections \"\" --denoise-scenes \"\" --no-video";
  for (const std::string format : {"png", "exr"}) {
    const fs::path demo = root_ / ("demo_" + format);
    CliRun r = run("demo --out " + demo.string() + sections + " --out-format " + format);
    ASSERT_EQ(r.code, 0) << r.err;
    const fs::path frames = demo / "frames" / "motion";
    for (const std::string row : {"reference", "no-aa", "ssaa-4x", "ssaa-16x", "taa-afterimage"})
      for (int t = 0; t < 4; ++t) {
        // SSAA renders start after the warm-up frame (ssaa_first_frame).
        const bool rendered = t >= 1 || row.rfind("ssaa", 0) != 0;
        EXPECT_EQ(fs::exists(frames / row / fmt::format("frame.{:04d}.{}", t, format)), rendered)
            << row << " " << t;
      }
    const auto table = nlohmann::json::parse(std::ifstream(demo / "metrics.json"));
    // The skipped warm-up frame has no scores; the rendered ones do, and the means read them.
    int ssaa_rows = 0;
    for (const auto& m : table["motion"]["methods"])
      if (m["label"] == "SSAA 4x" && ++ssaa_rows) {
        EXPECT_TRUE(m["frames"][0]["psnr"].is_null()) << m.dump();
        EXPECT_TRUE(m["frames"][1]["psnr"].is_number()) << m.dump();
        EXPECT_TRUE(m["summary"]["psnr"].is_number()) << m.dump();
      }
    EXPECT_EQ(ssaa_rows, 1) << table.dump();
    const std::string json = (demo / "eval.json").string();
    r = run("eval --out " + (frames / "taa-afterimage").string() + " --ref " +
            (demo / "cache" / "motion-32x18-4f" / "reference").string() + " --warmup 1 --json " +
            json);
    ASSERT_EQ(r.code, 0) << r.err;
    const auto j = nlohmann::json::parse(std::ifstream(json));
    double demo_psnr = -1;
    for (const auto& m : table["motion"]["methods"])
      if (m["label"] == "TAA afterimage") demo_psnr = m["summary"]["psnr"].get<double>();
    ASSERT_GT(demo_psnr, 0) << table.dump();
    EXPECT_NEAR(j["methods"][0]["summary"]["psnr"].get<double>(), demo_psnr,
                format == "exr" ? 1e-9 : 0.1);
  }
  expect_one_line_error(
      run("demo --out " + (root_ / "demo_tiff").string() + sections + " --out-format tiff"),
      "tiff");
}

// Outputs keep the input's names and numbers unless --out-name gives another stem; the
// frame numbers stay the input's (a Blender name_0003 input gives NAME.0003).
TEST_F(CliTest, OutNameRenamesButKeepsTheFrameNumbers) {
  const std::string seq = (root_ / "seq").string();
  const fs::path blender = root_ / "renamed_in", out = root_ / "renamed";
  fs::create_directories(blender);
  for (int t = 0; t < 3; ++t)
    fs::copy_file(io::frame_path(seq, t), blender / fmt::format("shot_{:04d}.exr", t + 3));
  CliRun r = run("resolve --in " + blender.string() + " --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  for (int t = 3; t < 6; ++t) EXPECT_TRUE(fs::exists(out / fmt::format("shot_{:04d}.exr", t)));
  r = run("resolve --in " + blender.string() + " --out " + out.string() +
          " --out-name taa --out-format png");
  ASSERT_EQ(r.code, 0) << r.err;
  for (int t = 3; t < 6; ++t) EXPECT_TRUE(fs::exists(out / fmt::format("taa.{:04d}.png", t)));
  EXPECT_FALSE(fs::exists(out / "taa.0000.png"));
  r = run("run --in " + blender.string() + " --out " + out.string() +
          " --pipeline taa,tonemap --out-name graded");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out / "graded.0005.exr"));
  expect_one_line_error(
      run("resolve --in " + blender.string() + " --out " + out.string() + " --out-name a/b"),
      "--out-name");
}

// EXR options: compression and half color are what the file says; half keeps the G-buffer
// float.
TEST_F(CliTest, ExrCompressionAndHalf) {
  const std::string seq = (root_ / "seq").string(), out = (root_ / "half").string();
  ASSERT_EQ(
      run("resolve --in " + seq + " --out " + out + " --compression piz --half --keep-gbuffer")
          .code,
      0);
  auto in = OIIO::ImageInput::open(io::frame_path(out, 2));
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().get_string_attribute("compression"), "piz");
  EXPECT_EQ(in->spec().channelformat(0), OIIO::TypeDesc::HALF);
  const Frame h = io::read_frame(io::frame_path(out, 2), core_channels(), "test");
  const Frame src = io::read_frame(io::frame_path(seq, 2));
  EXPECT_TRUE(h.depth == src.depth && h.motion == src.motion);
}

TEST_F(CliTest, BadInputsGiveOneLineErrors) {
  const std::string seq = (root_ / "seq").string();
  expect_one_line_error(run("info " + (root_ / "missing.exr").string()), "missing.exr");
  expect_one_line_error(
      run("render --scene nosuch --frames 2 --size 8x8 --out " + (root_ / "x").string()), "nosuch");
  expect_one_line_error(run("render --scene thin --frames 2 --size 8x8 --reference 5 --out " +
                            (root_ / "x").string()),
                        "5");
  // A frame without motion channels in a sequence given to resolve.
  const fs::path nomo = root_ / "nomotion";
  fs::create_directories(nomo);
  Frame f = io::read_frame(io::frame_path(seq, 0));
  f.motion = ImageF();
  io::write_frame(io::frame_path(nomo.string(), 0), f);
  expect_one_line_error(run("resolve --in " + nomo.string() + " --out " + (root_ / "y").string()),
                        "motion");
  // A corrupt frame: truncated.
  const fs::path bad = root_ / "corrupt";
  fs::create_directories(bad);
  fs::copy_file(io::frame_path(seq, 0), io::frame_path(bad.string(), 0));
  fs::resize_file(io::frame_path(bad.string(), 0), 200);
  expect_one_line_error(run("resolve --in " + bad.string() + " --out " + (root_ / "z").string()),
                        "frame.0000.exr");
  // Unknown TAA setting lists the valid keys (on one line).
  CliRun r = run("resolve --in " + seq + " --out " + (root_ / "w").string() + " --set nosuchkey=1");
  expect_one_line_error(r, "nosuchkey");
  EXPECT_NE(r.err.find("alpha"), std::string::npos);
}

TEST_F(CliTest, ResolveNeverOverwritesItsInput) {
  const fs::path copy = root_ / "inplace";
  fs::create_directories(copy);
  fs::copy_file(io::frame_path((root_ / "seq").string(), 0), io::frame_path(copy.string(), 0));
  fs::copy_file(io::frame_path((root_ / "seq").string(), 1), io::frame_path(copy.string(), 1));
  const auto before = fs::file_size(io::frame_path(copy.string(), 0));
  Frame orig = io::read_frame(io::frame_path(copy.string(), 0));
  CliRun r = run("resolve --in " + copy.string() + " --out " + copy.string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("overwrite"), std::string::npos) << r.err;
  EXPECT_EQ(fs::file_size(io::frame_path(copy.string(), 0)), before);
  EXPECT_TRUE(io::read_frame(io::frame_path(copy.string(), 0)).color == orig.color);
}

TEST_F(CliTest, NanPixelsNeverReachTheOutput) {
  const fs::path nan_dir = root_ / "nan";
  fs::create_directories(nan_dir);
  for (int t = 0; t < 6; ++t) {
    Frame f = io::read_frame(io::frame_path((root_ / "seq").string(), t));
    if (t == 2) {
      f.color.at(10, 10, 0) = std::numeric_limits<float>::quiet_NaN();
      f.color.at(11, 10, 1) = std::numeric_limits<float>::infinity();
    }
    io::write_frame(io::frame_path(nan_dir.string(), t), f);
  }
  CliRun r = run("resolve --in " + nan_dir.string() + " --out " + (root_ / "nan_out").string());
  ASSERT_EQ(r.code, 0) << r.err;
  for (int t = 0; t < 6; ++t) {
    Frame o = io::read_frame(io::frame_path((root_ / "nan_out").string(), t));
    for (float v : o.color.data()) ASSERT_TRUE(std::isfinite(v)) << "frame " << t;
  }
}

// The official FLIP vectors, checked through `afterimage compare` (PNG = LDR-FLIP,
// EXR = HDR-FLIP, as the official tool decides): mean within 1e-4 of NVIDIA's.
TEST(CliCompare, MatchesOfficialFlipMeans) {
  const fs::path dir = fs::path(AFTERIMAGE_TESTDATA_DIR) / "flip";
  const auto values = nlohmann::json::parse(std::ifstream(dir / "values.json"));
  int checked = 0;
  for (const auto& [name, pair] : values["pairs"].items()) {
    std::string args = "compare " + (dir / pair["reference"].get<std::string>()).string() + " " +
                       (dir / pair["test"].get<std::string>()).string() + " --json";
    if (std::abs(pair["ppd"].get<double>() - 67.0206451) > 1e-3)
      args += " --ppd " + std::to_string(pair["ppd"].get<double>());
    CliRun r = run(args);
    ASSERT_EQ(r.code, 0) << name << ": " << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_NEAR(j["flip"].get<double>(), pair["mean_double_accum"].get<double>(), 1e-4) << name;
    EXPECT_EQ(j["flip_mode"].get<std::string>(), pair["mode"].get<std::string>()) << name;
    ++checked;
  }
  EXPECT_EQ(checked, 9);
}

TEST_F(CliTest, EvalRefusesNonFiniteFramesAndMismatchedSequences) {
  const std::string seq = (root_ / "seq").string();
  const fs::path bad = root_ / "eval_nan";
  fs::create_directories(bad);
  for (int t = 0; t < 6; ++t) {
    Frame f = io::read_frame(io::frame_path(seq, t));
    if (t == 3) f.color.at(5, 7, 2) = std::numeric_limits<float>::quiet_NaN();
    io::write_frame(io::frame_path(bad.string(), t), f);
  }
  expect_one_line_error(
      run("eval --warmup 1 --out " + bad.string() + " --ref " + seq + "/reference"),
      "frame.0003.exr: non-finite color at pixel (5, 7)");
  const fs::path short_seq = root_ / "eval_short";
  fs::create_directories(short_seq);
  fs::copy_file(io::frame_path(seq, 0), io::frame_path(short_seq.string(), 0));
  expect_one_line_error(run("eval --out " + short_seq.string() + " --ref " + seq + "/reference"),
                        "1 frames, but the reference");
}
