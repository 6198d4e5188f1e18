// Fuzz target: text -> method specs and settings assignments (run/methods.h,
// core/params.h), what `--method`, `--preset` and `--set key=value` hand the library.
//
// Input: lines. Line 1 is a method spec ("taa:hdrp+alpha=0.2", "hdrp", ...) given to
// parse_method_spec / method_label / method_command / make_method. Every further line is a
// "key=value" assignment applied, in order, to TaaSettings and to SharpenSettings through
// their parameter tables, and appended to "taa:afterimage" as `resolve --set` does.
//
// Contracts checked beyond "no crash": a method make_method accepts processes frames without
// throwing; settings that validate() print and parse back to the same settings (get -> set
// round trip of every key), and their JSON and listing never throw.
#include <cstdio>
#include <string>
#include <vector>

#include "fuzz_common.h"
#include "post/sharpen.h"
#include "run/methods.h"
#include "taa/settings.h"

namespace afterimage::fuzz {
namespace {

[[noreturn]] void contract_broken(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_settings: contract broken: %s: %s\n", what, detail.c_str());
  std::abort();
}

std::vector<std::string> lines(std::string_view text) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    out.emplace_back(text.substr(start, end - start));
    start = end + 1;
  }
  return out;
}

// A method the registry built: its listing works and it resolves two frames.
void exercise(SequenceMethod& m) {
  static const Frame f0 = tiny_frame(8, 4, 0), f1 = tiny_frame(8, 4, 1);
  (void)m.name();
  (void)m.settings_json();
  (void)m.describe_settings();
  for (const Frame* f : {&f0, &f1}) {
    const Frame out = m.process(*f);  // validated settings: any exception is a finding
    if (out.color.width() != f->width || out.color.height() != f->height)
      contract_broken("output size differs from the input", m.name());
  }
}

void try_spec(const std::string& spec) {
  expect_errors([&] { (void)parse_method_spec(spec); });
  expect_errors([&] { (void)method_label(spec); });
  expect_errors([&] { (void)method_command(spec); });
  std::unique_ptr<SequenceMethod> m;
  if (expect_errors([&] { m = make_method(spec, Exec{1, true}); })) exercise(*m);
}

// Settings that validate must survive get -> set for every key.
template <class S>
void check_round_trip(const S& s) {
  const auto& table = S::params();
  S back{};
  for (const auto& key : table.keys()) {
    const std::string text = table.get(s, key);
    try {
      table.set(back, key, text);
    } catch (const SettingsError& e) {
      contract_broken("a printed value does not parse back", e.what());
    }
  }
  if (!(back == s)) contract_broken("get -> set changed the settings", table.to_json(s));
  (void)table.to_json(s);
  (void)table.describe(s);
}

}  // namespace
}  // namespace afterimage::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace afterimage;
  using namespace afterimage::fuzz;
  if (size > 4096) return 0;  // specs are short; long inputs only slow the search down
  const std::vector<std::string> in =
      lines(std::string_view(reinterpret_cast<const char*>(data), size));

  try_spec(in.front());

  taa::TaaSettings taa_s;
  post::SharpenSettings sharpen_s;
  std::string cli_spec = "taa:afterimage";
  for (size_t i = 1; i < in.size(); ++i) {
    expect_errors([&] { taa_s.set_assignment(in[i]); });
    expect_errors([&] { post::SharpenSettings::params().set_assignment(sharpen_s, in[i]); });
    cli_spec += "+" + in[i];
  }
  if (expect_errors([&] { taa_s.validate(); })) check_round_trip(taa_s);
  if (expect_errors([&] { post::SharpenSettings::params().validate(sharpen_s); }))
    check_round_trip(sharpen_s);
  if (in.size() > 1) try_spec(cli_spec);
  return 0;
}
