// Hostile and careless input (issue 9): each defect of the probe has a test here that
// reproduces it through the `afterimage` command. The contract under test: one line naming
// the file or argument and the problem, a non-zero exit code, no crash or hang, no input
// overwritten, nothing written when a check could have failed first, and no non-finite
// value in any output.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Imath/half.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "cli_util.h"
#include "core/atomic_file.h"
#include "io/io.h"
#include "io/sequence_input.h"
#include "test_util.h"

using namespace afterimage;
using test::CliRun;
using test::expect_one_line_error;
using test::run;
namespace fs = std::filesystem;

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}

// Names in `dir` (sorted), hidden files included.
std::vector<std::string> names_in(const fs::path& dir) {
  std::vector<std::string> n;
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir)) n.push_back(e.path().filename().string());
  std::sort(n.begin(), n.end());
  return n;
}

bool all_finite(const Frame& f) {
  bool ok = true;
  for (const ChannelInfo& r : kChannelTable)
    if (const ImageF* img = f.plane_set(r.key))
      for (float v : img->data()) ok = ok && std::isfinite(v);
  return ok;
}

// One pixel value of `type` at `p`, as double, and back.
double load_value(const char* p, OIIO::TypeDesc type) {
  switch (type.basetype) {
    case OIIO::TypeDesc::FLOAT:
      return *reinterpret_cast<const float*>(p);
    case OIIO::TypeDesc::HALF:
      return float(*reinterpret_cast<const half*>(p));
    case OIIO::TypeDesc::UINT:
      return *reinterpret_cast<const uint32_t*>(p);
    case OIIO::TypeDesc::UINT16:
      return *reinterpret_cast<const uint16_t*>(p);
    case OIIO::TypeDesc::UINT8:
      return *reinterpret_cast<const uint8_t*>(p);
    default:
      ADD_FAILURE() << "type " << type.c_str();
      return 0;
  }
}
void store_value(char* p, OIIO::TypeDesc type, double v) {
  switch (type.basetype) {
    case OIIO::TypeDesc::FLOAT:
      *reinterpret_cast<float*>(p) = float(v);
      break;
    case OIIO::TypeDesc::HALF:
      *reinterpret_cast<half*>(p) = half(float(v));
      break;
    case OIIO::TypeDesc::UINT:
      *reinterpret_cast<uint32_t*>(p) = uint32_t(v);
      break;
    case OIIO::TypeDesc::UINT16:
      *reinterpret_cast<uint16_t*>(p) = uint16_t(v);
      break;
    case OIIO::TypeDesc::UINT8:
      *reinterpret_cast<uint8_t*>(p) = uint8_t(v);
      break;
    default:
      ADD_FAILURE() << "type " << type.c_str();
  }
}

// Rewrites an EXR with OpenImageIO directly (what write_frame would refuse to produce):
// `edit` may change header attributes and per-channel formats; values are kept (converted
// by value where a channel's type changes).
// `value(channel, pixel, v)` may change values on the way.
using ValueEdit = std::function<double(const std::string& channel, size_t pixel, double v)>;
void rewrite_exr(const std::string& src, const std::string& dst,
                 const std::function<void(OIIO::ImageSpec&)>& edit, const ValueEdit& value = {}) {
  auto in = OIIO::ImageInput::open(src);
  ASSERT_TRUE(in) << OIIO::geterror();
  const OIIO::ImageSpec from = in->spec();
  OIIO::ImageSpec to = from;
  to.channelformats.resize(size_t(to.nchannels), to.format);
  edit(to);
  const size_t npix = size_t(from.width) * from.height;
  std::vector<std::vector<char>> planes(size_t(from.nchannels));
  for (int c = 0; c < from.nchannels; ++c) {
    const OIIO::TypeDesc t = from.channelformat(c);
    planes[size_t(c)].resize(npix * t.size());
    ASSERT_TRUE(in->read_image(0, 0, c, c + 1, t, planes[size_t(c)].data()));
  }
  size_t pixel_bytes = 0;
  for (int c = 0; c < to.nchannels; ++c) pixel_bytes += to.channelformat(c).size();
  std::vector<char> native(npix * pixel_bytes);
  for (size_t i = 0; i < npix; ++i) {
    char* p = native.data() + i * pixel_bytes;
    for (int c = 0; c < to.nchannels; ++c) {
      const OIIO::TypeDesc tf = from.channelformat(c), tt = to.channelformat(c);
      double v = load_value(planes[size_t(c)].data() + i * tf.size(), tf);
      if (value) v = value(to.channelnames[size_t(c)], i, v);
      store_value(p, tt, v);
      p += tt.size();
    }
  }
  auto out = OIIO::ImageOutput::create(dst);
  ASSERT_TRUE(out && out->open(dst, to)) << OIIO::geterror();
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UNKNOWN, native.data())) << out->geterror();
  ASSERT_TRUE(out->close());
}

