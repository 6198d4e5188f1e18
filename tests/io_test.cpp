#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include "io/io.h"
#include "test_util.h"

using namespace afterimage;
namespace fs = std::filesystem;

namespace {
// <temp>/afterimage_io_test_<name>, emptied.
fs::path temp_dir(const std::string& name) {
  return test::fresh_temp_dir("io_test_" + name);
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

namespace {
// Every row of the table present, filled with distinct random values.
Frame full_frame(int w, int h, unsigned seed) {
  Frame f = random_frame(w, h, seed);
  std::mt19937 rng(seed + 100);
  std::uniform_real_distribution<float> u(-5.0f, 5.0f);
  for (const ChannelInfo& r : kChannelTable) {
    if (r.core) continue;
    f.allocate_channel(r.key);
    for (float& v : f.plane_set(r.key)->data()) v = u(rng);
  }
  return f;
}

// Writes a float EXR with the given channel names; plane c of pixel i holds value(c, i).
template <class ValueFn>
void write_foreign_exr(const std::string& path, int w, int h, const std::vector<std::string>& names,
                       ValueFn value) {
  OIIO::ImageSpec spec(w, h, int(names.size()), OIIO::TypeDesc::FLOAT);
  spec.channelnames = names;
  std::vector<float> px(size_t(w) * h * names.size());
  for (size_t i = 0; i < size_t(w) * h; ++i)
    for (size_t c = 0; c < names.size(); ++c) px[i * names.size() + c] = value(int(c), int(i));
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out);
  ASSERT_TRUE(out->open(path, spec));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, px.data()));
  ASSERT_TRUE(out->close());
}

std::string error_of(const std::function<void()>& fn) {
  return test::error_of<InputError>(fn, "(no InputError)");
}
}  // namespace

TEST(Io, EveryChannelRoundTripsExactly) {
  fs::path d = temp_dir("every_channel");
  const Frame f = full_frame(19, 11, 8);
  const std::string p = io::frame_path(d.string(), 3);
  io::write_frame(p, f);
  const Frame g = io::read_frame(p, test::every_channel(), "test");
  for (const ChannelInfo& r : kChannelTable) {
    ASSERT_TRUE(g.has(r.key)) << r.name;
    if (r.type == PixelType::U32)
      EXPECT_TRUE(*g.plane_set_u32(r.key) == *f.plane_set_u32(r.key)) << r.name;
    else
      EXPECT_TRUE(*g.plane_set(r.key) == *f.plane_set(r.key)) << r.name;
  }
  // One file channel per plane, each with its table type.
  const std::string info = io::describe_file(p);
  size_t planes = 0;
  for (const ChannelInfo& r : kChannelTable) {
    planes += size_t(r.planes);
    for (int c = 0; c < r.planes; ++c) {
      const std::string want =
          fmt::format(" {}({})", r.exr[size_t(c)], r.type == PixelType::U32 ? "uint" : "float");
      EXPECT_NE(info.find(want), std::string::npos) << want << "\n" << info;
    }
  }
  EXPECT_NE(info.find(fmt::format("channels ({}):", planes)), std::string::npos) << info;
  EXPECT_EQ(io::read_channels(p).channels(), int(planes));
}

TEST(Io, OptionalChannelsStayAbsentWhenNotInTheFile) {
  fs::path d = temp_dir("optional");
  const std::string p = io::frame_path(d.string(), 0);
  Frame f = random_frame(8, 6, 9);
  f.allocate_channel(Channel::roughness);
  f.roughness.fill(0.25f);
  io::write_frame(p, f);
  const Frame g = io::read_frame(p);
  for (const ChannelInfo& r : kChannelTable)
    EXPECT_EQ(g.has(r.key), r.core || r.key == Channel::roughness) << r.name;
  EXPECT_TRUE(g.emission.empty());
  EXPECT_TRUE(g.motion_next.empty());
  EXPECT_EQ(g.roughness.at(7, 5, 0), 0.25f);
}

