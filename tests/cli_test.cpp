// End-to-end tests of the `afterimage` command: the README's workflow on a tiny sequence, and
// bad input giving one clear line and a non-zero exit code without touching inputs.
#include <gtest/gtest.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "cli_util.h"
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
  static void SetUpTestSuite() {
    root_ = test::fresh_temp_dir("cli_test_" + std::to_string(getpid()));
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
  // Output keeps the input's metadata and G-buffer.
  Frame in = io::read_frame(io::frame_path(seq, 4));
  Frame o = io::read_frame(io::frame_path(out, 4), {"color", "depth", "motion"});
  EXPECT_TRUE(o.view == in.view);
  EXPECT_EQ(o.jitter, in.jitter);
  EXPECT_FALSE(o.color == in.color);

  const std::string json = (root_ / "eval.json").string(), html = (root_ / "eval.html").string();
  r = run("eval --out " + out + " --out " + seq + "/ssaa4 --label taa --label ssaa4 --ref " + seq +
          "/reference --gbuffer " + seq + " --warmup 2 --json " + json + " --report " + html);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("taa"), std::string::npos);
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
