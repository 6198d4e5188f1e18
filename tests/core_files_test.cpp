// core/atomic_file.h and core/state_file.h: atomic writes (no temporaries left, old file
// intact on failure, OutputError naming the path, disk full detected) and state files
// (round trip of every element type, every corruption class rejected as InputError).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <span>
#include <system_error>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/state_file.h"
#include "test_util.h"

using namespace afterimage;
namespace fs = std::filesystem;

namespace {

// <temp>/afterimage_core_files_test_<name>, emptied.
fs::path temp_dir(const std::string& name) {
  return test::fresh_temp_dir("core_files_test_" + name);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void spit(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), std::streamsize(bytes.size()));
}

std::vector<std::string> names_in(const fs::path& d) {
  std::vector<std::string> n;
  for (const auto& e : fs::directory_iterator(d)) n.push_back(e.path().filename().string());
  std::sort(n.begin(), n.end());
  return n;
}

// Runs `f`, expects `E` whose message contains every one of `parts`.
template <class E, class F>
void expect_error(F&& f, std::initializer_list<std::string> parts) {
  try {
    f();
    ADD_FAILURE() << "no exception";
  } catch (const E& e) {
    for (const auto& p : parts)
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what() << " lacks " << p;
  }
}

}  // namespace

// --- atomic_file ---------------------------------------------------------------------------

TEST(AtomicFile, WritesReplacesAndLeavesNoTemporary) {
  fs::path d = temp_dir("write");
  const std::string p = (d / "a.json").string();
  write_text_atomic(p, "first\n");
  EXPECT_EQ(slurp(p), "first\n");
  write_text_atomic(p, "second");
  EXPECT_EQ(slurp(p), "second");
  const unsigned char bytes[4] = {0, 1, 254, 255};
  write_bytes_atomic((d / "b.bin").string(), bytes, 4);
  EXPECT_EQ(slurp(d / "b.bin"), std::string("\x00\x01\xfe\xff", 4));
  write_text_atomic((d / "empty.txt").string(), "");
  EXPECT_EQ(fs::file_size(d / "empty.txt"), 0u);
  EXPECT_EQ(names_in(d), (std::vector<std::string>{"a.json", "b.bin", "empty.txt"}));
}

TEST(AtomicFile, CreatesParentDirectories) {
  fs::path d = temp_dir("parents");
  const std::string p = (d / "x" / "y" / "z.html").string();
  write_text_atomic(p, "<html>");
  EXPECT_EQ(slurp(p), "<html>");
}

TEST(AtomicFile, TemporaryIsAUniqueSiblingWithTheSameExtension) {
  fs::path d = temp_dir("tempfile");
  std::string a, b;
  {
    TempFile t1((d / "frame.0001.exr").string()), t2((d / "frame.0001.exr").string());
    a = t1.path();
    b = t2.path();
    EXPECT_NE(a, b);
    EXPECT_EQ(fs::path(a).parent_path(), d);
    EXPECT_EQ(fs::path(a).extension(), ".exr");
    EXPECT_TRUE(fs::exists(a) && fs::exists(b));
  }
  EXPECT_FALSE(fs::exists(a) || fs::exists(b));  // removed unless released
}

TEST(AtomicFile, FailingCallbackKeepsOldFileAndRemovesTemporary) {
  fs::path d = temp_dir("callback");
  const std::string p = (d / "out.txt").string();
  write_text_atomic(p, "old");
  std::string seen_tmp;
  // An afterimage::Error passes through unchanged.
  expect_error<OutputError>(
      [&] {
        write_file_atomic(p, [&](const std::string& tmp) {
          seen_tmp = tmp;
          spit(tmp, "half a fi");
          throw OutputError("custom message");
        });
      },
      {"custom message"});
  EXPECT_FALSE(fs::exists(seen_tmp));
  // An I/O error (std::system_error) becomes OutputError naming the final path.
  expect_error<OutputError>(
      [&] {
        write_file_atomic(p, [](const std::string&) {
          throw std::system_error(EIO, std::generic_category(), "write failed");
        });
      },
      {p, "write failed"});
  // Anything else passes through (not an output problem), still without a temporary.
  EXPECT_THROW(write_file_atomic(p, [](const std::string&) { throw std::logic_error("bug"); }),
               std::logic_error);
  EXPECT_EQ(slurp(p), "old");
  EXPECT_EQ(names_in(d), std::vector<std::string>{"out.txt"});
}

