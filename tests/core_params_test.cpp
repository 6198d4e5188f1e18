// The generic parameter table (core/params.h) on a test-only settings struct: every kind of
// field, the error messages, JSON, the listings and the member-count check.
#include <gtest/gtest.h>

#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "core/error.h"
#include "core/params.h"

#include "test_util.h"

using namespace afterimage;

namespace {

enum class Shape { Round, Square };
constexpr EnumNames<Shape, 2> kShapeNames{{{Shape::Round, "round"}, {Shape::Square, "square"}}};

struct ToySettings {
  float gain = 0.5f;
  int taps = 3;
  bool enabled = false;
  Shape shape = Shape::Round;
  float lo = 0.25f;
  float hi = 0.75f;

  static const ParamTable<ToySettings>& params();
  bool operator==(const ToySettings&) const = default;
};

const ParamTable<ToySettings>& ToySettings::params() {
  static const ParamTable<ToySettings> kTable = [] {
    using S = ToySettings;
    ParamTable<S> t("toy");
    t.add_float("gain", &S::gain, 0.0f, 2.0f, "output gain")
        .add_int("taps", &S::taps, 1, 9, "filter taps | odd")
        .add_bool("enabled", &S::enabled, "switch the toy on")
        .add_enum("shape", &S::shape, kShapeNames, "kernel shape")
        .add_float("lo", &S::lo, 0.0f, 1.0f, "lower bound")
        .add_float("hi", &S::hi, 0.0f, 1.0f, "upper bound")
        .check([](const S& s) { return s.lo <= s.hi ? std::string() : std::string("lo > hi"); });
    return t;
  }();
  return kTable;
}

// The same struct with one member the table forgets.
struct ToyWithExtra {
  float gain = 0.5f;
  int forgotten = 0;
  static const ParamTable<ToyWithExtra>& params() {
    static const ParamTable<ToyWithExtra> kTable = [] {
      ParamTable<ToyWithExtra> t("toy");
      t.add_float("gain", &ToyWithExtra::gain, 0.0f, 2.0f, "output gain");
      return t;
    }();
    return kTable;
  }
};

std::string error_of(const std::function<void()>& fn) {
  return test::error_of<SettingsError>(fn, "");
}

}  // namespace

TEST(ParamTable, SetParsesEveryKind) {
  ToySettings s;
  settings::set(s, "gain", "1.5");
  settings::set(s, "taps", "7");
  settings::set(s, "shape", "square");
  settings::set_assignment(s, "enabled=on");
  EXPECT_FLOAT_EQ(s.gain, 1.5f);
  EXPECT_EQ(s.taps, 7);
  EXPECT_TRUE(s.enabled);
  EXPECT_EQ(s.shape, Shape::Square);
  for (const char* t : {"true", "1", "on", "yes"}) {
    settings::set(s, "enabled", "false");
    settings::set(s, "enabled", t);
    EXPECT_TRUE(s.enabled) << t;
  }
  for (const char* f : {"false", "0", "off", "no"}) {
    settings::set(s, "enabled", "true");
    settings::set(s, "enabled", f);
    EXPECT_FALSE(s.enabled) << f;
  }
  EXPECT_EQ(settings::get(s, "gain"), "1.5");
  EXPECT_EQ(settings::get(s, "taps"), "7");
  EXPECT_EQ(settings::get(s, "shape"), "square");
  EXPECT_EQ(settings::get(s, "enabled"), "false");
}

