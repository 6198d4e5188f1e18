#include "core/params.h"

#include <charconv>
#include <nlohmann/json.hpp>
#include <system_error>

namespace afterimage::params_detail {

float parse_float(std::string_view technique, std::string_view key, std::string_view text, float lo,
                  float hi) {
  float x = 0.0f;
  const char* e = text.data() + text.size();
  const auto r = std::from_chars(text.data(), e, x);
  if (r.ec != std::errc() || r.ptr != e)
    throw SettingsError(fmt::format("{} setting {}: '{}' is not a number", technique, key, text));
  // Written so that NaN fails too.
  if (!(x >= lo && x <= hi))
    throw SettingsError(
        fmt::format("{} setting {}: {} is out of range [{}, {}]", technique, key, text, lo, hi));
  return x;
}

int parse_int(std::string_view technique, std::string_view key, std::string_view text, int lo,
              int hi) {
  int x = 0;
  const char* e = text.data() + text.size();
  const auto r = std::from_chars(text.data(), e, x);
  if (r.ec == std::errc::result_out_of_range || (r.ec == std::errc() && (x < lo || x > hi)))
    throw SettingsError(
        fmt::format("{} setting {}: {} is out of range [{}, {}]", technique, key, text, lo, hi));
  if (r.ec != std::errc() || r.ptr != e)
    throw SettingsError(fmt::format("{} setting {}: '{}' is not an integer", technique, key, text));
  return x;
}

bool parse_bool(std::string_view technique, std::string_view key, std::string_view text) {
  if (text == "true" || text == "1" || text == "on" || text == "yes") return true;
  if (text == "false" || text == "0" || text == "off" || text == "no") return false;
  throw SettingsError(fmt::format("{} setting {}: '{}' is not a boolean (true|false|on|off|1|0)",
                                  technique, key, text));
}

std::size_t parse_enum(std::string_view technique, std::string_view key, std::string_view text,
                       const std::vector<std::string>& names) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == text) return i;
  throw SettingsError(
      fmt::format("{} setting {}: '{}' is not one of {}", technique, key, text, join(names, "|")));
}

void throw_unknown_key(std::string_view technique, std::string_view key,
                       const std::vector<std::string>& valid) {
  throw SettingsError(
      fmt::format("unknown {} setting '{}'; valid keys: {}", technique, key, join(valid, ", ")));
}

void throw_not_assignment(std::string_view technique, std::string_view assignment) {
  throw SettingsError(
      fmt::format("{} setting '{}' is not of the form key=value", technique, assignment));
}

void throw_out_of_range(std::string_view technique, std::string_view key, std::string_view value,
                        std::string_view range) {
  throw SettingsError(
      fmt::format("{} setting {} = {} is out of range {}", technique, key, value, range));
}

void throw_cross_field(std::string_view technique, std::string_view message) {
  throw SettingsError(fmt::format("{} settings: {}", technique, message));
}

std::string json_object(const std::vector<std::pair<std::string, ParamValue>>& fields) {
  nlohmann::json j = nlohmann::json::object();
  // Not a structured binding: clang 14 (the fuzz build) cannot capture one in a lambda.
  for (const auto& field : fields)
    std::visit([&j, &field](const auto& v) { j[field.first] = v; }, field.second);
  return j.dump(2);
}

std::string join(const std::vector<std::string>& items, std::string_view sep) {
  std::string s;
  for (const auto& i : items) {
    if (!s.empty()) s += sep;
    s += i;
  }
  return s;
}

std::string markdown_cell(std::string_view text) {
  std::string s;
  for (char c : text) {
    if (c == '|') s += '\\';
    s += c;
  }
  return s;
}

}  // namespace afterimage::params_detail
