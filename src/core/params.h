// The generic parameter table (DESIGN.md §2 core/, §6 "parameters declared with name, default
// and range; unknown keys rejected": Halide's GeneratorParam{"levels", 8, 1, 16}, pbrt's
// ReportUnused()). A technique's plain Settings struct registers each member once — key,
// member pointer, range or enum names, one-line doc — and gets parsing with range checks,
// get, validate, JSON, the --list-settings listing and the README table from that one
// place. Defaults are never restated: they are read from a default-constructed S.
//
// Registration: give S a `static const ParamTable<S>& params();` returning an immutable
// function-local static (see taa/settings.cpp), and test
// `aggregate_member_count<S>() == S::params().size()` so a member added without a table
// entry fails the build's tests.
#pragma once

#include <fmt/format.h>

#include <array>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "core/error.h"

namespace afterimage {

// Names of an enum's values: the single table used by parsing, printing and JSON.
template <class E, std::size_t N>
using EnumNames = std::array<std::pair<E, const char*>, N>;

// The name of `v`, or "?" for a value outside the table (validate() rejects those).
template <class E, std::size_t N>
const char* enum_name(const EnumNames<E, N>& names, E v) {
  for (const auto& [e, n] : names)
    if (e == v) return n;
  return "?";
}

// A field's value as JSON sees it (floats widened to double, as nlohmann::json(float) does).
using ParamValue = std::variant<bool, std::int64_t, double, std::string>;

namespace params_detail {
// Non-template halves of the table (params.cpp): parsing with the user-facing messages, all
// of them naming the technique ("taa setting alpha: ...").
float parse_float(std::string_view technique, std::string_view key, std::string_view text, float lo,
                  float hi);
int parse_int(std::string_view technique, std::string_view key, std::string_view text, int lo,
              int hi);
bool parse_bool(std::string_view technique, std::string_view key, std::string_view text);
// Index of `text` in `names`; SettingsError listing the names otherwise.
std::size_t parse_enum(std::string_view technique, std::string_view key, std::string_view text,
                       const std::vector<std::string>& names);
[[noreturn]] void throw_unknown_key(std::string_view technique, std::string_view key,
                                    const std::vector<std::string>& valid);
[[noreturn]] void throw_not_assignment(std::string_view technique, std::string_view assignment);
[[noreturn]] void throw_out_of_range(std::string_view technique, std::string_view key,
                                     std::string_view value, std::string_view range);
[[noreturn]] void throw_cross_field(std::string_view technique, std::string_view message);
// {"key": value, ...} with sorted keys, indented by 2 (nlohmann::json::dump(2)).
std::string json_object(const std::vector<std::pair<std::string, ParamValue>>& fields);
std::string join(const std::vector<std::string>& items, std::string_view sep);
// Escapes '|' so a cell cannot split a markdown table row.
std::string markdown_cell(std::string_view text);

// Converts to any member type; declared only (used in unevaluated brace-initialisation).
struct AnyMember {
  template <class T>
  constexpr operator T() const noexcept;
};
}  // namespace params_detail

// Number of members of the aggregate S: the largest n for which S{x1, ..., xn} compiles
// (brace-init arity detection, the technique of Boost.PFR). Counts each direct member once
// provided members are scalars or enums, as in every Settings struct.
template <class S, class... Args>
constexpr std::size_t aggregate_member_count() {
  if constexpr (requires { S{Args{}..., params_detail::AnyMember{}}; })
    return aggregate_member_count<S, Args..., params_detail::AnyMember>();
  else
    return sizeof...(Args);
}

enum class ParamKind { Float, Int, Bool, Enum };

// The table of one Settings struct S. Build it once (add_* in declaration order, then
// check()), keep it const.
template <class S>
class ParamTable {
 public:
  // One settable field, type-erased over its member type.
  struct Field {
    std::string key;
    std::string doc;
    ParamKind kind;
    std::string range;  // "[lo, hi]", "true|false" or "a|b|c": listings and error messages
    std::vector<std::string> names;  // enum value names (empty otherwise)
    std::function<std::string(const S&)> get;
    std::function<void(S&, std::string_view)> parse_set;  // throws SettingsError
    std::function<bool(const S&)> in_range;
    std::function<ParamValue(const S&)> value;
  };