TEST(Io, MissingRequiredChannelNamesFileChannelAndRequester) {
  fs::path d = temp_dir("required");
  const std::string p = io::frame_path(d.string(), 3);
  Frame f = random_frame(8, 6, 10);
  f.motion = ImageF();
  io::write_frame(p, f);
  const std::string m = error_of([&] {
    io::read_frame(p, {Channel::color, Channel::motion}, "taa");
  });
  EXPECT_EQ(m, p + ": missing channel(s) motion.X motion.Y (motion, required by taa)");
  const std::string v = error_of([&] { io::read_frame(p, {Channel::variance}, "svgf"); });
  EXPECT_EQ(v, p + ": missing channel(s) variance (variance, required by svgf)");
  EXPECT_NO_THROW(io::read_frame(p, {Channel::color, Channel::depth}, "taa"));
  // String keys are checked against the table.
  EXPECT_THROW(io::read_frame(p, {"colour"}), SettingsError);
}

TEST(Io, PartlyPresentChannelIsAnError) {
  fs::path d = temp_dir("partial");
  const std::string p = (d / "frame.0000.exr").string();
  write_foreign_exr(p, 5, 4, {"R", "G", "B", "motion_next.X"}, [](int, int) { return 1.0f; });
  const std::string m = error_of([&] { io::read_frame(p); });
  EXPECT_NE(m.find(p), std::string::npos) << m;
  EXPECT_NE(m.find("motion_next.Y"), std::string::npos) << m;
  EXPECT_EQ(m.find("motion_next.X"), std::string::npos) << m;  // names only what is missing
}

TEST(Io, ForeignLayoutRenamesAndConverts) {
  fs::path d = temp_dir("layout");
  const std::string p = (d / "render.0001.exr").string();
  const int w = 7, h = 3;
  const std::vector<std::string> names = {"View.Combined.R", "View.Combined.G", "View.Combined.B",
                                          "View.Vector.X",   "View.Vector.Y",   "View.Depth.Z"};
  // Plane c of pixel i holds 10 c + i / 8 (exact in float); depth is infinite in pixel 0.
  auto value = [](int c, int i) {
    if (c == 5 && i == 0) return std::numeric_limits<float>::infinity();
    return 10.0f * c + i / 8.0f;
  };
  write_foreign_exr(p, w, h, names, value);

  Layout layout("tool");
  layout.map(Channel::color, {"View.Combined.R", "View.Combined.G", "View.Combined.B"});
  // The tool's motion is +y up: flip y. Depth gets a scale and an offset (cm -> m, shifted).
  layout.map(Channel::motion, {"View.Vector.X", "View.Vector.Y"},
             {{"", 1.0, 0.0, ""}, {"", -1.0, 0.0, ""}});
  layout.map(Channel::depth, {"View.Depth.Z"}, {{"", 0.01, 0.5, ""}});

  const Frame f = io::read_frame(p, {Channel::color, Channel::motion}, "taa", nullptr, layout);
  ASSERT_TRUE(f.has_color() && f.has_motion() && f.has_depth());
  EXPECT_FALSE(f.has_normal());
  EXPECT_FALSE(f.has_id());
  for (int i = 0; i < w * h; ++i) {
    const int x = i % w, y = i / w;
    for (int c = 0; c < 3; ++c) EXPECT_EQ(f.color.at(x, y, c), value(c, i));
    EXPECT_EQ(f.motion.at(x, y, 0), value(3, i));
    EXPECT_EQ(f.motion.at(x, y, 1), -value(4, i));
    if (i > 0) {
      EXPECT_EQ(f.depth.at(x, y, 0), float(0.01 * value(5, i) + 0.5));
    }
  }
  EXPECT_EQ(f.depth.at(0, 0, 0), kBackgroundDepth);  // loader convention applies after conversion

  // The same file through our own layout has none of our names.
  EXPECT_NE(error_of([&] { io::read_frame(p); }).find("missing channel(s) R G B"),
            std::string::npos);
  // Required but not mapped by the layout.
  const std::string m = error_of([&] { io::read_frame(p, {Channel::id}, "taa", nullptr, layout); });
  EXPECT_NE(m.find(p), std::string::npos) << m;
  EXPECT_NE(m.find("id"), std::string::npos) << m;
}
