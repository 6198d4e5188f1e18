#include "core/state_file.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <system_error>

#include "core/atomic_file.h"
#include "core/error.h"

namespace afterimage {

namespace {

constexpr char kMagic[16] = {'A', 'F', 'T', 'E', 'R', 'I', 'M', 'A',
                             'G', 'E', '-', 'S', 'T', 'A', 'T', 'E'};
constexpr uint32_t kByteOrderMark = 0x01020304u;
constexpr uint32_t kByteOrderMarkSwapped = 0x04030201u;

// resize + memcpy rather than vector::insert (GCC 12 warns falsely on inserting into an
// empty vector).
void append_bytes(std::vector<unsigned char>& buf, const void* p, size_t n) {
  if (n == 0) return;
  const size_t at = buf.size();
  buf.resize(at + n);
  std::memcpy(buf.data() + at, p, n);
}

template <class T>
void append_pod(std::vector<unsigned char>& buf, const T& v) {
  append_bytes(buf, &v, sizeof(T));
}

void append_name(std::vector<unsigned char>& buf, std::string_view s) {
  append_pod(buf, uint32_t(s.size()));
  append_bytes(buf, s.data(), s.size());
}

// A foreign name, printable for an error message.
std::string printable(std::string_view s) {
  std::string out;
  for (char c : s) out += (c >= 0x20 && c < 0x7f) ? c : '?';
  return out;
}

}  // namespace

namespace {
// Size and name of every element type: one row each.
struct ElemInfo {
  ElemType type;
  size_t size;
  const char* name;
};
constexpr ElemInfo kElemTypes[] = {
    {ElemType::U8, 1, "u8"},   {ElemType::I32, 4, "i32"}, {ElemType::U32, 4, "u32"},
    {ElemType::I64, 8, "i64"}, {ElemType::U64, 8, "u64"}, {ElemType::F32, 4, "f32"},
    {ElemType::F64, 8, "f64"},
};
const ElemInfo* elem_info(ElemType t) {
  for (const ElemInfo& e : kElemTypes)
    if (e.type == t) return &e;
  return nullptr;
}
}  // namespace

size_t elem_size(ElemType t) {
  const ElemInfo* e = elem_info(t);
  return e ? e->size : 0;
}

const char* elem_name(ElemType t) {
  const ElemInfo* e = elem_info(t);
  return e ? e->name : "?";
}

uint64_t state_checksum(const void* data, size_t size, uint64_t hsh) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    hsh ^= p[i];
    hsh *= 1099511628211ull;
  }
  return hsh;
}

// ---------------------------------------------------------------------------------------

StateWriter::StateWriter(std::string_view kind, uint32_t kind_version) {
  AI_CHECK(!kind.empty() && kind.size() <= kStateMaxNameLength);
  AI_CHECK_GE(kind_version, 1u);
  append_bytes(buf_, kMagic, sizeof(kMagic));
  append_pod(buf_, kStateFormatVersion);
  append_pod(buf_, kByteOrderMark);
  append_name(buf_, kind);
  append_pod(buf_, kind_version);
  count_offset_ = buf_.size();
  append_pod(buf_, uint32_t(0));
}

void StateWriter::put_raw(std::string_view name, ElemType type, uint64_t count, const void* bytes) {
  AI_CHECK(!name.empty() && name.size() <= kStateMaxNameLength);
  AI_CHECK(std::find(names_.begin(), names_.end(), name) == names_.end());
  AI_CHECK_LT(names_.size(), size_t(kStateMaxSections));
  const size_t esize = elem_size(type);
  AI_CHECK_GT(esize, size_t(0));
  names_.emplace_back(name);
  append_name(buf_, name);
  append_pod(buf_, uint32_t(type));
  append_pod(buf_, uint32_t(esize));
  append_pod(buf_, count);
  append_bytes(buf_, bytes, size_t(count * esize));
  const uint32_t n = uint32_t(names_.size());
  std::memcpy(buf_.data() + count_offset_, &n, sizeof(n));
}

