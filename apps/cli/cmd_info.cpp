#include <fmt/format.h>

#include "apps/cli/commands.h"
#include "io/io.h"

namespace afterimage::cli {

void add_info_command(CLI::App& app, Context&) {
  auto* sub = app.add_subcommand("info", "print channels, size and metadata of an image file");
  auto file = std::make_shared<std::string>();
  sub->add_option("FILE", *file, "image file (EXR, PNG, ...)")->required();
  sub->callback([file] { fmt::print("{}", io::describe_file(*file)); });
}

}  // namespace afterimage::cli
