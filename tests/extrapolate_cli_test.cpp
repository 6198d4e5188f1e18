// End-to-end tests of `afterimage extrapolate` (issue 13): output written under the input's
// file names, scorable by `eval`, bit-identical for any thread count, one-line errors for bad
// input, and the input directory never modified.
#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "cli_util.h"

#include "io/io.h"
#include "test_util.h"

using namespace afterimage;
using test::CliRun;
using test::expect_one_line_error;
using test::run;
namespace fs = std::filesystem;

namespace {

// Every file under `dir` with its bytes: the input must come out of every run unchanged.
std::map<std::string, std::string> snapshot(const fs::path& dir) {
  std::map<std::string, std::string> m;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    std::stringstream s;
    s << std::ifstream(e.path(), std::ios::binary).rdbuf();
    m[e.path().string()] = s.str();
  }
  return m;
}

class ExtrapolateCliTest : public ::testing::Test {
 protected:
  static void TearDownTestSuite() { test::remove_if_passed(root_); }
  static void SetUpTestSuite() {
    root_ = test::fresh_temp_dir("extrapolate_cli_test");
    const CliRun r = run("render --scene motion --frames 5 --size 64x36 --out " + seq());
    ASSERT_EQ(r.code, 0) << r.err;
    before_ = snapshot(seq());
  }
  static std::string seq() { return (root_ / "seq").string(); }
  static fs::path root_;
  static std::map<std::string, std::string> before_;
};
fs::path ExtrapolateCliTest::root_;
std::map<std::string, std::string> ExtrapolateCliTest::before_;

}  // namespace

