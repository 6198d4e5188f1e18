// Running the `afterimage` binary from tests: exit code, stdout and stderr of one command.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
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
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, so.str(), se.str()};
}

// Error runs: exit 1 and exactly one line on stderr that names `needle`.
inline void expect_one_line_error(const CliRun& r, const std::string& needle) {
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

}  // namespace afterimage::test