class Hardening : public ::testing::Test {
 protected:
  static void TearDownTestSuite() { test::remove_if_passed(root_); }
  static void SetUpTestSuite() {
    root_ = test::fresh_temp_dir("hardening");
    CliRun r =
        run("render --scene motion --frames 4 --size 40x24 --out " + seq() + " --reference 4");
    ASSERT_EQ(r.code, 0) << r.err;
  }
  static std::string seq() { return (root_ / "seq").string(); }
  static std::string frame(int t) { return io::frame_path(seq(), t); }
  // A fresh copy of the rendered sequence (frames only) that a test may damage.
  static fs::path copy_of_sequence(const std::string& tag, int frames = 4) {
    const fs::path d = root_ / tag;
    fs::remove_all(d);
    fs::create_directories(d);
    for (int t = 0; t < frames; ++t) fs::copy_file(frame(t), io::frame_path(d.string(), t));
    return d;
  }
  static fs::path root_;
};
fs::path Hardening::root_;

// 1. Every file a command writes is checked against its inputs, before anything is written.
TEST_F(Hardening, SaveStateJsonAndReportNeverReplaceAnInput) {
  const fs::path in = copy_of_sequence("overwrite");
  const std::string victim = io::frame_path(in.string(), 2);
  const std::string before = slurp(victim);
  const fs::path out = root_ / "overwrite_out";
  expect_one_line_error(
      run("resolve --in " + in.string() + " --out " + out.string() + " --save-state " + victim),
      "refusing to overwrite an input file");
  EXPECT_EQ(slurp(victim), before);
  EXPECT_TRUE(names_in(out).empty()) << "refused before any frame was written";
  for (const char* opt : {"--json", "--report"}) {
    expect_one_line_error(run("eval --warmup 1 --out " + in.string() + " --ref " + seq() +
                              "/reference " + opt + " " + victim),
                          "refusing to overwrite an input file");
    EXPECT_EQ(slurp(victim), before) << opt;
  }
}

