// Option values that several subcommands parse the same way.
#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <string>

#include "apps/cli/commands.h"
#include "core/error.h"
#include "core/limits.h"

namespace afterimage::cli {

void parse_size(const std::string& text, int* width, int* height) {
  // strtoll, not sscanf("%d"): an overlong number must be refused, not overflow.
  const auto bad = [&](const std::string& why) {
    return SettingsError(fmt::format("size '{}': {}", text, why));
  };
  const size_t x = text.find_first_of("xX");
  auto number = [&](const std::string& part) -> int64_t {
    if (part.empty() || part.size() > 9 ||
        !std::all_of(part.begin(), part.end(), [](char c) { return c >= '0' && c <= '9'; }))
      throw bad("expected WIDTHxHEIGHT, e.g. 640x360");
    return std::stoll(part);
  };
  if (x == std::string::npos) throw bad("expected WIDTHxHEIGHT, e.g. 640x360");
  const int64_t w = number(text.substr(0, x)), h = number(text.substr(x + 1));
  if (auto problem = image_size_problem(w, h)) throw SettingsError("--" + *problem);
  *width = int(w);
  *height = int(h);
}

}  // namespace afterimage::cli
