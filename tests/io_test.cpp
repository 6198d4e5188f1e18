#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "io/io.h"

using namespace afterimage;
namespace fs = std::filesystem;

namespace {
fs::path temp_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("afterimage_io_test_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

Frame random_frame(int w, int h, unsigned seed) {
  Frame f = Frame::allocate(w, h);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-3.0f, 30.0f);
  for (ImageF* img : {&f.color, &f.normal, &f.albedo, &f.motion})
    for (float& v : img->data()) v = u(rng);
  for (float& v : f.depth.data()) v = std::abs(u(rng)) + 0.1f;
  f.depth.at(1, 1, 0) = kBackgroundDepth;
  for (uint32_t& v : f.id.data()) v = rng();  // full 32-bit range must survive
  Camera cam;
  cam.view = look_at({1.1, 2.3, 7.7}, {0.3, 0, 0}, {0, 1, 0});
  f.view = cam.view;
  f.projection = cam.projection(w, h);
  f.jitter = {0.123456789012345, -0.3141592653589793};
  f.index = 17;
  f.time = 17.0 / 30.0;
  f.lens = {35.0, 2.8, 4.5, 36.0};
  return f;
}
}  // namespace

TEST(Io, FrameRoundTripIsBitExact) {
  fs::path d = temp_dir("roundtrip");
  Frame f = random_frame(37, 23, 1);
  const std::string p = io::frame_path(d.string(), 17);
  EXPECT_EQ(fs::path(p).filename(), "frame.0017.exr");
  io::write_frame(p, f);
  Frame g = io::read_frame(p, {"color", "depth", "normal", "albedo", "motion", "id"});
  EXPECT_EQ(g.width, 37);
  EXPECT_EQ(g.height, 23);
  EXPECT_TRUE(g.color == f.color);
  EXPECT_TRUE(g.depth == f.depth);
  EXPECT_TRUE(g.normal == f.normal);
  EXPECT_TRUE(g.albedo == f.albedo);
  EXPECT_TRUE(g.motion == f.motion);
  EXPECT_TRUE(g.id == f.id);
  EXPECT_TRUE(g.view == f.view);
  EXPECT_TRUE(g.projection == f.projection);
  EXPECT_EQ(g.jitter, f.jitter);
  EXPECT_EQ(g.index, 17);
  EXPECT_EQ(g.time, f.time);
  EXPECT_EQ(g.lens, f.lens);
  // Nothing but the frame is left in the directory (atomic write leaves no temp file).
  int n = 0;
  for (auto& e : fs::directory_iterator(d)) (void)e, ++n;
  EXPECT_EQ(n, 1);
}

TEST(Io, InfiniteOrNanDepthLoadsAsBackground) {
  fs::path d = temp_dir("depth");
  Frame f = random_frame(9, 5, 2);
  f.depth.at(0, 0, 0) = std::numeric_limits<float>::infinity();
  f.depth.at(1, 0, 0) = std::numeric_limits<float>::quiet_NaN();
  f.depth.at(2, 0, 0) = 3e20f;
  io::write_frame((d / "frame.0000.exr").string(), f);
  Frame g = io::read_frame((d / "frame.0000.exr").string(), {"depth"});
  EXPECT_EQ(g.depth.at(0, 0, 0), kBackgroundDepth);
  EXPECT_EQ(g.depth.at(1, 0, 0), kBackgroundDepth);
  EXPECT_EQ(g.depth.at(2, 0, 0), kBackgroundDepth);
  EXPECT_EQ(g.depth.at(3, 0, 0), f.depth.at(3, 0, 0));
}