TEST(AtomicFile, DirectoryThatCannotBeCreatedIsAnOutputError) {
  fs::path d = temp_dir("nodir");
  spit(d / "blocker", "a regular file");
  const std::string p = (d / "blocker" / "sub" / "out.json").string();
  expect_error<OutputError>([&] { write_text_atomic(p, "{}"); }, {p, "cannot create directory"});
  EXPECT_EQ(names_in(d), std::vector<std::string>{"blocker"});
}

TEST(AtomicFile, RenameFailureIsAnOutputError) {
  fs::path d = temp_dir("rename");
  fs::create_directories(d / "taken" / "child");  // a non-empty directory is in the way
  const std::string p = (d / "taken").string();
  expect_error<OutputError>([&] { write_text_atomic(p, "x"); }, {p, "cannot rename into place"});
  EXPECT_EQ(names_in(d), std::vector<std::string>{"taken"});
}

// A full disk: /dev/full fails every write with ENOSPC. What is tested is the byte writer
// of write_bytes_atomic/write_text_atomic (write_all_to) against /dev/full, run as the
// callback of write_file_atomic, so the error path from ENOSPC to OutputError, the removal of
// the temporary and the untouched old file are all real; only the destination differs from
// a real full disk (no small tmpfs is available here).
TEST(AtomicFile, DiskFullIsAnErrorNeverATruncatedFile) {
  if (access("/dev/full", W_OK) != 0) GTEST_SKIP() << "/dev/full not available";
  const std::string big(1 << 20, 'x');
  try {
    write_all_to("/dev/full", big.data(), big.size());
    ADD_FAILURE() << "write to /dev/full succeeded";
  } catch (const std::system_error& e) {
    EXPECT_EQ(e.code().value(), ENOSPC);
  }
  fs::path d = temp_dir("full");
  const std::string p = (d / "report.html").string();
  write_text_atomic(p, "old");
  expect_error<OutputError>(
      [&] {
        write_file_atomic(p, [&](const std::string& tmp) {
          spit(tmp, "partial");  // what a real full disk leaves behind
          write_all_to("/dev/full", big.data(), big.size());
        });
      },
      {p, "write failed", std::error_code(ENOSPC, std::generic_category()).message()});
  EXPECT_EQ(slurp(p), "old");
  EXPECT_EQ(names_in(d), std::vector<std::string>{"report.html"});
}

// --- state_file ----------------------------------------------------------------------------

namespace {

constexpr const char* kKind = "test";

// A file with one section of every element type, plus scalars, an image and an empty one.
void write_sample(const std::string& path, const char* kind = kKind, uint32_t version = 2) {
  StateWriter w(kind, version);
  const uint8_t u8[] = {0, 7, 255};
  const int32_t i32[] = {-5, 0, std::numeric_limits<int32_t>::max()};
  const uint32_t u32[] = {0xdeadbeefu, 1};
  const int64_t i64[] = {std::numeric_limits<int64_t>::min(), 42};
  const uint64_t u64[] = {~0ull};
  const float f32[] = {1.5f, -0.0f, std::numeric_limits<float>::infinity()};
  const double f64[] = {3.141592653589793, std::numeric_limits<double>::denorm_min()};
  w.put("u8", std::span<const uint8_t>(u8));
  w.put("i32", std::span<const int32_t>(i32));
  w.put("u32", std::span<const uint32_t>(u32));
  w.put("i64", std::span<const int64_t>(i64));
  w.put("u64", std::span<const uint64_t>(u64));
  w.put("f32", std::span<const float>(f32));
  w.put("f64", std::span<const double>(f64));
  w.put("empty", std::span<const float>());
  w.put_i64("frames", -17);
  w.put_f64("time", 0.1);
  ImageF img(5, 3, 2);
  for (size_t i = 0; i < img.data().size(); ++i) img.data()[i] = float(i) * 0.25f;
  img.data()[3] = std::numeric_limits<float>::quiet_NaN();  // bits survive
  w.put("image", img);
  ImageU32 ids(4, 2, 1);
  for (size_t i = 0; i < ids.data().size(); ++i) ids.data()[i] = uint32_t(i * 0x9e3779b9u);
  w.put("ids", ids);
  w.save(path);
}

// Byte offsets from the layout in state_file.h, for the tests that forge fields.
constexpr size_t kFormatOffset = 16, kBomOffset = 20, kKindOffset = 24;
size_t section_count_offset(const std::string& kind) {
  return kKindOffset + 4 + kind.size() + 4;
}

void fix_checksum(std::string& bytes) {
  const uint64_t sum = state_checksum(bytes.data(), bytes.size() - 8);
  std::memcpy(bytes.data() + bytes.size() - 8, &sum, 8);
}

template <class T>
void poke(std::string& bytes, size_t offset, T v) {
  std::memcpy(bytes.data() + offset, &v, sizeof(T));
}

}  // namespace