void StateWriter::save(const std::string& path) {
  const uint64_t sum = state_checksum(buf_.data(), buf_.size());
  const size_t body = buf_.size();
  append_pod(buf_, sum);
  try {
    write_bytes_atomic(path, buf_.data(), buf_.size());
  } catch (...) {
    buf_.resize(body);
    throw;
  }
  buf_.resize(body);
}

// ---------------------------------------------------------------------------------------

void StateReader::fail(const std::string& why) const {
  throw InputError(fmt::format("{}: not a valid {} state file ({})", path_, kind_, why));
}

StateReader::StateReader(const std::string& path, std::string_view kind, uint32_t max_kind_version)
    : path_(path), kind_(kind) {
  // Read the whole file: its size is what is really on disk, so this allocation is bounded
  // by the file, never by a value inside it.
  // stat before open: opening a FIFO for reading blocks until a writer appears. O_NONBLOCK
  // covers a file swapped for one in between; fstat then refuses it.
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    fail(fmt::format("cannot open: {}", std::generic_category().message(errno)));
  if (!S_ISREG(st.st_mode)) fail("not a regular file");
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) fail(fmt::format("cannot open: {}", std::generic_category().message(errno)));
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    fail("not a regular file");
  }
  if (uint64_t(st.st_size) > kStateMaxBytes) {
    ::close(fd);
    fail(fmt::format("{} bytes, more than the limit of {} bytes", uint64_t(st.st_size),
                     kStateMaxBytes));
  }
  buf_.resize(size_t(st.st_size));
  size_t got = 0;
  while (got < buf_.size()) {
    const ssize_t n = ::read(fd, buf_.data() + got, buf_.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : 0;
      ::close(fd);
      fail(err ? fmt::format("read error: {}", std::generic_category().message(err))
               : std::string("file shrank while reading"));
    }
    got += size_t(n);
  }
  ::close(fd);

  // Cursor over the bytes before the checksum; every read is bounds-checked.
  if (buf_.size() < sizeof(kMagic) + 8) fail(fmt::format("too short ({} bytes)", buf_.size()));
  const size_t body = buf_.size() - 8;
  size_t pos = 0;
  auto need = [&](uint64_t n, const char* what) {
    if (n > body - pos) fail(fmt::format("truncated in {}", what));
  };
  auto u32 = [&](const char* what) {
    need(4, what);
    uint32_t v;
    std::memcpy(&v, buf_.data() + pos, 4);
    pos += 4;
    return v;
  };
  auto u64 = [&](const char* what) {
    need(8, what);
    uint64_t v;
    std::memcpy(&v, buf_.data() + pos, 8);
    pos += 8;
    return v;
  };
  auto name = [&](const char* what) {
    const uint32_t n = u32(what);
    if (n == 0 || n > kStateMaxNameLength) fail(fmt::format("{} length {}", what, n));
    need(n, what);
    std::string s(reinterpret_cast<const char*>(buf_.data() + pos), n);
    pos += n;
    return s;
  };

  if (std::memcmp(buf_.data(), kMagic, sizeof(kMagic)) != 0) fail("bad magic");
  pos = sizeof(kMagic);
  const uint32_t format = u32("header");
  const uint32_t bom = u32("header");
  if (bom == kByteOrderMarkSwapped) fail("written on a machine of other byte order");
  if (bom != kByteOrderMark) fail("bad byte-order mark");
  if (format != kStateFormatVersion)
    fail(
        fmt::format("format version {}, this build reads version {}", format, kStateFormatVersion));
  const std::string file_kind = name("kind");
  if (file_kind != kind_) fail(fmt::format("it holds '{}' state", printable(file_kind)));
  kind_version_ = u32("header");
  if (kind_version_ == 0 || kind_version_ > max_kind_version)
    fail(fmt::format("{} version {}, this build reads versions 1 to {}", kind_, kind_version_,
                     max_kind_version));

  uint64_t stored;
  std::memcpy(&stored, buf_.data() + body, 8);
  if (stored != state_checksum(buf_.data(), body))
    fail("checksum mismatch (corrupted or truncated)");

  // Checksummed, but still validate every size: a consistent file with absurd sizes (a bug or
  // a forgery) must fail cleanly, not read out of bounds or allocate.
  const uint32_t nsec = u32("header");
  if (nsec > kStateMaxSections)
    fail(fmt::format("{} sections (at most {})", nsec, kStateMaxSections));
  sections_.reserve(nsec);
  for (uint32_t i = 0; i < nsec; ++i) {
    Section s;
    s.name = name("section name");
    if (find(s.name)) fail(fmt::format("duplicate section '{}'", printable(s.name)));
    s.type = ElemType(u32("section header"));
    const uint32_t esize = u32("section header");
    if (elem_size(s.type) == 0 || esize != elem_size(s.type))
      fail(fmt::format("section '{}': unknown element type {} of size {}", printable(s.name),
                       uint32_t(s.type), esize));
    s.count = u64("section header");
    if (s.count > (body - pos) / esize)
      fail(fmt::format("section '{}': {} elements of {} bytes exceed the file", printable(s.name),
                       s.count, esize));
    s.bytes = buf_.data() + pos;
    pos += size_t(s.count * esize);
    sections_.push_back(std::move(s));
  }
  if (pos != body) fail(fmt::format("{} unexpected bytes after the last section", body - pos));
}