TEST(Io, MissingChannelIsOneLineErrorNamingFileAndChannel) {
  fs::path d = temp_dir("missing");
  Frame f = random_frame(8, 6, 3);
  f.motion = ImageF();
  const std::string p = (d / "frame.0000.exr").string();
  io::write_frame(p, f);
  try {
    io::read_frame(p, {"color", "motion"});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    std::string m = e.what();
    EXPECT_NE(m.find(p), std::string::npos) << m;
    EXPECT_NE(m.find("motion.X"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
  // Optional groups may be absent when not required.
  EXPECT_NO_THROW(io::read_frame(p, {"color"}));
}

TEST(Io, UnreadableAndCorruptFilesAreInputErrors) {
  fs::path d = temp_dir("corrupt");
  EXPECT_THROW(io::read_frame((d / "nope.exr").string()), InputError);
  const std::string p = (d / "frame.0000.exr").string();
  io::write_frame(p, random_frame(31, 17, 4));
  // Truncate the file to half its size.
  auto size = fs::file_size(p);
  fs::resize_file(p, size / 2);
  EXPECT_THROW(io::read_frame(p), InputError);
  // Garbage bytes.
  std::ofstream(d / "junk.exr") << "this is not an EXR file";
  EXPECT_THROW(io::read_frame((d / "junk.exr").string()), InputError);
}

TEST(Io, SizeMismatchAcrossSequenceIsReported) {
  fs::path d = temp_dir("sizes");
  io::write_frame(io::frame_path(d.string(), 0), random_frame(8, 6, 5));
  io::write_frame(io::frame_path(d.string(), 1), random_frame(9, 6, 6));
  auto files = io::list_sequence(d.string());
  ASSERT_EQ(files.size(), 2u);
  Frame a = io::read_frame(files[0]);
  Frame b = io::read_frame(files[1]);
  EXPECT_NO_THROW(io::check_same_size(a, 8, 6, files[0]));
  try {
    io::check_same_size(b, a.width, a.height, files[1]);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("frame.0001.exr"), std::string::npos);
  }
  EXPECT_THROW(io::list_sequence((d / "empty").string()), InputError);
}

TEST(Io, RefusesToOverwriteAnInput) {
  fs::path d = temp_dir("overwrite");
  const std::string p = io::frame_path(d.string(), 0);
  Frame f = random_frame(8, 6, 7);
  io::write_frame(p, f);
  io::InputRegistry inputs;
  Frame g = io::read_frame(p, {"color"}, &inputs);
  g.color.fill(0.0f);
  // Through another spelling of the same path, too.
  EXPECT_THROW(io::write_frame((d / "." / "frame.0000.exr").string(), g, &inputs), InputError);
  Frame again = io::read_frame(p);
  EXPECT_TRUE(again.color == f.color);  // input untouched
}

// A failed write is an OutputError naming the file, leaving no temporary; text outputs get the
// same refusal to replace an input as images.
TEST(Io, FailedWritesAreOutputErrors) {
  fs::path d = temp_dir("write_fail");
  { std::ofstream(d / "blocker") << "a regular file"; }
  const std::string p = (d / "blocker" / "frame.0000.exr").string();
  try {
    io::write_frame(p, random_frame(8, 6, 7));
    FAIL() << "expected OutputError";
  } catch (const OutputError& e) {
    EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what();
  }
  EXPECT_THROW(io::write_rgb((d / "blocker" / "x.png").string(), ImageF(4, 4, 3)), OutputError);
  EXPECT_THROW(io::write_rgb((d / "x.unknown-format").string(), ImageF(4, 4, 3)), OutputError);

  const std::string frame = io::frame_path(d.string(), 0);
  io::write_frame(frame, random_frame(8, 6, 7));
  io::InputRegistry inputs;
  io::read_frame(frame, {"color"}, &inputs);
  EXPECT_THROW(io::write_text(frame, "{}", &inputs), InputError);
  io::write_text((d / "m.json").string(), "{}\n", &inputs);
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(d)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"blocker", "frame.0000.exr", "m.json"}));
}

TEST(Io, PngIsReadAsSrgbDecoded) {
  fs::path d = temp_dir("png");
  ImageF img(5, 3, 3, 0.5f);
  io::write_rgb((d / "a.png").string(), img);
  ImageF back = io::read_rgb((d / "a.png").string());
  // 0.5 quantises to 128/255, then decodes through the sRGB curve.
  EXPECT_NEAR(back.at(2, 1, 0), 0.2158605f, 1e-5f);
  ImageF raw = io::read_rgb((d / "a.png").string(), false);
  EXPECT_NEAR(raw.at(2, 1, 0), 128.0f / 255.0f, 1e-6f);
  auto bytes = io::encode_png(img);
  ASSERT_GT(bytes.size(), 8u);
  EXPECT_EQ(bytes[1], 'P');
}