TEST(StateFile, RoundTripsEverySectionType) {
  fs::path d = temp_dir("state_rt");
  const std::string p = (d / "s.state").string();
  write_sample(p);
  EXPECT_EQ(names_in(d), std::vector<std::string>{"s.state"});  // written atomically

  StateReader r(p, kKind, 2);
  EXPECT_EQ(r.kind_version(), 2u);
  ASSERT_EQ(r.sections().size(), 12u);
  EXPECT_EQ(r.sections()[0].name, "u8");
  EXPECT_EQ(r.get<uint8_t>("u8"), (std::vector<uint8_t>{0, 7, 255}));
  EXPECT_EQ(r.get<int32_t>("i32"),
            (std::vector<int32_t>{-5, 0, std::numeric_limits<int32_t>::max()}));
  EXPECT_EQ(r.get<uint32_t>("u32"), (std::vector<uint32_t>{0xdeadbeefu, 1}));
  EXPECT_EQ(r.get<int64_t>("i64"), (std::vector<int64_t>{std::numeric_limits<int64_t>::min(), 42}));
  EXPECT_EQ(r.get<uint64_t>("u64"), (std::vector<uint64_t>{~0ull}));
  const auto f32 = r.get<float>("f32");
  ASSERT_EQ(f32.size(), 3u);
  EXPECT_EQ(f32[0], 1.5f);
  EXPECT_TRUE(std::signbit(f32[1]));
  EXPECT_TRUE(std::isinf(f32[2]));
  EXPECT_EQ(r.get<double>("f64"),
            (std::vector<double>{3.141592653589793, std::numeric_limits<double>::denorm_min()}));
  EXPECT_TRUE(r.get<float>("empty").empty());
  EXPECT_EQ(r.get_i64("frames"), -17);
  EXPECT_EQ(r.get_f64("time"), 0.1);
  ImageF img(5, 3, 2);
  r.get("image", img);
  EXPECT_TRUE(std::isnan(img.data()[3]));
  EXPECT_EQ(img.data()[14], 14 * 0.25f);
  ImageU32 ids(4, 2, 1);
  r.get("ids", ids);
  EXPECT_EQ(ids.data()[7], uint32_t(7 * 0x9e3779b9u));
  // Older kind versions are accepted (the owner may migrate them).
  EXPECT_EQ(StateReader(p, kKind, 5).kind_version(), 2u);
}

TEST(StateFile, WrongSectionUseIsAnInputError) {
  fs::path d = temp_dir("state_use");
  const std::string p = (d / "s.state").string();
  write_sample(p);
  StateReader r(p, kKind, 2);
  const std::string what = p + ": not a valid test state file";
  expect_error<InputError>([&] { r.get<float>("nope"); }, {what, "missing section 'nope'"});
  expect_error<InputError>([&] { r.get<float>("u32"); }, {what, "holds u32, expected f32"});
  ImageF wrong(5, 3, 1);
  expect_error<InputError>([&] { r.get("image", wrong); }, {what, "holds 30 f32, expected 15"});
  expect_error<InputError>([&] { r.get_i64("i64"); }, {"holds 2 i64, expected 1"});
}