TEST(ParamTable, RejectsUnknownKeysAndBadValuesNamingTheTechnique) {
  ToySettings s;
  const std::string unknown = error_of([&] { settings::set(s, "gian", "1"); });
  EXPECT_EQ(unknown, "unknown toy setting 'gian'; valid keys: gain, taps, enabled, shape, lo, hi");
  EXPECT_EQ(error_of([&] { settings::set(s, "gain", "3"); }),
            "toy setting gain: 3 is out of range [0, 2]");
  EXPECT_EQ(error_of([&] { settings::set(s, "gain", "1x"); }),
            "toy setting gain: '1x' is not a number");
  EXPECT_FALSE(error_of([&] { settings::set(s, "gain", "nan"); }).empty());
  EXPECT_EQ(error_of([&] { settings::set(s, "taps", "10"); }),
            "toy setting taps: 10 is out of range [1, 9]");
  EXPECT_EQ(error_of([&] { settings::set(s, "taps", "2.5"); }),
            "toy setting taps: '2.5' is not an integer");
  EXPECT_FALSE(error_of([&] { settings::set(s, "taps", "99999999999"); }).empty());
  EXPECT_EQ(error_of([&] { settings::set(s, "enabled", "maybe"); }),
            "toy setting enabled: 'maybe' is not a boolean (true|false|on|off|1|0)");
  EXPECT_EQ(error_of([&] { settings::set(s, "shape", "oval"); }),
            "toy setting shape: 'oval' is not one of round|square");
  EXPECT_EQ(error_of([&] { settings::set_assignment(s, "gain"); }),
            "toy setting 'gain' is not of the form key=value");
  EXPECT_FALSE(error_of([&] { settings::set_assignment(s, "=1"); }).empty());
  EXPECT_FALSE(error_of([&] { (void)settings::get(s, "nope"); }).empty());
  EXPECT_EQ(s, ToySettings{});  // nothing changed
}

TEST(ParamTable, ValidateChecksRangesEnumsAndCrossFieldRule) {
  ToySettings s;
  settings::validate(s);
  s.taps = 0;
  EXPECT_EQ(error_of([&] { settings::validate(s); }),
            "toy setting taps = 0 is out of range [1, 9]");
  s = ToySettings{};
  s.shape = static_cast<Shape>(7);
  EXPECT_EQ(error_of([&] { settings::validate(s); }),
            "toy setting shape = ? is out of range round|square");
  s = ToySettings{};
  s.lo = 0.9f;
  EXPECT_EQ(error_of([&] { settings::validate(s); }), "toy settings: lo > hi");
}

TEST(ParamTable, JsonDescribeAndMarkdown) {
  ToySettings s;
  s.gain = 1.25f;
  const auto j = nlohmann::json::parse(settings::to_json(s));
  EXPECT_EQ(j.size(), 6u);
  EXPECT_EQ(j["gain"], 1.25);
  EXPECT_EQ(j["taps"], 3);
  EXPECT_TRUE(j["taps"].is_number_integer());
  EXPECT_EQ(j["enabled"], false);
  EXPECT_EQ(j["shape"], "round");

  const std::string d = settings::describe(s);
  EXPECT_NE(d.find("gain                       = 1.25           default 0.5, range [0, 2] -- "
                   "output gain\n"),
            std::string::npos)
      << d;
  EXPECT_NE(d.find("shape                      = round          default round, range "
                   "round|square -- kernel shape\n"),
            std::string::npos)
      << d;

  const std::string md = settings::markdown_table<ToySettings>();
  EXPECT_EQ(md.substr(0, md.find('\n')), "| key | default | range | description |");
  EXPECT_NE(md.find("| `taps` | `3` | [1, 9] | filter taps \\| odd |\n"), std::string::npos) << md;
  EXPECT_NE(md.find("| `enabled` | `false` | `true`, `false` | switch the toy on |\n"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| `shape` | `round` | `round`, `square` | kernel shape |\n"),
            std::string::npos)
      << md;
}

TEST(ParamTable, MemberCountCatchesUnregisteredMembers) {
  static_assert(aggregate_member_count<ToySettings>() == 6);
  static_assert(aggregate_member_count<ToyWithExtra>() == 2);
  EXPECT_TRUE(settings::all_members_registered<ToySettings>());
  EXPECT_FALSE(settings::all_members_registered<ToyWithExtra>());
  EXPECT_EQ(ToySettings::params().keys(),
            (std::vector<std::string>{"gain", "taps", "enabled", "shape", "lo", "hi"}));
  EXPECT_EQ(ToySettings::params().technique(), "toy");
}