const StateReader::Section* StateReader::find(std::string_view name) const {
  for (const auto& s : sections_)
    if (s.name == name) return &s;
  return nullptr;
}

const StateReader::Section& StateReader::section(std::string_view name) const {
  const Section* s = find(name);
  if (!s) fail(fmt::format("missing section '{}'", name));
  return *s;
}

const StateReader::Section& StateReader::typed(std::string_view name, ElemType t) const {
  const Section& s = section(name);
  if (s.type != t)
    fail(fmt::format("section '{}' holds {}, expected {}", name, elem_name(s.type), elem_name(t)));
  return s;
}

void StateReader::expect_count(const Section& s, uint64_t count) const {
  if (s.count != count)
    fail(fmt::format("section '{}' holds {} {}, expected {}", s.name, s.count, elem_name(s.type),
                     count));
}

void StateReader::copy_out(const Section& s, void* dst) {
  if (s.count) std::memcpy(dst, s.bytes, size_t(s.count) * elem_size(s.type));
}

int64_t StateReader::get_i64(std::string_view name) const {
  const Section& s = typed(name, ElemType::I64);
  expect_count(s, 1);
  int64_t v;
  copy_out(s, &v);
  return v;
}

StateReader::Size StateReader::get_size(std::string_view w_name, std::string_view h_name) const {
  const Size s{get_i64(w_name), get_i64(h_name)};
  if (s.w < 0 || s.h < 0 || s.w > kMaxStateSide || s.h > kMaxStateSide || (s.w == 0) != (s.h == 0))
    fail(fmt::format("impossible size {}x{}", s.w, s.h));
  return s;
}

bool StateReader::get_flag(std::string_view name) const {
  const int64_t v = get_i64(name);
  if (v != 0 && v != 1) fail(fmt::format("{} is {}", name, v));
  return v == 1;
}

int64_t StateReader::get_count(std::string_view name) const {
  const int64_t v = get_i64(name);
  if (v < 0) fail(fmt::format("negative {}", name));
  return v;
}

double StateReader::get_f64(std::string_view name) const {
  const Section& s = typed(name, ElemType::F64);
  expect_count(s, 1);
  double v;
  copy_out(s, &v);
  return v;
}

}  // namespace afterimage
