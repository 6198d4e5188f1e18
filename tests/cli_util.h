// Running the `afterimage` binary from tests: exit code, stdout and stderr of one command.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace afterimage::test {

// AFTERIMAGE_BIN, else the `afterimage` binary beside the test binary.
inline std::string cli_path() {
  if (const char* p = std::getenv("AFTERIMAGE_BIN")) return p;
  return (std::filesystem::read_symlink("/proc/self/exe").parent_path() / "afterimage").string();
}

struct CliRun {
  int code;  // exit code; -1 if killed by a signal
  std::string out, err;
};

#if defined(__SANITIZE_ADDRESS__)
#define AFTERIMAGE_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define AFTERIMAGE_TEST_ASAN 1
#endif
#endif

// A shell prefix that caps the memory of the command at `mb` megabytes: `ulimit -v` (address
// space) normally; under AddressSanitizer (scripts/sanitize.sh builds the CLI with it too),
// which reserves terabytes of address space at start-up, its own limit on one allocation.
inline std::string memory_limit(int mb) {
#ifdef AFTERIMAGE_TEST_ASAN
  return "ASAN_OPTIONS=\"$ASAN_OPTIONS:max_allocation_size_mb=" + std::to_string(mb) + "\" ";
#else
  return "ulimit -v " + std::to_string(int64_t(mb) * 1000) + "; ";
#endif
}

// Runs `afterimage <args>` through /bin/sh (args are shell words), capturing both streams.
// `prefix` goes before the binary (e.g. "ulimit -f 16;" or "timeout 20").
inline CliRun run(const std::string& args, const std::string& prefix = "") {
  static int n = 0;
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / "afterimage_cli_test_logs";
  std::filesystem::create_directories(dir);
  const std::string stem = std::to_string(getpid()) + "_" + std::to_string(n++);
  const std::filesystem::path o = dir / (stem + ".out"), e = dir / (stem + ".err");
  const std::string cmd =
      prefix + " " + cli_path() + " " + args + " > " + o.string() + " 2> " + e.string();
  const int rc = std::system(cmd.c_str());
  std::stringstream so, se;
  so << std::ifstream(o).rdbuf();
  se << std::ifstream(e).rdbuf();
  std::error_code ec;  // captured: the logs need not stay (the tests print what they check)
  std::filesystem::remove(o, ec);
  std::filesystem::remove(e, ec);
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, so.str(), se.str()};
}

// Error runs: exit 1 and exactly one line on stderr that names `needle`.
inline void expect_one_line_error(const CliRun& r, const std::string& needle) {
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

}  // namespace afterimage::test
