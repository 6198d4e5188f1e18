#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "eval/report.h"
#include "io/io.h"
#include "test_util.h"

using namespace afterimage;
namespace fs = std::filesystem;

namespace {
ReportData sample_report() {
  ReportData d;
  d.title = "Report test";
  d.commands = {"afterimage eval --out a --ref r"};
  SceneSection s;
  s.name = "synthetic";
  for (int m = 0; m < 3; ++m) {
    MethodSummary ms;
    ms.label = "method" + std::to_string(m);
    ms.aggregate = {{"psnr", 30.0 + m},
                    {"ssim", 0.9 + 0.01 * m},
                    {"flip", 0.1 - 0.01 * m},
                    {"sharpness", 0.5 + 0.45 * m}};  // 0.5, 0.95, 1.4: best is closest to 1
    for (int t = 0; t < 20; ++t) ms.per_frame["psnr"].push_back(25 + m + std::sin(t * 0.3));
    ms.ghosting = {0.3, 0.2, 0.1, 0.05, 0.03, 0.02, 0.01, 0.01};
    ms.ms_per_frame = 1.5 * m;
    s.methods.push_back(ms);
  }
  Figure f;
  f.title = "crop";
  ImageF img(32, 16, 3);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 32; ++x) img.at(x, y, 0) = x / 31.0f, img.at(x, y, 1) = y / 15.0f;
  f.panels.push_back({"gradient", img});
  s.figures.push_back(f);
  d.scenes.push_back(s);
  return d;
}
}  // namespace

TEST(Report, Base64KnownVectors) {
  auto enc = [](std::string s) {
    return base64_encode(std::vector<unsigned char>(s.begin(), s.end()));
  };
  EXPECT_EQ(enc(""), "");
  EXPECT_EQ(enc("f"), "Zg==");
  EXPECT_EQ(enc("fo"), "Zm8=");
  EXPECT_EQ(enc("foo"), "Zm9v");
  EXPECT_EQ(enc("foobar"), "Zm9vYmFy");
}

TEST(Report, HtmlIsSelfContainedWithTableAndPlots) {
  std::string h = render_report_html(sample_report());
  EXPECT_NE(h.find("<table class=\"results\">"), std::string::npos);
  EXPECT_NE(h.find("<svg"), std::string::npos);
  EXPECT_NE(h.find("data:image/png;base64,"), std::string::npos);
  EXPECT_EQ(h.find("http://"), h.find("http://www.w3.org/2000/svg"));  // only the SVG namespace
  EXPECT_EQ(h.find("https://"), std::string::npos);
  // Best value of each column is marked: method2 has the highest PSNR.
  EXPECT_NE(h.find("<td class=\"best\">32.000</td>"), std::string::npos);
  // Sharpness is best closest to 1 (an aliased image is "sharper" than the truth).
  EXPECT_NE(h.find("<td class=\"best\">0.9500</td>"), std::string::npos);
  EXPECT_EQ(h.find("<td class=\"best\">1.400</td>"), std::string::npos);
}

// Renders the report in headless Chromium: the page must load, show the table, and the
// screenshot must not be blank.
TEST(Report, RendersInHeadlessChromium) {
  const char* candidates[] = {"/usr/bin/chromium", "/usr/bin/chromium-browser"};
  std::string chromium;
  for (const char* c : candidates)
    if (fs::exists(c)) chromium = c;
  ASSERT_FALSE(chromium.empty()) << "chromium is not installed (scripts/setup-deps.sh installs it)";
  const fs::path dir = test::fresh_temp_dir("report_test");
  const fs::path html = dir / "report.html", png = dir / "shot.png", dom = dir / "dom.html";
  std::ofstream(html) << render_report_html(sample_report());
  const std::string flags =
      "--headless --no-sandbox --disable-gpu --disable-quic --no-first-run "
      "--disable-background-networking --disable-component-update --disable-sync "
      "--user-data-dir=" +
      (dir / "profile").string();
  std::string cmd = chromium + " " + flags +
                    " --window-size=1200,900 --screenshot=" + png.string() + " file://" +
                    html.string() + " > " + (dir / "log1.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  cmd = chromium + " " + flags + " --dump-dom file://" + html.string() + " > " + dom.string() +
        " 2> " + (dir / "log2.txt").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::stringstream ss;
  ss << std::ifstream(dom).rdbuf();
  EXPECT_NE(ss.str().find("class=\"results\""), std::string::npos);
  EXPECT_NE(ss.str().find("method2"), std::string::npos);
  ASSERT_TRUE(fs::exists(png));
  ImageF shot = io::read_rgb(png.string(), false);
  double mean = 0, var = 0;
  for (float v : shot.data()) mean += v;
  mean /= double(shot.data().size());
  for (float v : shot.data()) var += (v - mean) * (v - mean);
  var /= double(shot.data().size());
  EXPECT_GT(var, 1e-3) << "screenshot is blank";
}
