// Versioned, checksummed binary state files for temporal classes (TAA history, ...).
//
// Layout (native byte order, no padding; all integers unsigned unless noted):
//   "AFTERIMAGE-STATE" (16 bytes) | u32 format version | u32 byte-order mark 0x01020304 |
//   u32 kind length, kind bytes | u32 kind version | u32 section count |
//   per section: u32 name length, name bytes, u32 element type (ElemType), u32 element size,
//                u64 element count, count * size bytes |
//   u64 FNV-1a checksum of every byte before it.
// Written with write_file_atomic. The reader validates the whole file (magic, byte order,
// versions, kind, checksum, every size against the bytes actually present and fixed limits,
// before allocating) and throws InputError "<path>: not a valid <kind> state file (<why>)".
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/image.h"

namespace afterimage {

enum class ElemType : uint32_t { U8 = 1, I32 = 2, U32 = 3, I64 = 4, U64 = 5, F32 = 6, F64 = 7 };

// The ElemType of a C++ element type (compile error for types a state file cannot hold).
template <class T>
constexpr ElemType elem_type_of() {
  if constexpr (std::is_same_v<T, uint8_t>)
    return ElemType::U8;
  else if constexpr (std::is_same_v<T, int32_t>)
    return ElemType::I32;
  else if constexpr (std::is_same_v<T, uint32_t>)
    return ElemType::U32;
  else if constexpr (std::is_same_v<T, int64_t>)
    return ElemType::I64;
  else if constexpr (std::is_same_v<T, uint64_t>)
    return ElemType::U64;
  else if constexpr (std::is_same_v<T, float>)
    return ElemType::F32;
  else if constexpr (std::is_same_v<T, double>)
    return ElemType::F64;
  else
    static_assert(sizeof(T) == 0, "no state-file element type for T");
}
template <class T>
struct ElemTypeOf {
  static constexpr ElemType value = elem_type_of<T>();
};

size_t elem_size(ElemType t);       // 0 for unknown values
const char* elem_name(ElemType t);  // "f32", ...; "?" for unknown values

// 64-bit FNV-1a (the trailer checksum).
uint64_t state_checksum(const void* data, size_t size, uint64_t seed = 1469598103934665603ull);

// Limits the reader enforces (a forged size must not allocate or read past the file).
inline constexpr uint32_t kStateMaxNameLength = 64;  // kind and section names
inline constexpr uint32_t kStateMaxSections = 256;
// Largest state file read: a few float planes of the largest image core/limits.h accepts.
inline constexpr uint64_t kStateMaxBytes = uint64_t(16) * 4 * 8192 * 8192;
inline constexpr uint32_t kStateFormatVersion = 1;

class StateWriter {
 public:
  // `kind` names the owner ("taa"); `kind_version` its section layout version (>= 1).
  StateWriter(std::string_view kind, uint32_t kind_version);

  template <class T>
  void put(std::string_view name, std::span<const T> values) {
    put_raw(name, ElemTypeOf<T>::value, values.size(), values.data());
  }
  template <class T>
  void put(std::string_view name, const Image<T>& img) {
    put(name, std::span<const T>(img.data()));
  }
  void put_i64(std::string_view name, int64_t v) { put(name, std::span<const int64_t>(&v, 1)); }
  void put_f64(std::string_view name, double v) { put(name, std::span<const double>(&v, 1)); }
  // Appends a section; names must be unique (AI_CHECK).
  void put_raw(std::string_view name, ElemType type, uint64_t count, const void* bytes);

  // Writes the sections and the checksum atomically (OutputError on failure). Non-const:
  // the checksum is appended to the buffer for the write and removed again (no copy).
  void save(const std::string& path);

 private:
  std::vector<unsigned char> buf_;
  std::vector<std::string> names_;
  size_t count_offset_ = 0;  // where the section count lives in buf_
};

class StateReader {
 public:
  struct Section {
    std::string name;
    ElemType type;
    uint64_t count;
    const unsigned char* bytes;  // into the reader's buffer
  };

  // Reads and validates `path` as a state file of `kind` with a kind version in
  // [1, max_kind_version]; throws InputError otherwise.
  StateReader(const std::string& path, std::string_view kind, uint32_t max_kind_version);
  StateReader(const StateReader&) = delete;  // sections point into buf_
  StateReader& operator=(const StateReader&) = delete;

  uint32_t kind_version() const { return kind_version_; }
  const std::vector<Section>& sections() const { return sections_; }
  bool has(std::string_view name) const { return find(name) != nullptr; }
  // The section, or InputError "missing section".
  const Section& section(std::string_view name) const;

  // Typed getters: the element type must match, and `count` (or the image size) must equal
  // the stored count; otherwise InputError.
  template <class T>
  std::vector<T> get(std::string_view name) const {
    const Section& s = typed(name, ElemTypeOf<T>::value);
    std::vector<T> v(s.count);  // bounded by the file size (checked when reading)
    copy_out(s, v.data());
    return v;
  }
  template <class T>
  void get(std::string_view name, Image<T>& img) const {
    const Section& s = typed(name, ElemTypeOf<T>::value);
    expect_count(s, img.data().size());
    copy_out(s, img.data().data());
  }
  // A new w x h x `planes` image from section `name`. w and h come from the file, so the
  // section must hold exactly that many values before the image is allocated: no allocation
  // is larger than what the file itself contains.
  template <class T>
  Image<T> get_image(std::string_view name, int64_t w, int64_t h, int planes) const {
    const Section& s = typed(name, ElemTypeOf<T>::value);
    expect_count(s, uint64_t(w) * uint64_t(h) * uint64_t(planes));
    Image<T> img(int(w), int(h), planes);
    copy_out(s, img.data().data());
    return img;
  }
  int64_t get_i64(std::string_view name) const;
  double get_f64(std::string_view name) const;
  // The header fields every temporal method's state starts with: an image size from two i64
  // sections (both 0 = no history, else each in [1, kMaxStateSide]; InputError "impossible
  // size WxH"), a 0/1 flag and a non-negative count.
  static constexpr int64_t kMaxStateSide = 1 << 16;
  struct Size {
    int64_t w, h;
  };
  Size get_size(std::string_view w_name, std::string_view h_name) const;
  bool get_flag(std::string_view name) const;
  int64_t get_count(std::string_view name) const;

  // Throws InputError "<path>: not a valid <kind> state file (<why>)".
  [[noreturn]] void fail(const std::string& why) const;

 private:
  const Section* find(std::string_view name) const;
  const Section& typed(std::string_view name, ElemType t) const;
  void expect_count(const Section& s, uint64_t count) const;
  static void copy_out(const Section& s, void* dst);

  std::string path_, kind_;
  uint32_t kind_version_ = 0;
  std::vector<unsigned char> buf_;
  std::vector<Section> sections_;
};

}  // namespace afterimage