  // `technique` names the owner in every message ("taa" -> "taa setting alpha: ...").
  explicit ParamTable(std::string technique) : technique_(std::move(technique)) {}

  ParamTable& add_float(const char* key, float S::*m, float lo, float hi, const char* doc) {
    Field f = field(key, ParamKind::Float, fmt::format("[{}, {}]", lo, hi), doc);
    f.get = [m](const S& s) { return fmt::format("{}", s.*m); };
    f.parse_set = [m, lo, hi, k = std::string(key), t = technique_](S& s, std::string_view v) {
      s.*m = params_detail::parse_float(t, k, v, lo, hi);
    };
    f.in_range = [m, lo, hi](const S& s) { return s.*m >= lo && s.*m <= hi; };
    f.value = [m](const S& s) { return ParamValue(double(s.*m)); };
    return add(std::move(f));
  }

  ParamTable& add_int(const char* key, int S::*m, int lo, int hi, const char* doc) {
    Field f = field(key, ParamKind::Int, fmt::format("[{}, {}]", lo, hi), doc);
    f.get = [m](const S& s) { return fmt::format("{}", s.*m); };
    f.parse_set = [m, lo, hi, k = std::string(key), t = technique_](S& s, std::string_view v) {
      s.*m = params_detail::parse_int(t, k, v, lo, hi);
    };
    f.in_range = [m, lo, hi](const S& s) { return s.*m >= lo && s.*m <= hi; };
    f.value = [m](const S& s) { return ParamValue(std::int64_t(s.*m)); };
    return add(std::move(f));
  }

  ParamTable& add_bool(const char* key, bool S::*m, const char* doc) {
    Field f = field(key, ParamKind::Bool, "true|false", doc);
    f.get = [m](const S& s) { return std::string(s.*m ? "true" : "false"); };
    f.parse_set = [m, k = std::string(key), t = technique_](S& s, std::string_view v) {
      s.*m = params_detail::parse_bool(t, k, v);
    };
    f.in_range = [](const S&) { return true; };
    f.value = [m](const S& s) { return ParamValue(bool(s.*m)); };
    return add(std::move(f));
  }

  template <class E, std::size_t N>
  ParamTable& add_enum(const char* key, E S::*m, const EnumNames<E, N>& names, const char* doc) {
    std::vector<std::string> list;
    for (const auto& [e, n] : names) list.emplace_back(n);
    Field f = field(key, ParamKind::Enum, params_detail::join(list, "|"), doc);
    f.names = list;
    f.get = [m, names](const S& s) { return std::string(enum_name(names, s.*m)); };
    f.parse_set = [m, names, list, k = std::string(key), t = technique_](S& s, std::string_view v) {
      s.*m = names[params_detail::parse_enum(t, k, v, list)].first;
    };
    f.in_range = [m, names](const S& s) {
      for (const auto& [e, n] : names)
        if (e == s.*m) return true;
      return false;
    };
    f.value = [m, names](const S& s) { return ParamValue(std::string(enum_name(names, s.*m))); };
    return add(std::move(f));
  }

  // Cross-field rule run by validate() after the range checks: returns "" when `s` is
  // consistent, else the reason (reported as "<technique> settings: <reason>").
  ParamTable& check(std::function<std::string(const S&)> rule) {
    checks_.push_back(std::move(rule));
    return *this;
  }

  const std::string& technique() const { return technique_; }
  std::size_t size() const { return fields_.size(); }
  const std::vector<Field>& fields() const { return fields_; }

  // Every key, in registration (= declaration) order.
  std::vector<std::string> keys() const {
    std::vector<std::string> k;
    for (const auto& f : fields_) k.push_back(f.key);
    return k;
  }

  // Throws SettingsError for an unknown key (listing the valid ones).
  const Field& find(std::string_view key) const {
    for (const auto& f : fields_)
      if (f.key == key) return f;
    params_detail::throw_unknown_key(technique_, key, keys());
  }

