// The demo's held-out check of the default TAA preset (apps/demo/demo_split.h) on hand-made
// tables: means per set, the scenes an anchor wins, the gain over the best anchor and the
// temporal-error ratio against the anchor with the lowest one.
#include <gtest/gtest.h>

#include "apps/demo/demo_split.h"

using namespace afterimage;

namespace {

MethodSummary row(const std::string& label, double flip, double temporal) {
  MethodSummary m;
  m.label = label;
  m.aggregate = {{"flip", flip}, {"temporal_error", temporal}, {"psnr", 30.0}};
  return m;
}

}  // namespace

TEST(DemoSplit, JudgesTheDefaultOnTheValidationScenesOnly) {
  const std::vector<SplitScene> scenes = {
      // A tuning scene where the default loses badly: it must not count.
      {"tune", false, {row("TAA ours", 0.9, 0.1), row("TAA a", 0.1, 0.1), row("TAA b", 0.1, 0.1)}},
      {"v1",
       true,
       {row("TAA ours", 0.08, 0.010), row("TAA a", 0.10, 0.008), row("TAA b", 0.13, 0.020)}},
      {"v2",
       true,
       {row("TAA ours", 0.04, 0.010), row("TAA a", 0.05, 0.008), row("TAA b", 0.03, 0.004)}},
  };
  const SplitVerdict v = judge_taa_split(scenes, "TAA ours", {"TAA a", "TAA b"});
  ASSERT_TRUE(v.judged);
  // Validation means: ours .06, a .075, b .08; temporal ours .010, a .008, b .012.
  ASSERT_EQ(v.validation.methods.size(), 3u);
  EXPECT_NEAR(v.validation.methods[0].aggregate.at("flip"), 0.06, 1e-12);
  EXPECT_EQ(v.best_anchor, "TAA a");
  EXPECT_NEAR(v.flip_gain, 1.0 - 0.06 / 0.075, 1e-12);  // 20% better
  EXPECT_EQ(v.best_temporal_anchor, "TAA a");
  EXPECT_NEAR(v.temporal_ratio, 0.010 / 0.008, 1e-12);
  ASSERT_EQ(v.losses.size(), 1u);  // b wins v2
  EXPECT_EQ(v.losses[0], "v2: TAA b 0.0300 < 0.0400");
  EXPECT_NE(v.text().find("-20.0% vs TAA a"), std::string::npos) << v.text();
  // The tuning mean holds the tuning scene alone.
  EXPECT_NEAR(v.tuning.methods[0].aggregate.at("flip"), 0.9, 1e-12);
}

TEST(DemoSplit, NoVerdictWithoutValidationScenesOrWithAMissingRow) {
  const std::vector<SplitScene> tuning_only = {
      {"tune", false, {row("TAA ours", 0.1, 0.1), row("TAA a", 0.1, 0.1)}}};
  EXPECT_FALSE(judge_taa_split(tuning_only, "TAA ours", {"TAA a"}).judged);
  EXPECT_EQ(judge_taa_split(tuning_only, "TAA ours", {"TAA a"}).text(), "");
  // An anchor that did not run on every validation scene is not averaged (no verdict).
  const std::vector<SplitScene> partial = {
      {"v1", true, {row("TAA ours", 0.1, 0.1), row("TAA a", 0.1, 0.1)}},
      {"v2", true, {row("TAA ours", 0.1, 0.1)}}};
  const SplitVerdict v = judge_taa_split(partial, "TAA ours", {"TAA a"});
  EXPECT_FALSE(v.judged);
  ASSERT_EQ(v.validation.methods.size(), 1u);
  EXPECT_EQ(v.validation.methods[0].label, "TAA ours");
}
