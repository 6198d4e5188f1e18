// tools/opencv_nlm.py, the OpenCV multi-frame NLM peer through OpenCV's Python binding (issue 11,
// "Peers and baselines"): on a small path-traced `room` sequence it writes frames that
// `afterimage eval` scores, better than the raw 1-spp input; the PSNR it prints for the h it
// keeps is eval's; bad arguments give one line and a non-zero exit; the input is never touched.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "cli_util.h"
#include "test_util.h"

namespace afterimage {
namespace {

namespace fs = std::filesystem;

// Debian's interpreter (python3-opencv installs into it; a pyenv or venv python3 on PATH may not
// see the package).
std::string python() {
  return fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
}
std::string script() {
  return (fs::path(AFTERIMAGE_TESTDATA_DIR) / ".." / ".." / "tools" / "opencv_nlm.py").string();
}

struct Shell {
  int code;
  std::string out;
};
Shell shell(const std::string& cmd) {
  // This process's own log (a fixed name would be shared by two test runs on one machine).
  const fs::path log =
      fs::temp_directory_path() / ("afterimage_nlm_tool_" + std::to_string(getpid()) + ".log");
  const int rc = std::system((cmd + " > " + log.string() + " 2>&1").c_str());
  std::string text;
  if (FILE* f = std::fopen(log.c_str(), "r")) {
    char buf[4096];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
    std::fclose(f);
  }
  std::error_code ec;  // read: the log need not stay (the tests print what they check)
  fs::remove(log, ec);
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, text};
}

double eval_psnr(const std::string& out, const std::string& ref, const std::string& label) {
  const test::CliRun r = test::run("eval --warmup 0 --out " + out + " --ref " + ref);
  EXPECT_EQ(r.code, 0) << r.err;
  const size_t row = r.out.find("\n" + label + " ");
  if (row == std::string::npos) {
    ADD_FAILURE() << r.out;
    return 0.0;
  }
  return std::stod(r.out.substr(row + label.size() + 2));
}

TEST(ToolsOpencvNlm, DenoisesARoomSequenceThatEvalScores) {
  // scripts/setup-deps.sh installs python3-opencv; without it this test fails (it is the only
  // run of the script), with the install command in the message.
  ASSERT_EQ(shell(python() + " -c 'import cv2'").code, 0)
      << "python3-opencv is missing: apt-get install python3-opencv";
  const fs::path dir = test::fresh_temp_dir("nlm_tool");
  const std::string noisy = (dir / "noisy").string(), out = (dir / "nlm").string();
  test::CliRun r = test::run("render --scene room --path-trace --frames 5 --size 48x27 --out " +
                             noisy + " --reference 32");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string ref = noisy + "/reference";
  const auto before = fs::last_write_time(noisy + "/frame.0002.exr");

  Shell s = shell(python() + " " + script() + " --in " + noisy + " --out " + out +
                  " --h 12,30 --ref " + ref);
  ASSERT_EQ(s.code, 0) << s.out;
  EXPECT_NE(s.out.find("h 12: "), std::string::npos) << s.out;
  EXPECT_NE(s.out.find("h 30: "), std::string::npos) << s.out;
  EXPECT_NE(s.out.find("ms/frame"), std::string::npos) << s.out;
  for (int k = 0; k < 5; ++k)
    EXPECT_TRUE(fs::exists(out + "/frame.000" + std::to_string(k) + ".exr")) << k;

  const double raw = eval_psnr(noisy, ref, "noisy"), nlm = eval_psnr(out, ref, "nlm");
  std::printf("room 48x27, 5 frames: raw %.2f dB, OpenCV NLM (script) %.2f dB\n", raw, nlm);
  EXPECT_GT(nlm, raw + 1.0);
  // The script's own score of the h it kept is eval's (the same display transform).
  const size_t kept = s.out.find("wrote 5 frames with h ");
  ASSERT_NE(kept, std::string::npos) << s.out;
  const std::string h = s.out.substr(kept + 22, s.out.find(' ', kept + 22) - kept - 22);
  const size_t line = s.out.find("h " + h + ": ");
  ASSERT_NE(line, std::string::npos) << s.out;
  const size_t at = s.out.find("display PSNR ", line);
  ASSERT_NE(at, std::string::npos) << s.out;
  EXPECT_NEAR(std::stod(s.out.substr(at + 13)), nlm, 0.01) << s.out;

  // Bad arguments: one line, non-zero exit, nothing written over the input.
  for (const std::string& bad :
       {" --out " + noisy + " --h 10", " --out " + out + " --h -3", " --out " + out + " --h 6,9",
        " --out " + out + " --h 10 --window 4"}) {
    s = shell(python() + " " + script() + " --in " + noisy + bad);
    EXPECT_NE(s.code, 0) << bad;
    EXPECT_EQ(std::count(s.out.begin(), s.out.end(), '\n'), 1) << bad << ": " << s.out;
    EXPECT_NE(s.out.find("opencv_nlm: "), std::string::npos) << s.out;
  }
  EXPECT_EQ(fs::last_write_time(noisy + "/frame.0002.exr"), before);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace afterimage