  // Parses `value` into `s`; SettingsError (and `s` unchanged) for unknown keys, malformed or
  // out-of-range values.
  void set(S& s, std::string_view key, std::string_view value) const {
    find(key).parse_set(s, value);
  }
  // "key=value"
  void set_assignment(S& s, std::string_view assignment) const {
    const auto eq = assignment.find('=');
    if (eq == std::string_view::npos || eq == 0)
      params_detail::throw_not_assignment(technique_, assignment);
    set(s, assignment.substr(0, eq), assignment.substr(eq + 1));
  }
  std::string get(const S& s, std::string_view key) const { return find(key).get(s); }

  // Throws SettingsError naming the first field out of range, then the first failed check.
  void validate(const S& s) const {
    for (const auto& f : fields_)
      if (!f.in_range(s)) params_detail::throw_out_of_range(technique_, f.key, f.get(s), f.range);
    for (const auto& c : checks_)
      if (std::string why = c(s); !why.empty()) params_detail::throw_cross_field(technique_, why);
  }

  // {"alpha": 0.1, "history": "bilinear", ...}
  std::string to_json(const S& s) const {
    std::vector<std::pair<std::string, ParamValue>> v;
    for (const auto& f : fields_) v.emplace_back(f.key, f.value(s));
    return params_detail::json_object(v);
  }

  // One line per key: "key = value   default D, range R -- doc" (for --list-settings), the
  // defaults those of the struct unless a user of it has its own (run's sharpen stage).
  std::string describe(const S& s, const S& defaults = S{}) const {
    std::string out;
    for (const auto& f : fields_)
      out += fmt::format("{:<26} = {:<14} default {}, range {} -- {}\n", f.key, f.get(s),
                         f.get(defaults), f.range, f.doc);
    return out;
  }

  // | key | default | range | description | — the settings table of the README.
  std::string markdown_table() const {
    const S defaults{};
    std::string out = "| key | default | range | description |\n| --- | --- | --- | --- |\n";
    for (const auto& f : fields_) {
      std::string range = f.range;
      if (f.kind == ParamKind::Enum || f.kind == ParamKind::Bool) {
        std::vector<std::string> names = f.names;
        if (f.kind == ParamKind::Bool) names = {"true", "false"};
        for (auto& n : names) n = "`" + n + "`";
        range = params_detail::join(names, ", ");
      }
      out += fmt::format("| `{}` | `{}` | {} | {} |\n", f.key, f.get(defaults),
                         params_detail::markdown_cell(range), params_detail::markdown_cell(f.doc));
    }
    return out;
  }

 private:
  Field field(const char* key, ParamKind kind, std::string range, const char* doc) const {
    for (const auto& f : fields_) AI_CHECK(f.key != key);  // a key is registered once
    Field f;
    f.key = key;
    f.doc = doc;
    f.kind = kind;
    f.range = std::move(range);
    return f;
  }
  ParamTable& add(Field f) {
    fields_.push_back(std::move(f));
    return *this;
  }

  std::string technique_;
  std::vector<Field> fields_;
  std::vector<std::function<std::string(const S&)>> checks_;
};

// Generic access for any S with `static const ParamTable<S>& params()`.
template <class S>
concept HasParams = requires {
  { S::params() } -> std::same_as<const ParamTable<S>&>;
};

namespace settings {
template <HasParams S>
void set(S& s, std::string_view key, std::string_view value) {
  S::params().set(s, key, value);
}
template <HasParams S>
void set_assignment(S& s, std::string_view assignment) {
  S::params().set_assignment(s, assignment);
}
template <HasParams S>
std::string get(const S& s, std::string_view key) {
  return S::params().get(s, key);
}
template <HasParams S>
void validate(const S& s) {
  S::params().validate(s);
}
template <HasParams S>
std::string to_json(const S& s) {
  return S::params().to_json(s);
}
template <HasParams S>
std::string describe(const S& s) {
  return S::params().describe(s);
}
template <HasParams S>
std::string markdown_table() {
  return S::params().markdown_table();
}
// True when every member of the aggregate S has a table entry (the test each Settings struct
// runs; see aggregate_member_count).
template <HasParams S>
bool all_members_registered() {
  return aggregate_member_count<S>() == S::params().size();
}
}  // namespace settings

}  // namespace afterimage
