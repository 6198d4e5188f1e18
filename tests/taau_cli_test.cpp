// `render --render-scale` and `resolve --upscale` end to end (issue 10): the low-resolution
// G-buffer beside full-resolution references, the upsampled output at full resolution that
// eval scores against them, and one-line errors for impossible scales and sizes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "camera/camera.h"
#include "cli_util.h"
#include "io/io.h"
#include "test_util.h"

using namespace afterimage;
using test::CliRun;
using test::expect_one_line_error;
using test::run;
namespace fs = std::filesystem;

namespace {

class TaauCliTest : public ::testing::Test {
 protected:
  static void TearDownTestSuite() { test::remove_if_passed(root_); }
  static void SetUpTestSuite() {
    root_ = test::fresh_temp_dir("taau_cli_test");
    // 17 frames: frame 16 tells Halton 32 (2x: ceil(8 * 2^2)) from the default Halton 16.
    CliRun r = run("render --scene motion --frames 17 --size 64x36 --render-scale 2 --out " +
                   (root_ / "seq").string() + " --reference 4");
    ASSERT_EQ(r.code, 0) << r.err;
    render_out_ = r.out;
  }
  static fs::path root_;
  static std::string render_out_;
};
fs::path TaauCliTest::root_;
std::string TaauCliTest::render_out_;

}  // namespace

TEST_F(TaauCliTest, RenderScaleWritesLowResGbufferAndFullResReferences) {
  const std::string seq = (root_ / "seq").string();
  const Frame g = io::read_frame(io::frame_path(seq, 16));
  EXPECT_EQ(g.width, 32);
  EXPECT_EQ(g.height, 18);
  const JitterSequence halton32{JitterPattern::Halton, 32};
  EXPECT_EQ(g.jitter, halton32.at(16));
  EXPECT_NE(g.jitter, io::read_frame(io::frame_path(seq, 0)).jitter);
  const Frame ref = io::read_frame(io::frame_path(seq + "/reference", 16));
  EXPECT_EQ(ref.width, 64);
  EXPECT_EQ(ref.height, 36);
  EXPECT_NE(render_out_.find("--upscale 64x36"), std::string::npos) << render_out_;
}

TEST_F(TaauCliTest, ResolveUpscaleWritesFullResolutionThatEvalScores) {
  const std::string seq = (root_ / "seq").string();
  for (const char* arg : {"performance", "2", "64x36"}) {
    const std::string out = (root_ / (std::string("up_") + arg)).string();
    CliRun r = run("resolve --in " + seq + " --out " + out + " --upscale " + arg);
    ASSERT_EQ(r.code, 0) << r.err;
    const Frame o = io::read_frame(io::frame_path(out, 5));
    EXPECT_EQ(o.width, 64) << arg;
    EXPECT_EQ(o.height, 36) << arg;
    for (const ChannelInfo& c : kChannelTable)
      EXPECT_EQ(o.has(c.key), c.key == Channel::color) << c.name;
  }
  // The three spellings of 2x are one method: identical files.
  EXPECT_EQ(io::read_frame(io::frame_path((root_ / "up_performance").string(), 9)).color,
            io::read_frame(io::frame_path((root_ / "up_64x36").string(), 9)).color);
  CliRun r = run("eval --out " + (root_ / "up_performance").string() + " --ref " + seq +
                 "/reference --warmup 4");
  EXPECT_EQ(r.code, 0) << r.err;
  // --keep-gbuffer cannot copy a 32x18 G-buffer into a 64x36 output: a note, color only.
  const std::string kept = (root_ / "kept").string();
  r = run("resolve --in " + seq + " --out " + kept + " --upscale performance --keep-gbuffer");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("not copied"), std::string::npos) << r.err;
  EXPECT_FALSE(io::read_frame(io::frame_path(kept, 3)).has_depth());
  // --list-settings shows the TAAU table.
  r = run("resolve --upscale quality --list-settings");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("scale"), std::string::npos);
  EXPECT_NE(r.out.find("1.5"), std::string::npos);
}

TEST_F(TaauCliTest, ImpossibleScalesAndSizesAreOneLineErrors) {
  const std::string seq = (root_ / "seq").string(), out = (root_ / "bad").string();
  for (const char* bad : {"0.5", "4.5", "nan", "inf", "-1", "fast", "64x", "0x36"})
    expect_one_line_error(run("resolve --in " + seq + " --out " + out + " --upscale " + bad),
                          "--upscale");
  // An output smaller than the input, or more than 4x larger: refused before writing.
  expect_one_line_error(run("resolve --in " + seq + " --out " + out + " --upscale 16x18"),
                        "1 to 4 times");
  expect_one_line_error(run("resolve --in " + seq + " --out " + out + " --upscale 200x36"),
                        "1 to 4 times");
  EXPECT_FALSE(fs::exists(io::frame_path(out, 0)));
  expect_one_line_error(
      run("resolve --in " + seq + " --out " + out + " --upscale 2 --preset afterimage"),
      "--preset");
  expect_one_line_error(
      run("resolve --in " + seq + " --out " + out + " --upscale 2 --set kernel=box"), "kernel");
  for (const char* bad : {"0.5", "5", "nan"})
    expect_one_line_error(run(std::string("render --scene thin --frames 1 --size 16x16 --out ") +
                              (root_ / "r").string() + " --render-scale " + bad),
                          "--render-scale");
}
