#include <fmt/format.h>

#include <malloc.h>

#include <csignal>
#include <exception>
#include <filesystem>

#include "afterimage/version.h"
#include "apps/cli/commands.h"
#include "core/error.h"
#include "core/limits.h"
#include "core/simd_target.h"
#include "io/io.h"

int main(int argc, char** argv) {
  // Frame-sized buffers (8-100 MB at 1080p) are allocated and freed every frame; above glibc's
  // mmap threshold each one is a fresh mapping whose pages fault in zeroed, measured ~20% of a
  // 1080p resolve. Images' buffers come from the library's frame buffer cache (core/image.h);
  // this keeps the others (OpenImageIO's file buffers, plain vectors) in the heap between frames.
  mallopt(M_MMAP_THRESHOLD, 1 << 30);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  using namespace afterimage;
  // A file-size limit (ulimit -f) then fails the write with EFBIG, reported like a full disk,
  // instead of killing the process.
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"afterimage: temporal reconstruction of rendered image sequences"};
  app.require_subcommand(1);
  app.set_version_flag("--version", fmt::format("afterimage {} ({})", AFTERIMAGE_VERSION_STRING,
                                                simd_description()));
  cli::Context ctx;
  for (int i = 0; i < argc; ++i) ctx.command_line += (i ? " " : "") + std::string(argv[i]);
  std::string simd = ctx.exec.simd ? "on" : "off";
  // Parsed wide so that 1e5 or 1e12 reach the range check below instead of failing
  // conversion or overflowing int.
  int64_t threads = ctx.exec.threads;
  app.add_option("--threads", threads,
                 fmt::format("worker threads, 0 = all (at most {})", kMaxThreads));
  app.add_option("--simd", simd, "on: full-width SIMD; off: 1-lane reference path")
      ->check(CLI::IsMember({"on", "off"}));
  app.parse_complete_callback([&] {
    ctx.exec.simd = simd == "on";
    if (auto problem = thread_count_problem(threads))
      throw SettingsError(fmt::format("--threads / AFTERIMAGE_THREADS: {}", *problem));
    ctx.exec.threads = int(threads);
    io::set_io_threads(ctx.exec.threads);  // OpenEXR's own pool decodes / encodes line blocks
  });

  cli::add_render_command(app, ctx);
  cli::add_info_command(app, ctx);
  cli::add_compare_command(app, ctx);
  cli::add_eval_command(app, ctx);
  cli::add_resolve_command(app, ctx);
  cli::add_denoise_command(app, ctx);
  cli::add_demo_command(app, ctx);
  cli::add_bench_command(app, ctx);
  cli::add_run_command(app, ctx);
  cli::add_extrapolate_command(app, ctx);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const Error& e) {
    fmt::print(stderr, "afterimage: error: {}\n", e.what());
    return 1;
  } catch (const std::filesystem::filesystem_error& e) {
    // An environment problem on a path (not a bug): one line naming the path.
    fmt::print(stderr, "afterimage: error: {}: {}\n", e.path1().string(), e.code().message());
    return 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "afterimage: internal error: {}\n", e.what());
    return 2;
  }
  return 0;
}
