#include "pipeline/methods.h"

#include <fmt/format.h>

#include "core/error.h"
#include "taa/presets.h"
#include "taa/taa_method.h"

namespace afterimage {

namespace {

std::unique_ptr<SequenceMethod> make_taa(const std::string& label, const std::string& variant,
                                         const std::vector<std::string>& overrides,
                                         const Exec& exec) {
  taa::TaaSettings s = taa::make_preset(variant);
  for (const auto& kv : overrides) s.set_assignment(kv);
  s.validate();
  return std::make_unique<taa::TaaMethod>(label, s, exec);
}

std::string taa_settings_markdown() {
  return taa::TaaSettings::params().markdown_table();
}

std::vector<std::string> taa_demo_variants() {
  // Every published preset; "none" (no rectification) is a reference for tests.
  std::vector<std::string> v;
  for (const auto& p : taa::preset_names())
    if (p != "none") v.push_back(p);
  return v;
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (true) {
    const size_t at = s.find(sep, start);
    parts.push_back(s.substr(start, at == std::string::npos ? at : at - start));
    if (at == std::string::npos) return parts;
    start = at + 1;
  }
}

const MethodFamily& family(const std::string& technique, const std::string& spec) {
  for (const MethodFamily& f : method_families())
    if (f.technique == technique) return f;
  std::vector<std::string> names;
  for (const MethodFamily& f : method_families()) names.push_back(f.technique);
  throw SettingsError(fmt::format("method '{}': unknown technique '{}' (valid: {})", spec,
                                  technique, fmt::join(names, ", ")));
}

}  // namespace

const std::vector<MethodFamily>& method_families() {
  // Immutable table: one entry per technique.
  static const std::vector<MethodFamily> kFamilies = {
      {"taa", "TAA", "afterimage resolve --preset",
       "temporal anti-aliasing (taa/); variants are the named presets", taa::preset_names(),
       taa_demo_variants(), &taa_settings_markdown, &make_taa},
  };
  return kFamilies;
}

MethodSpec parse_method_spec(const std::string& spec) {
  const std::vector<std::string> parts = split(spec, '+');
  const std::string& head = parts.front();
  const size_t colon = head.find(':');
  MethodSpec m;
  m.technique =
      colon == std::string::npos ? method_families().front().technique : head.substr(0, colon);
  m.variant = colon == std::string::npos ? head : head.substr(colon + 1);
  m.overrides.assign(parts.begin() + 1, parts.end());
  family(m.technique, spec);  // throws for unknown techniques
  return m;
}

std::unique_ptr<SequenceMethod> make_method(const std::string& spec, const Exec& exec) {
  const MethodSpec m = parse_method_spec(spec);
  const std::string label = spec.find(':') == std::string::npos ? m.technique + ":" + spec : spec;
  return family(m.technique, spec).make(label, m.variant, m.overrides, exec);
}

std::string method_label(const std::string& spec) {
  const MethodSpec m = parse_method_spec(spec);
  std::string s = family(m.technique, spec).label + " " + m.variant;
  for (const auto& kv : m.overrides) s += "+" + kv;
  return s;
}

std::string method_command(const std::string& spec) {
  const MethodSpec m = parse_method_spec(spec);
  std::string s = family(m.technique, spec).command + " " + m.variant;
  for (const auto& kv : m.overrides) s += " --set " + kv;
  return s;
}

std::vector<std::string> method_names() {
  std::vector<std::string> names;
  for (const MethodFamily& f : method_families())
    for (const auto& v : f.variants) names.push_back(f.technique + ":" + v);
  return names;
}

std::vector<std::string> default_demo_methods() {
  std::vector<std::string> names;
  for (const MethodFamily& f : method_families())
    for (const auto& v : f.demo_variants) names.push_back(f.technique + ":" + v);
  return names;
}

const std::vector<std::string>& method_variants(const std::string& technique) {
  return family(technique, technique).variants;
}

std::string settings_markdown(const std::string& technique) {
  return family(technique, technique).settings_markdown();
}

std::string default_variant(const std::string& technique) {
  return method_variants(technique).front();
}

}  // namespace afterimage
