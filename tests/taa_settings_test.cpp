// TaaSettings key/value interface and presets (DESIGN.md §6: parameters declared with name,
// default and range; unknown keys rejected; presets are named).
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "core/error.h"
#include "core/params.h"
#include "taa/presets.h"
#include "taa/resolver.h"
#include "taa/settings.h"

#include "test_util.h"

using namespace afterimage;
using namespace afterimage::taa;

namespace {
std::string error_of(const std::function<void()>& fn) {
  return test::error_of<SettingsError>(fn, "");
}
}  // namespace

TEST(TaaSettings, UnknownKeyListsValidKeys) {
  TaaSettings s;
  std::string msg = error_of([&] { s.set("alpah", "0.1"); });
  ASSERT_FALSE(msg.empty());
  EXPECT_NE(msg.find("alpah"), std::string::npos);
  for (const auto& k : setting_keys()) EXPECT_NE(msg.find(k), std::string::npos) << k;
  EXPECT_FALSE(error_of([&] { (void)s.get("nope"); }).empty());
  EXPECT_FALSE(error_of([&] { s.set_assignment("no_equals_sign"); }).empty());
}

TEST(TaaSettings, OutOfRangeAndMalformedValuesAreRejected) {
  TaaSettings s;
  EXPECT_THROW(s.set("alpha", "2"), SettingsError);
  EXPECT_THROW(s.set("alpha", "0"), SettingsError);
  EXPECT_THROW(s.set("alpha", "nan"), SettingsError);
  EXPECT_THROW(s.set("alpha", "0.1x"), SettingsError);
  EXPECT_THROW(s.set("alpha", ""), SettingsError);
  EXPECT_THROW(s.set("variance_gamma", "-1"), SettingsError);
  EXPECT_THROW(s.set("sharpen", "0.5"), SettingsError);  // a post pass, not a TAA setting
  EXPECT_THROW(s.set("sample_count", "maybe"), SettingsError);
  std::string msg = error_of([&] { s.set("history", "lanczos"); });
  EXPECT_NE(msg.find("catmull_rom_5"), std::string::npos);  // lists the valid names
  EXPECT_EQ(s, TaaSettings{});                              // nothing changed
}

TEST(TaaSettings, SetGetRoundTrip) {
  TaaSettings s;
  s.set("alpha", "0.25");
  s.set_assignment("history=catmull_rom_9");
  s.set("sample_count", "on");
  s.set("rectify", "convex_hull");
  s.set("depth_reject", "reduce");
  EXPECT_FLOAT_EQ(s.alpha, 0.25f);
  EXPECT_EQ(s.history, HistorySampler::CatmullRom9);
  EXPECT_TRUE(s.sample_count);
  EXPECT_EQ(s.rectify, Rectify::ConvexHull);
  EXPECT_EQ(s.depth_reject, Rejection::Reduce);
  EXPECT_EQ(s.get("history"), "catmull_rom_9");
  EXPECT_EQ(s.get("sample_count"), "true");
  // Every key's printed value parses back to the same settings.
  TaaSettings p = make_preset("ue4"), q;
  for (const auto& k : setting_keys()) q.set(k, p.get(k));
  EXPECT_EQ(p, q);
}

TEST(TaaSettings, ValidateCatchesDirectEdits) {
  TaaSettings s;
  s.validate();
  s.alpha = 5.0f;
  EXPECT_THROW(s.validate(), SettingsError);
  s = TaaSettings{};
  s.luma_feedback_min = 0.99f;
  s.luma_feedback_max = 0.9f;
  EXPECT_THROW(s.validate(), SettingsError);
  s = TaaSettings{};
  s.history = static_cast<HistorySampler>(42);
  EXPECT_THROW(s.validate(), SettingsError);
  EXPECT_THROW(TemporalResolver{s}, SettingsError);
}

TEST(TaaSettings, JsonAndListingCoverEveryKey) {
  TaaSettings s = make_preset("afterimage");
  auto j = nlohmann::json::parse(s.to_json());
  for (const auto& k : setting_keys()) EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_EQ(j["history"], "catmull_rom_5");
  EXPECT_EQ(j["sample_count"], true);
  std::string listing = s.describe();
  for (const auto& k : setting_keys()) EXPECT_NE(listing.find(k), std::string::npos) << k;
}

TEST(TaaPresets, AllValidateAndUnknownListsNames) {
  for (const auto& n : preset_names()) make_preset(n).validate();
  std::string msg = error_of([] { make_preset("fxaa"); });
  for (const auto& n : preset_names()) EXPECT_NE(msg.find(n), std::string::npos) << n;
  EXPECT_EQ(make_preset("none"), TaaSettings{});
  EXPECT_FLOAT_EQ(make_preset("uncharted4").alpha, 0.05f);
  EXPECT_EQ(make_preset("ue4").color_space, ColorSpace::YCoCg);
  EXPECT_EQ(make_preset("inside").neighborhood, Neighborhood::Rounded);
  EXPECT_FLOAT_EQ(make_preset("hdrp").variance_gamma, 1.5f);
  EXPECT_TRUE(make_preset("variance").variance_intersect_minmax);
}

TEST(TaaSettings, EveryMemberIsRegistered) {
  // A member added to TaaSettings without a table entry in settings.cpp fails here.
  EXPECT_EQ(aggregate_member_count<TaaSettings>(), TaaSettings::params().size());
  EXPECT_TRUE(settings::all_members_registered<TaaSettings>());
  EXPECT_EQ(setting_keys(), TaaSettings::params().keys());
  EXPECT_EQ(TaaSettings::params().technique(), "taa");
}

TEST(TaaSettings, GenericAccessMatchesMembers) {
  TaaSettings a, b;
  a.set("history", "bicubic_16");
  settings::set(b, "history", "bicubic_16");
  EXPECT_EQ(a, b);
  EXPECT_EQ(settings::to_json(a), a.to_json());
  EXPECT_EQ(settings::describe(a), a.describe());
  EXPECT_EQ(to_string(a.history), a.get("history"));
  // Messages keep naming the technique.
  EXPECT_EQ(error_of([&] { a.set("alpha", "3"); }),
            "taa setting alpha: 3 is out of range [0.001, 1]");
  a = TaaSettings{};
  a.luma_feedback_min = 0.99f;
  a.luma_feedback_max = 0.9f;
  EXPECT_EQ(error_of([&] { a.validate(); }),
            "taa settings: luma_feedback_min (0.99) must not exceed luma_feedback_max (0.9)");
}

TEST(TaaSettings, ReadmeTableIsCurrent) {
  // The README block is the output of `afterimage resolve --list-settings --markdown`;
  // regenerate it when a setting changes.
  std::ifstream in(std::string(AFTERIMAGE_SOURCE_DIR) + "/README.md");
  ASSERT_TRUE(in) << "cannot read README.md";
  const std::string readme((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string begin = "<!-- taa-settings:begin -->\n", end = "<!-- taa-settings:end -->";
  const auto b = readme.find(begin), e = readme.find(end);
  ASSERT_NE(b, std::string::npos);
  ASSERT_NE(e, std::string::npos);
  ASSERT_LT(b, e);
  EXPECT_EQ(readme.substr(b + begin.size(), e - b - begin.size()),
            TaaSettings::params().markdown_table())
      << "README.md settings table is stale: replace the block with the output of "
         "`afterimage resolve --list-settings --markdown`";
}