TEST(StateFile, EveryCorruptionIsRejected) {
  fs::path d = temp_dir("state_bad");
  const std::string p = (d / "s.state").string();
  write_sample(p);
  const std::string good = slurp(p);
  auto rejects = [&](const std::string& bytes, const std::string& why) {
    spit(p, bytes);
    expect_error<InputError>([&] { StateReader r(p, kKind, 2); },
                             {p + ": not a valid test state file (", why});
  };
  std::string b = good;
  b[good.size() / 2] ^= 0x10;  // payload bit flip
  rejects(b, "checksum mismatch");
  b = good;
  b[good.size() - 1] ^= 0x01;  // the checksum itself
  rejects(b, "checksum mismatch");
  for (size_t n : {size_t(0), size_t(10), size_t(30), good.size() / 2, good.size() - 1})
    rejects(good.substr(0, n), n < 24 ? "too short" : "");  // truncated anywhere
  b = good;
  b[0] = 'X';
  rejects(b, "bad magic");
  rejects(std::string(100, 'a'), "bad magic");

  // Foreign kind and future kind version (well-formed files of someone else).
  write_sample(p, "other", 2);
  expect_error<InputError>([&] { StateReader r(p, kKind, 2); }, {"it holds 'other' state"});
  write_sample(p, kKind, 3);
  expect_error<InputError>([&] { StateReader r(p, kKind, 2); },
                           {"test version 3, this build reads versions 1 to 2"});

  // Forged header fields with a consistent checksum: validated by value, not by checksum.
  b = good;
  poke<uint32_t>(b, kFormatOffset, 2);
  fix_checksum(b);
  rejects(b, "format version 2");
  b = good;
  poke<uint32_t>(b, kBomOffset, 0x04030201u);
  fix_checksum(b);
  rejects(b, "other byte order");
  b = good;
  poke<uint32_t>(b, kKindOffset, 0xffffffffu);  // absurd kind length
  fix_checksum(b);
  rejects(b, "kind length");
  // Absurd section count and size: rejected before any allocation (the reader reserves
  // sections only below kStateMaxSections and checks every count against the bytes present).
  const size_t count_at = section_count_offset(kKind);
  b = good;
  poke<uint32_t>(b, count_at, 0xffffffffu);
  fix_checksum(b);
  rejects(b, "4294967295 sections");
  b = good;
  poke<uint32_t>(b, count_at, 13);  // one more than present
  fix_checksum(b);
  rejects(b, "truncated");
  // First section "u8": u32 name length, "u8", u32 type, u32 size, u64 count.
  const size_t first_count = count_at + 4 + 4 + 2 + 4 + 4;
  b = good;
  poke<uint64_t>(b, first_count, uint64_t(1) << 62);
  fix_checksum(b);
  rejects(b, "exceed the file");
  b = good;
  poke<uint32_t>(b, first_count - 8, 99);  // unknown element type
  fix_checksum(b);
  rejects(b, "unknown element type 99");
  b = good;
  b.insert(b.size() - 8, "junk");
  fix_checksum(b);
  rejects(b, "4 unexpected bytes");

  // Unreadable.
  expect_error<InputError>([&] { StateReader r((d / "missing").string(), kKind, 2); },
                           {"missing: not a valid test state file (cannot open"});
  expect_error<InputError>([&] { StateReader r(d.string(), kKind, 2); }, {"not a regular file"});
}

TEST(StateFile, SaveFailureIsAnOutputError) {
  fs::path d = temp_dir("state_save");
  spit(d / "blocker", "file");
  const std::string p = (d / "blocker" / "s.state").string();
  StateWriter w(kKind, 1);
  w.put_i64("x", 1);
  expect_error<OutputError>([&] { w.save(p); }, {p});
  // The writer is unchanged by the failure: a later save produces a valid file.
  const std::string ok = (d / "ok.state").string();
  w.save(ok);
  EXPECT_EQ(StateReader(ok, kKind, 1).get_i64("x"), 1);
}
