// `afterimage render --shading-cache` end to end: frames and per-frame counters written, the
// still scene equal to full shading, bad settings refused with one line before any output.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

#include "cli_util.h"
#include "io/io.h"
#include "test_util.h"

namespace afterimage {
namespace {

namespace fs = std::filesystem;

TEST(ShadingCacheCli, WritesFramesAndCountersAndMatchesFullShadingWhenStill) {
  const fs::path dir = test::fresh_temp_dir("shading_cache_cli");
  const std::string common =
      "render --scene penumbra --static --frames 4 --size 48x27 "
      "--jitter none --soft-shadows --light-samples 4 --out ";
  auto r = test::run(common + (dir / "cached").string() + " --shading-cache reuse --refresh 3");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("shading cache (reuse):"), std::string::npos) << r.out;
  r = test::run(common + (dir / "full").string());
  ASSERT_EQ(r.code, 0) << r.err;

  const auto j = nlohmann::json::parse(std::ifstream(dir / "cached" / "shading_cache.json"));
  ASSERT_EQ(j["frames"].size(), 4u);
  EXPECT_EQ(j["settings"]["refresh"], 3);
  EXPECT_EQ(j["frames"][0]["shaded"],
            j["frames"][0]["pixels"].get<int>() - j["frames"][0]["background"].get<int>());
  for (int k = 1; k < 4; ++k) {
    EXPECT_EQ(j["frames"][k]["misses"]["id"], 0);
    EXPECT_LT(j["frames"][k]["shaded_fraction"].get<double>(), 0.5) << k;
  }
  // Still scene, no jitter: the cached frames are the fully shaded ones, to float rounding of
  // the two ways of composing the color.
  for (int k = 0; k < 4; ++k) {
    const Frame a = io::read_frame(io::frame_path((dir / "cached").string(), k));
    const Frame b = io::read_frame(io::frame_path((dir / "full").string(), k));
    for (size_t i = 0; i < a.color.data().size(); ++i)
      ASSERT_NEAR(a.color.data()[i], b.color.data()[i], 1e-5f * (1.0f + b.color.data()[i]))
          << "frame " << k;
  }
}

TEST(ShadingCacheCli, BadSettingsAreOneLineErrorsBeforeOutput) {
  const fs::path dir = test::fresh_temp_dir("shading_cache_cli_bad");
  const std::string out = " --out " + (dir / "o").string();
  const std::string base = "render --scene motion --frames 2 --size 32x18";
  test::expect_one_line_error(test::run(base + out + " --refresh 4"), "--shading-cache");
  test::expect_one_line_error(
      test::run(base + out + " --shading-cache reuse --cache-set refresh=0"), "refresh");
  test::expect_one_line_error(
      test::run(base + out + " --shading-cache reuse --cache-set nonsense=1"), "nonsense");
  test::expect_one_line_error(test::run(base + out + " --shading-cache average --alpha 7"),
                              "alpha");
  test::expect_one_line_error(test::run(base + out + " --soft-shadows --light-samples 5"),
                              "light_samples");
  EXPECT_FALSE(fs::exists(dir / "o"));
  const auto r = test::run(base + out + " --shading-cache sometimes");
  EXPECT_NE(r.code, 0);
}

}  // namespace
}  // namespace afterimage
