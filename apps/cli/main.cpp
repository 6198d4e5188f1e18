#include <fmt/format.h>

#include <exception>

#include "apps/cli/commands.h"
#include "core/error.h"

int main(int argc, char** argv) {
  using namespace afterimage;
  CLI::App app{"afterimage: temporal reconstruction of rendered image sequences"};
  app.require_subcommand(1);
  cli::Context ctx;
  for (int i = 0; i < argc; ++i) ctx.command_line += (i ? " " : "") + std::string(argv[i]);
  std::string simd = ctx.exec.simd ? "on" : "off";
  app.add_option("--threads", ctx.exec.threads, "worker threads (0 = all)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--simd", simd, "on: full-width SIMD; off: 1-lane reference path")
      ->check(CLI::IsMember({"on", "off"}));
  app.parse_complete_callback([&] { ctx.exec.simd = simd == "on"; });

  cli::add_render_command(app, ctx);
  cli::add_info_command(app, ctx);
  cli::add_compare_command(app, ctx);
  cli::add_eval_command(app, ctx);
  cli::add_resolve_command(app, ctx);
  cli::add_demo_command(app, ctx);
  cli::add_bench_command(app, ctx);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const Error& e) {
    fmt::print(stderr, "afterimage: error: {}\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "afterimage: internal error: {}\n", e.what());
    return 2;
  }
  return 0;
}
