// `afterimage render --path-trace`: the noisy frames with their channels, the path-traced
// reference and a second one with another seed; bad combinations are one-line errors.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
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

TEST(PathTraceCli, WritesNoisyFramesAndTwoSeedReferences) {
  const fs::path root = test::fresh_temp_dir("path_trace_cli");
  const test::RemoveIfPassed cleanup{root};
  const std::string out = (root / "room").string();
  CliRun r =
      run("render --scene room --path-trace --bounces 3 --frames 2 --size 32x18 "
          "--reference 5 --reference-seed 7 --out " +
          out);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("reference 5 spp:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ms/frame"), std::string::npos) << r.out;
  for (int t = 0; t < 2; ++t) {
    const Frame f = io::read_frame(io::frame_path(out, t));
    for (Channel c : {Channel::emission, Channel::albedo, Channel::diffuse, Channel::specular,
                      Channel::direct, Channel::indirect, Channel::depth_gradient,
                      Channel::roughness, Channel::motion, Channel::id})
      EXPECT_TRUE(f.has(c)) << channel_info(c).name;
    const Frame a = io::read_frame(io::frame_path(out + "/reference", t));
    const Frame b = io::read_frame(io::frame_path(out + "/reference-seed7", t));
    EXPECT_EQ(a.jitter, Vec2d(0.0, 0.0));
    EXPECT_EQ(a.depth, b.depth);  // same camera and time
    EXPECT_NE(a.color, b.color);  // other random numbers
    EXPECT_NE(a.color, f.color);
    EXPECT_TRUE(a.has(Channel::direct) && a.has(Channel::indirect));
  }
  const std::string x = " --frames 1 --size 8x8 --out " + (root / "x").string();
  expect_one_line_error(run("render --scene room --bounces 2" + x), "--path-trace");
  expect_one_line_error(run("render --scene room --path-trace --reference-seed 3" + x),
                        "--reference");
  expect_one_line_error(run("render --scene room --path-trace --bounces 0" + x), "bounces");
  expect_one_line_error(run("render --scene room --path-trace --shading-cache reuse" + x),
                        "shading cache");
  EXPECT_FALSE(fs::exists(root / "x"));
}

}  // namespace