TEST_F(ExtrapolateCliTest, WritesEveryFrameAndEvalScoresIt) {
  const std::string out = (root_ / "ex").string();
  CliRun r = run("extrapolate --in " + seq() + " --out " + out);
  ASSERT_EQ(r.code, 0) << r.err;
  // Per synthesised frame: its sources and hole fraction; then the summary line.
  EXPECT_NE(r.out.find("frame 1: extrapolated from 0 (camera), holes "), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("frame 3: extrapolated from 2 (camera), holes "), std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("frame 2:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("extrapolate: 5 frames"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("2 synthesised with --skip 1"), std::string::npos) << r.out;
  for (int k = 0; k < 5; ++k) {
    const Frame in = io::read_frame(io::frame_path(seq(), k), {"color"});
    const Frame o = io::read_frame(io::frame_path(out, k), {"color"});
    EXPECT_TRUE(o.view == in.view) << k;
    EXPECT_TRUE(o.projection == in.projection) << k;
    EXPECT_EQ(o.jitter, in.jitter) << k;
    EXPECT_EQ(o.index, in.index) << k;
    EXPECT_FALSE(o.has_depth()) << k;  // color only
    // Rendered frames are copied; synthesised ones are made from the previous frame.
    EXPECT_EQ(o.color == in.color, k % 2 == 0) << k;
  }
  r = run("eval --out " + out + " --ref " + seq() + " --warmup 0");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("PSNR"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\nex "), std::string::npos) << r.out;
  // The kept frames are copies (PSNR inf); --every 2:1 scores the synthesised ones only.
  EXPECT_NE(r.out.find("inf"), std::string::npos) << r.out;
  r = run("eval --out " + out + " --ref " + seq() + " --warmup 0 --every 2:1");
  ASSERT_EQ(r.code, 0) << r.err;
  const size_t row = r.out.find("\nex ");
  ASSERT_NE(row, std::string::npos) << r.out;
  const double psnr = std::stod(r.out.substr(row + 4));
  EXPECT_TRUE(std::isfinite(psnr)) << r.out;
  EXPECT_GT(psnr, 10.0) << r.out;
  expect_one_line_error(run("eval --out " + out + " --ref " + seq() + " --every 2:5"), "--every");
  expect_one_line_error(run("eval --out " + out + " --ref " + seq() + " --every two"), "--every");
  EXPECT_EQ(snapshot(seq()), before_);
}

// Coverage alpha (run/alpha.h): rendered frames keep theirs, synthesised frames get the
// alpha splatted and filled as their color is, so a color c * alpha (c constant) comes out as
// c times the output's alpha; an opaque sequence gives exactly 1. (Before, the alpha was not
// read and every output had none.)
TEST_F(ExtrapolateCliTest, CarriesAlphaWithTheColor) {
  const float c[3] = {0.25f, 0.5f, 1.0f};
  const fs::path in = root_ / "alpha", opaque = root_ / "alpha_opaque";
  fs::create_directories(in);
  fs::create_directories(opaque);
  for (int k = 0; k < 5; ++k) {
    Frame f = io::read_frame(io::frame_path(seq(), k), {"color"});
    io::write_frame(io::frame_path(opaque.string(), k), [&] {
      Frame o = f;
      o.alpha = ImageF(f.width, f.height, 1, 1.0f);
      return o;
    }());
    f.alpha = ImageF(f.width, f.height, 1);
    for (int y = 0; y < f.height; ++y)
      for (int x = 0; x < f.width; ++x) {
        const float a = f.id.at(x, y, 0) != 0 ? 1.0f - 0.25f * float(f.id.at(x, y, 0) % 4)
                                              : 0.125f * float((x + 3 * y) % 9);
        f.alpha.at(x, y, 0) = a;
        for (int p = 0; p < 3; ++p) f.color.at(x, y, p) = c[p] * a;
      }
    io::write_frame(io::frame_path(in.string(), k), f);
  }
  for (const std::string opts : {"", " --interpolate"}) {
    SCOPED_TRACE(opts);
    const std::string out = (root_ / ("alpha_out" + std::to_string(opts.size()))).string();
    const CliRun r = run("extrapolate --in " + in.string() + " --out " + out + opts);
    ASSERT_EQ(r.code, 0) << r.err;
    for (int k = 0; k < 5; ++k) {
      const Frame src = io::read_frame(io::frame_path(in.string(), k), {"color"});
      const Frame o = io::read_frame(io::frame_path(out, k), {"color"});
      ASSERT_TRUE(o.has(Channel::alpha)) << k;
      if (k % 2 == 0) {
        EXPECT_EQ(o.alpha, src.alpha) << k;
        continue;
      }
      double err = 0;
      for (int y = 0; y < o.height; ++y)
        for (int x = 0; x < o.width; ++x)
          for (int p = 0; p < 3; ++p)
            err = std::max(err, std::abs(double(o.color.at(x, y, p)) -
                                         double(c[p]) * double(o.alpha.at(x, y, 0))));
      EXPECT_LT(err, 1e-5) << k;
      EXPECT_NE(o.alpha, src.alpha) << k;  // moved with the splat
    }
  }
  const std::string out = (root_ / "alpha_opaque_out").string();
  ASSERT_EQ(run("extrapolate --in " + opaque.string() + " --out " + out).code, 0);
  for (int k = 0; k < 5; ++k) {
    const Frame o = io::read_frame(io::frame_path(out, k), {"color"});
    ASSERT_TRUE(o.has(Channel::alpha)) << k;
    for (float a : o.alpha.data()) ASSERT_EQ(a, 1.0f) << k;
  }
}

TEST_F(ExtrapolateCliTest, SkipInterpolateFillAndThreadsAreBitIdentical) {
  const std::string a = (root_ / "t1").string(), b = (root_ / "t2").string();
  const std::string args = " extrapolate --in " + seq() + " --skip 2 --interpolate --fill naive";
  CliRun r1 = run("--threads 1" + args + " --out " + a);
  ASSERT_EQ(r1.code, 0) << r1.err;
  CliRun r2 = run("--threads 2" + args + " --out " + b);
  ASSERT_EQ(r2.code, 0) << r2.err;
  // Frames 1 and 2 lie between rendered 0 and 3; frame 4 has no rendered frame after it.
  EXPECT_NE(r1.out.find("frame 1: interpolated from 0 (camera) + 3 (camera)"), std::string::npos)
      << r1.out;
  EXPECT_NE(r1.out.find("frame 4: extrapolated from 3 (camera)"), std::string::npos) << r1.out;
  for (int k = 0; k < 5; ++k) {
    const Frame fa = io::read_frame(io::frame_path(a, k), {"color"});
    const Frame fb = io::read_frame(io::frame_path(b, k), {"color"});
    EXPECT_TRUE(fa.color == fb.color) << k;
  }
  EXPECT_EQ(snapshot(seq()), before_);
}

TEST_F(ExtrapolateCliTest, UsesExactMotionWhenTheRendererWroteIt) {
  const std::string in = (root_ / "seq_next").string(), out = (root_ / "ex_next").string();
  CliRun r = run("render --scene motion --frames 3 --size 64x36 --motion-next --out " + in);
  ASSERT_EQ(r.code, 0) << r.err;
  r = run("extrapolate --in " + in + " --out " + out + " --interpolate");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("frame 1: interpolated from 0 (motion_next) + 2 (motion)"),
            std::string::npos)
      << r.out;
}

TEST_F(ExtrapolateCliTest, BadInputIsOneLineAndTouchesNothing) {
  const std::string out = (root_ / "bad").string();
  expect_one_line_error(run("extrapolate --in " + seq() + " --out " + out + " --skip 0"),
                        "--skip 0");
  expect_one_line_error(run("extrapolate --in " + seq() + " --out " + out + " --fill blur"),
                        "--fill 'blur'");
  // Output over the input: refused before anything is written.
  expect_one_line_error(run("extrapolate --in " + seq() + " --out " + seq()),
                        "refusing to overwrite an input file");
  expect_one_line_error(run("extrapolate --in " + (root_ / "missing").string() + " --out " + out),
                        "missing");
  EXPECT_FALSE(fs::exists(out));
  // Frames without depth: named, with the missing channel.
  const fs::path nodepth = root_ / "nodepth";
  fs::create_directories(nodepth);
  for (int k = 0; k < 3; ++k) {
    const Frame f = io::read_frame(io::frame_path(seq(), k), {"color"});
    Frame c;
    static_cast<FrameHeader&>(c) = f;
    c.color = f.color;
    io::write_frame(io::frame_path(nodepth.string(), k), c);
  }
  const CliRun r = run("extrapolate --in " + nodepth.string() + " --out " + out);
  expect_one_line_error(r, "frame.0000.exr");
  EXPECT_NE(r.err.find("depth"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  // Frames of different sizes.
  const fs::path mixed = root_ / "mixed";
  fs::create_directories(mixed);
  for (int k = 0; k < 2; ++k)
    fs::copy_file(io::frame_path(seq(), k), io::frame_path(mixed.string(), k));
  ASSERT_EQ(
      run("render --scene motion --frames 1 --size 32x18 --out " + (root_ / "small").string()).code,
      0);
  fs::copy_file(io::frame_path((root_ / "small").string(), 0), io::frame_path(mixed.string(), 2));
  expect_one_line_error(run("extrapolate --in " + mixed.string() + " --out " + out),
                        "differs from the sequence's 64x36");
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(snapshot(seq()), before_);
}