// 2. Non-finite G-buffer values are repaired with a warning; non-finite header values are
// refused. Nothing non-finite reaches an output file.
TEST_F(Hardening, NonFiniteGbufferIsRepairedNeverCopiedToTheOutput) {
  const fs::path in = root_ / "nan_gbuffer";
  fs::create_directories(in);
  for (int t = 0; t < 4; ++t) {
    Frame f = io::read_frame(frame(t), core_channels(), "test");
    for (int x = 0; x < 40; ++x) f.motion.at(x, 5, 0) = kNaN;  // a row of NaN motion.X
    f.normal.at(3, 3, 1) = kNaN;
    f.albedo.at(4, 4, 2) = kInf;
    f.depth.at(6, 6, 0) = -1.0f;
    f.color.at(7, 7, 0) = kNaN;
    io::write_frame(io::frame_path(in.string(), t), f);
  }
  const fs::path out = root_ / "nan_gbuffer_out";
  // --keep-gbuffer: every channel is read (so repaired and warned about) and written back.
  CliRun r = run("resolve --in " + in.string() + " --out " + out.string() + " --keep-gbuffer");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("40 non-finite motion values set to 0"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1 non-finite normal values set to 0"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1 non-finite albedo values set to 0"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1 depth values NaN or <= 0 set to background"), std::string::npos);
  EXPECT_NE(r.err.find("1 non-finite color values"), std::string::npos) << r.err;
  for (int t = 0; t < 4; ++t) {
    const Frame o = io::read_frame(io::frame_path(out.string(), t), core_channels(), "test");
    EXPECT_TRUE(all_finite(o)) << "frame " << t;
    EXPECT_EQ(o.depth.at(6, 6, 0), kBackgroundDepth);
  }
}

TEST_F(Hardening, NonFiniteHeaderIsRefusedNamingTheField) {
  struct Case {
    const char* what;
    std::function<void(OIIO::ImageSpec&)> edit;
  };
  const double nan2[2] = {std::nan(""), 0.0};
  std::vector<Case> cases{
      {"jitter",
       [&](OIIO::ImageSpec& s) {
         s.attribute("afterimage:jitter",
                     OIIO::TypeDesc(OIIO::TypeDesc::DOUBLE, OIIO::TypeDesc::VEC2), nan2);
       }},
      {"time is not finite",
       [](OIIO::ImageSpec& s) {
         const double t = std::nan("");
         s.attribute("afterimage:time", OIIO::TypeDesc::DOUBLE, &t);
       }},
      {"view matrix is not finite",
       [](OIIO::ImageSpec& s) {
         double m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
         m[3] = std::nan("");
         s.attribute("afterimage:view",
                     OIIO::TypeDesc(OIIO::TypeDesc::DOUBLE, OIIO::TypeDesc::MATRIX44), m);
       }},
      {"projection matrix is not finite",
       [](OIIO::ImageSpec& s) {
         double m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
         m[5] = HUGE_VAL;
         s.attribute("afterimage:projection",
                     OIIO::TypeDesc(OIIO::TypeDesc::DOUBLE, OIIO::TypeDesc::MATRIX44), m);
       }},
  };
  for (const Case& c : cases) {
    const fs::path in = copy_of_sequence("nan_header");
    rewrite_exr(frame(2), io::frame_path(in.string(), 2), c.edit);
    const fs::path out = root_ / "nan_header_out";
    fs::remove_all(out);
    const CliRun r = run("resolve --in " + in.string() + " --out " + out.string());
    expect_one_line_error(r, "frame.0002.exr");
    EXPECT_NE(r.err.find(c.what), std::string::npos) << r.err;
    EXPECT_TRUE(names_in(out).empty()) << "headers are checked before the first write";
  }
}

// 3. A write that runs out of space is an error, and no partial file is left under the name.
// RLIMIT_FSIZE (ulimit -f) makes write() fail with EFBIG like a full disk with ENOSPC; the
// command ignores SIGXFSZ so that it is an error message, not a killed process.
TEST_F(Hardening, FullDiskIsAnErrorNeverATruncatedFile) {
  const std::string json = (root_ / "full.json").string(), html = (root_ / "full.html").string();
  for (const std::string& opt : {"--json " + json, "--report " + html}) {
    const CliRun r = run("eval --warmup 1 --out " + seq() + " --ref " + seq() + "/reference " + opt,
                         "ulimit -f 4;");  // 4 KiB
    expect_one_line_error(r, "full.");
    EXPECT_FALSE(fs::exists(json) || fs::exists(html)) << opt;
  }
  const fs::path out = root_ / "full_frames";
  const CliRun r = run("resolve --in " + seq() + " --out " + out.string(), "ulimit -f 8;");
  expect_one_line_error(r, "frame.0000.exr");
  EXPECT_TRUE(names_in(out).empty());
}

// 4. Thread counts that would crash TBB are refused.
TEST_F(Hardening, AbsurdThreadCountsAreRefused) {
  for (const char* n : {"100000", "-1", "99999999999"})
    expect_one_line_error(run(std::string("--threads ") + n + " resolve --in " + seq() + " --out " +
                              (root_ / "threads").string()),
                          "thread count");
  EXPECT_FALSE(fs::exists(root_ / "threads"));
}

// 5, 6. compare validates the viewing condition and refuses non-finite images, as eval does.
TEST_F(Hardening, CompareValidatesPpdAndRefusesNonFiniteImages) {
  const std::string ref = io::frame_path(seq() + "/reference", 1), test_img = frame(1);
  for (const char* ppd : {"1e30", "3e9", "1e8", "0.5", "nan"})
    expect_one_line_error(
        run("compare --ppd " + std::string(ppd) + " " + ref + " " + test_img, "timeout 60"),
        "ppd must be in [1, 1000]");
  const fs::path bad = root_ / "compare_nan.exr";
  Frame f = io::read_frame(test_img);
  f.color.at(2, 3, 1) = kInf;
  io::write_frame(bad.string(), f);
  expect_one_line_error(run("compare " + ref + " " + bad.string()),
                        "compare_nan.exr: non-finite color at pixel (2, 3)");
  expect_one_line_error(run("compare " + bad.string() + " " + ref),
                        "compare_nan.exr: non-finite color at pixel (2, 3)");
}

// 7 and "check before writing": every header is checked before the first output.
TEST_F(Hardening, SequenceProblemsAreFoundBeforeAnythingIsWritten) {
  {  // a frame of another size
    const fs::path in = copy_of_sequence("mixed_size");
    Frame f = Frame::allocate(41, 24);
    io::write_frame(io::frame_path(in.string(), 3), f);
    const fs::path out = root_ / "mixed_size_out";
    expect_one_line_error(run("resolve --in " + in.string() + " --out " + out.string()),
                          "frame.0003.exr: size 41x24 differs from the sequence's 40x24");
    EXPECT_TRUE(names_in(out).empty());
  }
  {  // frame 3 lacks the motion channels
    const fs::path in = copy_of_sequence("late_missing");
    Frame f = io::read_frame(frame(3), core_channels(), "test");
    f.motion = ImageF();
    io::write_frame(io::frame_path(in.string(), 3), f);
    const fs::path out = root_ / "late_missing_out";
    expect_one_line_error(run("resolve --in " + in.string() + " --out " + out.string()),
                          "frame.0003.exr: missing channel(s) motion.X motion.Y");
    EXPECT_TRUE(names_in(out).empty());
  }
  {  // corrupt pixel data in frame 2 (header intact): frames 0 and 1 complete, no temporaries
    const fs::path in = copy_of_sequence("late_corrupt");
    const std::string p = io::frame_path(in.string(), 2);
    {  // 8000 bytes near the end (chunk headers and pixels of several rows) overwritten; the
       // file keeps its size, so only decoding can find the damage
      std::fstream file(p, std::ios::in | std::ios::out | std::ios::binary);
      file.seekp(std::streamoff(fs::file_size(p) - 10000));
      const std::string garbage(8000, '\xff');
      file.write(garbage.data(), std::streamsize(garbage.size()));
    }
    const fs::path out = root_ / "late_corrupt_out";
    const CliRun r = run("resolve --in " + in.string() + " --out " + out.string());
    EXPECT_EQ(r.code, 1);
    // After the progress lines of frames 0 and 1, one error line naming the file.
    EXPECT_NE(r.err.find("afterimage: error: " + p + ": corrupt or truncated image data"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(names_in(out), (std::vector<std::string>{"frame.0000.exr", "frame.0001.exr"}));
    EXPECT_NO_THROW(io::read_frame(io::frame_path(out.string(), 1)));
  }
}

// 8. Sizes come from headers and are limited before anything is allocated.
TEST_F(Hardening, HugeSizesAreRefusedBeforeAllocation) {
  // A small file whose header claims 40000 x 40000: patch the data and display windows.
  const fs::path in = copy_of_sequence("huge_header", 1);
  const std::string p = io::frame_path(in.string(), 0);
  std::string bytes = slurp(p);
  for (const char* attr : {"dataWindow", "displayWindow"}) {
    const std::string key = std::string(attr) + std::string("\0box2i\0", 7);
    const size_t at = bytes.find(key);
    ASSERT_NE(at, std::string::npos) << attr;
    const size_t box = at + key.size() + 4;  // after the 4-byte attribute size
    const int32_t big = 39999;
    std::memcpy(&bytes[box + 8], &big, 4);
    std::memcpy(&bytes[box + 12], &big, 4);
  }
  std::ofstream(p, std::ios::binary | std::ios::trunc) << bytes;
  const CliRun r = run("resolve --in " + in.string() + " --out " + (root_ / "huge_out").string(),
                       test::memory_limit(4000) + "timeout 60");
  expect_one_line_error(r, "frame.0000.exr");
  EXPECT_EQ(r.err.find("internal error"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("bad_alloc"), std::string::npos) << r.err;

  // Fuzz finding F3 (tests/fuzz/README.md): a 21 KB EXR whose header declares 40000 x 40000
  // and whose line-offset table is valid. Refused from the header, under a 4 GB address
  // space limit (the old loader allocated 19 GB).
  const fs::path f3 = root_ / "f3";
  fs::create_directories(f3);
  fs::copy_file(fs::path(AFTERIMAGE_TESTDATA_DIR) /
                    "../fuzz/regressions/fuzz_frame_loader/exr-40000x40000-from-21kb",
                f3 / "frame.0000.exr", fs::copy_options::overwrite_existing);
  expect_one_line_error(run("resolve --in " + f3.string() + " --out " + (root_ / "f3_out").string(),
                            test::memory_limit(4000) + "timeout 60"),
                        "frame.0000.exr: size 40000x40000 exceeds the limit");
  // Fuzz finding F2: 17 bytes declaring a 2 GiB attribute of unknown type, which OpenEXR
  // allocates before reading. Refused by our header walk, under a 1 GB limit.
  const fs::path f2 = root_ / "f2.exr";
  const unsigned char f2_bytes[] = {0x76, 0x2f, 0x31, 0x01, 0x02, 0x00, 0x00, 0x00, 'a',
                                    0x00, 'z',  'z',  0x00, 0xff, 0xff, 0xff, 0x7f};
  std::ofstream(f2, std::ios::binary).write(reinterpret_cast<const char*>(f2_bytes), 17);
  expect_one_line_error(run("info " + f2.string(), test::memory_limit(1000) + "timeout 60"),
                        "f2.exr: damaged OpenEXR header (attribute 'a' declares 2147483647 bytes");

  // Fuzz finding F7: a 627-byte file declaring a 4 x 704643073 scanline window, whose chunk
  // offset table OpenEXR allocated (1 GiB) when OpenImageIO opened the file, before our size
  // check ran. The header walk now checks the window first.
  const fs::path f7 = root_ / "f7.exr";
  fs::copy_file(fs::path(AFTERIMAGE_TESTDATA_DIR) /
                    "../fuzz/regressions/fuzz_frame_loader/exr-scanline-chunk-table-1g",
                f7, fs::copy_options::overwrite_existing);
  expect_one_line_error(run("info " + f7.string(), test::memory_limit(1000) + "timeout 60"),
                        "f7.exr: size 4x704643074 exceeds the limit");
  // Fuzz finding F8: channels of pixel type 1701998593 / 1392508930 (and samplings near 2^31)
  // made OpenEXR's core library allocate 1.6 / 1.1 GB when OpenImageIO opened the file.
  for (const auto& [file, message] : std::vector<std::pair<std::string, std::string>>{
           {"exr-channel-pixel-type-1.6g", "channel 8: pixel type 1701998593"},
           {"exr-channel-pixel-type-1.1g",
            "channel 7: pixel type 1392508930 (0 uint, 1 half, 2 float)"}}) {
    const fs::path f8 = root_ / (file + ".exr");
    fs::copy_file(
        fs::path(AFTERIMAGE_TESTDATA_DIR) / "../fuzz/regressions/fuzz_frame_loader" / file, f8,
        fs::copy_options::overwrite_existing);
    expect_one_line_error(run("info " + f8.string(), test::memory_limit(1000) + "timeout 60"),
                          message);
  }
  // Fuzz finding F9: a scanline file with a 'tiles' attribute crashed OpenImageIO (SIGFPE).
  {
    const fs::path f9 = root_ / "f9.exr";
    fs::copy_file(fs::path(AFTERIMAGE_TESTDATA_DIR) /
                      "../fuzz/regressions/fuzz_frame_loader/exr-scanline-with-tiles-sigfpe",
                  f9, fs::copy_options::overwrite_existing);
    expect_one_line_error(
        run("info " + f9.string()),
        "f9.exr: damaged OpenEXR header (a 'tiles' attribute in a scanline image)");
  }
  // Fuzz finding F10: a 4 x 2 tiled image with 16711428 x 4 tiles made OpenImageIO allocate a
  // 3.5 GB tile buffer.
  {
    const fs::path f10 = root_ / "f10.exr";
    fs::copy_file(fs::path(AFTERIMAGE_TESTDATA_DIR) /
                      "../fuzz/regressions/fuzz_frame_loader/exr-tile-16711428x4-3.5g",
                  f10, fs::copy_options::overwrite_existing);
    expect_one_line_error(run("info " + f10.string(), test::memory_limit(1000) + "timeout 60"),
                          "f10.exr: damaged OpenEXR header (tiles of 16711428x4 for a 4x2 image)");
  }
  // Fuzz finding F11: attribute names repeated in one header made OpenEXR's core library read
  // value bytes as a 1.6 GB size.
  {
    const fs::path f11 = root_ / "f11.exr";
    fs::copy_file(fs::path(AFTERIMAGE_TESTDATA_DIR) /
                      "../fuzz/regressions/fuzz_frame_loader/exr-repeated-attribute-1.6g",
                  f11, fs::copy_options::overwrite_existing);
    expect_one_line_error(
        run("info " + f11.string(), test::memory_limit(1000) + "timeout 60"),
        "f11.exr: damaged OpenEXR header (attribute 'afterimage:frame' appears twice)");
  }
  // Fuzz finding F12: 2169 bytes declaring 29192 x 769 pixels of 28 float channels made the
  // loader allocate a 2.5 GB read buffer before finding the file truncated.
  {
    const fs::path f12 = root_ / "f12.exr";
    fs::copy_file(fs::path(AFTERIMAGE_TESTDATA_DIR) /
                      "../fuzz/regressions/fuzz_frame_loader/exr-29192x769-in-2kb-2.5g",
                  f12, fs::copy_options::overwrite_existing);
    expect_one_line_error(run("info " + f12.string(), test::memory_limit(1000) + "timeout 60"),
                          "f12.exr: damaged OpenEXR header (29192x769 pixels of 112 bytes cannot "
                          "be stored in 2169 bytes)");
  }
  // A standard attribute of another type is not that attribute: OpenEXR would size its
  // tables from defaults. Our own frame with its dataWindow typed box2f (same size).
  {
    const fs::path in2 = copy_of_sequence("box2f_window", 1);
    const std::string p2 = io::frame_path(in2.string(), 0);
    std::string b2 = slurp(p2);
    const std::string key = std::string("dataWindow\0box2i\0", 17);
    const size_t at = b2.find(key);
    ASSERT_NE(at, std::string::npos);
    b2[at + 15] = 'f';
    std::ofstream(p2, std::ios::binary | std::ios::trunc) << b2;
    expect_one_line_error(run("info " + p2),
                          "damaged OpenEXR header (attribute 'dataWindow' has type box2f, "
                          "expected box2i)");
  }
  // 1 x 1 tiles of a 1024 x 1024 ZIP window are 1M chunks: an 8 MB offset table that a
  // 300-byte file cannot hold (its pixels alone would pass the compression-ratio check).
  {
    std::string h("\x76\x2f\x31\x01\x02\x02\x00\x00", 8);  // version 2, tiled (bit 9)
    auto attr = [&](const std::string& name, const std::string& type, const std::string& v) {
      const int32_t n = int32_t(v.size());
      h += name + '\0' + type + '\0' + std::string(reinterpret_cast<const char*>(&n), 4) + v;
    };
    auto i32 = [](std::initializer_list<int32_t> v) {
      std::string o;
      for (int32_t x : v) o.append(reinterpret_cast<const char*>(&x), 4);
      return o;
    };
    attr("channels", "chlist", std::string("R\0", 2) + i32({2, 0, 1, 1}) + std::string(1, '\0'));
    attr("compression", "compression", std::string(1, '\3'));  // ZIP
    attr("dataWindow", "box2i", i32({0, 0, 1023, 1023}));
    attr("displayWindow", "box2i", i32({0, 0, 1023, 1023}));
    attr("lineOrder", "lineOrder", std::string(1, '\0'));
    attr("pixelAspectRatio", "float", i32({0x3f800000}));
    attr("screenWindowCenter", "v2f", i32({0, 0}));
    attr("screenWindowWidth", "float", i32({0x3f800000}));
    attr("tiles", "tiledesc", i32({1, 1}) + std::string(1, '\0'));
    h += '\0';
    const fs::path tiles = root_ / "tiles.exr";
    std::ofstream(tiles, std::ios::binary) << h;
    expect_one_line_error(run("info " + tiles.string(), test::memory_limit(1000) + "timeout 60"),
                          "1048576 chunks declared, the file cannot hold");
  }

  expect_one_line_error(run("render --scene thin --frames 1 --size 16384x16384 --out " +
                            (root_ / "huge_render").string()),
                        "exceeds the limit");
  expect_one_line_error(run("render --scene thin --frames 1 --size 99999999999x2 --out " +
                            (root_ / "huge_render").string()),
                        "size '99999999999x2'");
  EXPECT_FALSE(fs::exists(root_ / "huge_render"));
  expect_one_line_error(run("resolve --in " + seq() + " --out " + (root_ / "zero_state").string() +
                                " --load-state /dev/zero",
                            "timeout 60"),
                        "/dev/zero: not a valid taa state file (not a regular file)");
}

// 9. Anything that is not a regular file is refused without being opened.
TEST_F(Hardening, FifosDevicesAndDirectoriesAreRefusedWithoutHanging) {
  const fs::path fifo = root_ / "fifo.exr";
  fs::remove(fifo);
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  expect_one_line_error(run("info " + fifo.string(), "timeout 20"), "not a regular file");
  expect_one_line_error(run("info /dev/zero", "timeout 20"), "/dev/zero: not a regular file");
  const fs::path in = copy_of_sequence("special", 2);
  fs::create_symlink("/dev/zero", in / "frame.0002.exr");
  ASSERT_EQ(mkfifo((in / "frame.0003.exr").c_str(), 0600), 0);
  const fs::path out = root_ / "special_out";
  expect_one_line_error(run("resolve --in " + in.string() + " --out " + out.string(), "timeout 20"),
                        "frame.0002.exr: not a regular file");
  EXPECT_TRUE(names_in(out).empty());
  // A FIFO as the first frame, which --layout auto opens to recognise the layout.
  const fs::path first = root_ / "fifo_first";
  fs::create_directories(first);
  ASSERT_EQ(mkfifo((first / "frame.0000.exr").c_str(), 0600), 0);
  expect_one_line_error(
      run("resolve --in " + first.string() + " --out " + out.string(), "timeout 20"),
      "frame.0000.exr: not a regular file");
  expect_one_line_error(
      run("resolve --in " + seq() + " --out " + out.string() + " --load-state " + root_.string()),
      "not a regular file");
}

// 10. Temporaries: unique, removed on failure, and stale ones of killed runs cleaned up.
TEST_F(Hardening, NoTemporaryIsLeftBehind) {
  // A state that cannot be written (the target is a directory): refused before the run.
  const fs::path out = root_ / "state_fail";
  fs::create_directories(out / "state.bin");
  expect_one_line_error(run("resolve --in " + seq() + " --out " + out.string() + " --save-state " +
                            (out / "state.bin").string()),
                        "state.bin");
  EXPECT_EQ(names_in(out), std::vector<std::string>{"state.bin"});

  // Stale temporaries of a dead process go; those of a live one (this test) stay.
  const fs::path o2 = root_ / "stale";
  fs::create_directories(o2);
  const pid_t child = fork();
  if (child == 0) _exit(0);
  ASSERT_GT(child, 0);
  waitpid(child, nullptr, 0);  // its pid now names no process
  const std::string dead = ".afterimage-" + std::to_string(child) + "-000001-0000abcd.tmp.exr";
  const std::string live = ".afterimage-" + std::to_string(getpid()) + "-000001-0000abcd.tmp.exr";
  std::ofstream(o2 / dead) << "partial";
  std::ofstream(o2 / live) << "partial";
  std::ofstream(o2 / ".someone-else.tmp.exr") << "not ours";
  const CliRun r = run("resolve --in " + seq() + " --out " + o2.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto names = names_in(o2);
  EXPECT_EQ(std::count(names.begin(), names.end(), dead), 0);
  EXPECT_EQ(std::count(names.begin(), names.end(), live), 1);
  EXPECT_EQ(std::count(names.begin(), names.end(), ".someone-else.tmp.exr"), 1);
}

// 11. User mistakes are one-line errors naming the argument or file, never "internal error".
TEST_F(Hardening, UserMistakesAreNotInternalErrors) {
  // --name is a literal stem: pattern characters are ordinary characters.
  const fs::path odd = root_ / "odd_names";
  fs::create_directories(odd);
  for (int t = 0; t < 2; ++t)
    fs::copy_file(frame(t), io::frame_path(odd.string(), t, "fr(ame[1]+"));
  CliRun r = run("resolve --in " + odd.string() + " --out " + (root_ / "odd_out").string() +
                 " --name 'fr(ame[1]+'");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(io::frame_path((root_ / "odd_out").string(), 1, "fr(ame[1]+")));
  expect_one_line_error(
      run("resolve --in " + seq() + " --out " + (root_ / "x").string() + " --name 'a['"),
      "no frames named a[.NNNN.exr");
  expect_one_line_error(
      run("resolve --in " + seq() + " --out " + (root_ / "x").string() + " --name a/b"),
      "--name 'a/b'");

  const fs::path big = copy_of_sequence("big_number", 1);
  fs::copy_file(frame(1), big / "frame.99999999999.exr");
  expect_one_line_error(run("resolve --in " + big.string() + " --out " + (root_ / "x").string()),
                        "frame.99999999999.exr: frame number 99999999999 has more than 9 digits");

  // A lens scene at an extreme aspect: the focal length its field of view implies (4.08 m at
  // 1x40) passes the focus distance (3 m); the frames would carry a lens no thin lens has.
  expect_one_line_error(
      run("render --scene focus --frames 1 --size 1x40 --out " + (root_ / "thin").string()),
      "--size 1x40: with the scene's field of view, lens focus distance 3: must exceed the focal "
      "length");
  EXPECT_FALSE(fs::exists(root_ / "thin"));

  const fs::path file = root_ / "a_file";
  std::ofstream(file) << "x";
  expect_one_line_error(run("demo --out " + file.string()),
                        "a_file: exists and is not a directory");
  expect_one_line_error(run("resolve --in " + seq() + " --out " + file.string()),
                        "a_file: exists and is not a directory");
  EXPECT_EQ(slurp(file), "x");
}

// 12. Data that OpenImageIO would silently rescale, impossible depth, odd numbering, a state
// of another size, and an empty evaluation are refused or reported.
TEST_F(Hardening, SilentlyWrongInputIsRefusedOrReported) {
  struct TypeCase {
    const char* channel;
    OIIO::TypeDesc type;
    const char* message;
  };
  const std::vector<TypeCase> types{
      {"Z", OIIO::TypeDesc::UINT, "channel Z (depth) is stored as uint; expected half or float"},
      // (OpenEXR stores only half, float and uint.)
      {"R", OIIO::TypeDesc::UINT, "channel R (color) is stored as uint"},
      {"motion.Y", OIIO::TypeDesc::UINT, "channel motion.Y (motion) is stored as uint"},
  };
  for (const TypeCase& c : types) {
    const fs::path in = copy_of_sequence("types");
    rewrite_exr(frame(1), io::frame_path(in.string(), 1), [&](OIIO::ImageSpec& s) {
      s.channelformats[size_t(s.channelindex(c.channel))] = c.type;
    });
    const fs::path out = root_ / "types_out";
    fs::remove_all(out);
    expect_one_line_error(run("resolve --in " + in.string() + " --out " + out.string()),
                          std::string("frame.0001.exr: ") + c.message);
    EXPECT_TRUE(names_in(out).empty()) << c.channel;
  }

  {  // a float id (Blender's IndexOB) is read exactly when it holds whole numbers
    const fs::path in = copy_of_sequence("float_id");
    auto to_float = [](OIIO::ImageSpec& s) {
      s.channelformats[size_t(s.channelindex("id"))] = OIIO::TypeDesc::FLOAT;
    };
    rewrite_exr(frame(1), io::frame_path(in.string(), 1), to_float);
    const Frame a = io::read_frame(frame(1), core_channels(), "test");
    const Frame b = io::read_frame(io::frame_path(in.string(), 1), core_channels(), "test");
    EXPECT_TRUE(a.id == b.id);
    rewrite_exr(frame(1), io::frame_path(in.string(), 1), to_float,
                [](const std::string& ch, size_t i, double v) {
                  return ch == "id" && i == 41 ? 2.5 : v;  // pixel (1, 1) of 40 x 24
                });
    // Found only when the pixels are read (after frame 0 is written, as corrupt data is).
    const CliRun r = run("resolve --in " + in.string() + " --out " + (root_ / "x").string());
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("frame.0001.exr: channel id (id) holds 2.5 at pixel (1, 1)"),
              std::string::npos)
        << r.err;
  }
  {  // duplicate numbers
    const fs::path in = copy_of_sequence("dupes");
    fs::copy_file(frame(3), in / "frame.003.exr");
    expect_one_line_error(run("resolve --in " + in.string() + " --out " + (root_ / "x").string()),
                          "frame number 3 also in");
  }
  {  // a gap: warned, and history restarts there (the output equals a fresh start)
    const fs::path in = copy_of_sequence("gap");
    fs::remove(io::frame_path(in.string(), 2));
    const fs::path out = root_ / "gap_out";
    const CliRun r = run("resolve --in " + in.string() + " --out " + out.string());
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("frame.0003.exr: frame 2 missing before it; history restarts"),
              std::string::npos)
        << r.err;
    const fs::path alone = root_ / "gap_alone", alone_out = root_ / "gap_alone_out";
    fs::create_directories(alone);
    fs::copy_file(frame(3), io::frame_path(alone.string(), 3));
    ASSERT_EQ(run("resolve --in " + alone.string() + " --out " + alone_out.string()).code, 0);
    EXPECT_TRUE(io::read_frame(io::frame_path(out.string(), 3)).color ==
                io::read_frame(io::frame_path(alone_out.string(), 3)).color);
  }
  {  // every 2nd frame: one line, not one a frame; irregular gaps: three lines and a count
    const fs::path in = root_ / "every2";
    fs::create_directories(in);
    for (int k : {0, 1, 2}) fs::copy_file(frame(k), io::frame_path(in.string(), 2 * k));
    const CliRun r = run("resolve --in " + in.string() + " --out " + (root_ / "e2").string());
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("frame.0000.exr: the frames are numbered 0, 2, ... 4, one every 2: each "
                         "one's motion vectors point one frame back"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(r.err.find("missing before it"), std::string::npos) << r.err;
    const std::vector<io::SequenceFile> files{{0, "a"}, {2, "b"},  {3, "c"}, {6, "d"},
                                              {9, "e"}, {10, "f"}, {15, "g"}};
    const std::vector<bool> gap{false, true, false, true, true, false, true};
    EXPECT_EQ(io::describe_gaps(files, gap, "X"),
              (std::vector<std::string>{"b: frame 1 missing before it; X",
                                        "d: frames 4..5 missing before it; X",
                                        "e: frames 7..8 missing before it; X",
                                        "a: 1 more gap after e (the last before g); X at each"}));
    EXPECT_TRUE(io::describe_gaps(files, std::vector<bool>(7, false), "X").empty());
  }
  {  // a state saved at another size
    const std::string state = (root_ / "small.state").string();
    const fs::path small = root_ / "small";
    ASSERT_EQ(run("render --scene motion --frames 2 --size 20x12 --out " + small.string()).code, 0);
    ASSERT_EQ(run("resolve --in " + small.string() + " --out " + (root_ / "small_out").string() +
                  " --save-state " + state)
                  .code,
              0);
    const fs::path out = root_ / "state_size_out";
    expect_one_line_error(
        run("resolve --in " + seq() + " --out " + out.string() + " --load-state " + state),
        "small.state: state saved at 20x12, the sequence is 40x24");
    EXPECT_TRUE(names_in(out).empty());
  }
  expect_one_line_error(run("eval --out " + seq() + " --ref " + seq() + "/reference --warmup 4"),
                        "--warmup 4 leaves no frame to score");
}

// 13. Messages say what is really wrong.
TEST_F(Hardening, MessagesNameTheRealProblem) {
  // The longest valid file name (NAME_MAX 255): "<246 chars>.0000.exr".
  const std::string stem(246, 'n');
  const fs::path in = root_ / "long_name";
  fs::create_directories(in);
  fs::copy_file(frame(0), io::frame_path(in.string(), 0, stem));
  const fs::path out = root_ / "long_name_out";
  const CliRun r =
      run("resolve --in " + in.string() + " --out " + out.string() + " --name " + stem);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(io::frame_path(out.string(), 0, stem)));

  // A deep image.
  const std::string deep = (root_ / "deep.exr").string();
  {
    OIIO::ImageSpec spec(4, 4, 1, OIIO::TypeDesc::FLOAT);
    spec.channelnames = {"Z"};
    spec.deep = true;
    OIIO::ImageBuf buf(spec);
    ASSERT_TRUE(buf.write(deep)) << buf.geterror();
  }
  expect_one_line_error(run("info " + deep), "deep.exr: deep image");

  // Permission denied (root reads everything: only checked as another user).
  if (geteuid() != 0) {
    const fs::path locked = root_ / "locked.exr";
    fs::copy_file(frame(0), locked, fs::copy_options::overwrite_existing);
    fs::permissions(locked, fs::perms::none);
    expect_one_line_error(run("info " + locked.string()), "locked.exr: cannot read:");
  }
}

}  // namespace
