#include "io/io.h"

#include "afterimage/version.h"

#include <OpenImageIO/half.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string_view>
#include <type_traits>

#include "core/atomic_file.h"
#include "core/color.h"
#include "core/error.h"
#include "core/limits.h"

namespace afterimage::io {

namespace fs = std::filesystem;
using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

namespace {

// OpenEXR through its core library: the C++ API unpacks pixels through per-scanline slices,
// measured 10x slower on uncompressed and 1.8x on ZIP 1080p G-buffer frames (io bench in
// DESIGN.md §3 "Compression"); the bytes read are identical. Set once, before the first file
// is opened.
const bool kOiioConfigured = [] {
  OIIO::attribute("openexr:core", 1);
  return true;
}();

std::string canonical_or_absolute(const std::string& path) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(path), ec);
  return ec ? fs::absolute(path).lexically_normal().string() : p.string();
}

// Writes with `write_fn(out)` through the core atomic helper (unique temporary sibling with
// the same extension, so OIIO picks the format from it; synced, renamed into place).
template <class WriteFn>
void atomic_write(const std::string& path, const ImageSpec& spec, const InputRegistry* inputs,
                  WriteFn&& write_fn) {
  if (inputs) inputs->check_writable(path);
  write_file_atomic(path, [&](const std::string& tmp) {
    auto out = ImageOutput::create(tmp);
    if (!out) throw OutputError(fmt::format("{}: no writer for this file type", path));
    if (!out->open(tmp, spec))
      throw OutputError(fmt::format("{}: cannot open for writing: {}", path, out->geterror()));
    bool ok = write_fn(*out);
    std::string err = ok ? "" : out->geterror();
    ok = out->close() && ok;
    if (!ok)
      throw OutputError(
          fmt::format("{}: write failed: {}", path, err.empty() ? out->geterror() : err));
  });
}

// A regular, readable file: anything else is refused before it is opened (a FIFO would block
// the open, /dev/zero never ends, a directory gives a misleading decoder message).
void check_regular_readable(const std::string& path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);  // follows symbolic links
  if (!fs::exists(st)) {
    if (fs::is_symlink(fs::symlink_status(path, ec)))
      throw InputError(fmt::format("{}: no such file (dangling symbolic link)", path));
    throw InputError(fmt::format("{}: no such file", path));
  }
  if (fs::is_directory(st)) throw InputError(fmt::format("{}: is a directory, not a file", path));
  if (!fs::is_regular_file(st))
    throw InputError(fmt::format(
        "{}: not a regular file (a FIFO, device or socket); refusing to read it", path));
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0)
    throw InputError(fmt::format("{}: cannot read: {}", path,
                                 std::error_code(errno, std::generic_category()).message()));
  ::close(fd);
}

// OpenEXR allocates the declared size of an attribute before reading it (an unknown type's
// value: `new char[size]`), so a 17-byte file can ask for 2 GiB (fuzz finding F2,
// tests/fuzz/README.md). Walk the header(s) first and refuse any attribute that claims more
// bytes than the file holds. The layout (OpenEXR file layout document): magic 76 2f 31 01, a
// 4-byte version with flags, then per part a list of (name\0, type\0, int32 size, value)
// ended by an empty name; multi-part files end the list of headers with one more empty name.
// Checks that an attribute value of OpenEXR type `type` is exactly `size` bytes as OpenEXR
// would read it; `f` is at the value. Fixed-size types must declare their size; the variable
// ones (chlist, preview, stringvector) must be consumed exactly by their structure.
// For a chlist, `pixel_bytes` receives the bytes one pixel of all channels takes uncompressed.
std::optional<std::string> exr_attribute_problem(std::istream& f, const std::string& type,
                                                 uint32_t size, double* pixel_bytes = nullptr) {
  static const std::map<std::string, uint32_t> kFixed{
      {"box2i", 16},      {"box2f", 16},   {"chromaticities", 32},
      {"compression", 1}, {"double", 8},   {"envmap", 1},
      {"float", 4},       {"int", 4},      {"keycode", 28},
      {"lineOrder", 1},   {"m33f", 36},    {"m33d", 72},
      {"m44f", 64},       {"m44d", 128},   {"rational", 8},
      {"tiledesc", 9},    {"timecode", 8}, {"v2i", 8},
      {"v2f", 8},         {"v2d", 16},     {"v3i", 12},
      {"v3f", 12},        {"v3d", 24},     {"deepImageState", 1}};
  if (auto it = kFixed.find(type); it != kFixed.end()) {
    if (size != it->second)
      return fmt::format("{} bytes declared, the type has {}", size, it->second);
    return std::nullopt;
  }
  auto read_u32 = [&](uint32_t& v) { return bool(f.read(reinterpret_cast<char*>(&v), 4)); };
  if (type == "chlist") {  // (name\0, int32 type, uint8 pLinear, 3 reserved, 2 x int32)*, \0
    uint64_t used = 0;
    for (int n = 0; n < 1 << 20; ++n) {
      uint32_t name_len = 0;
      int c;
      while ((c = f.get()) > 0 && name_len < 256) ++name_len;
      if (c == EOF || name_len >= 256) return std::string("unterminated channel name");
      used += name_len + 1;
      if (name_len == 0) break;
      char rest[16];
      if (!f.read(rest, 16)) return std::string("truncated channel list");
      used += 16;
      // OpenEXR's core library sizes buffers from these before it checks them (fuzz finding
      // F8: pixel types 1701998593 and 1392508930 made opening allocate 1.6 and 1.1 GB).
      int32_t pixel_type, x_sampling, y_sampling;
      std::memcpy(&pixel_type, rest, 4);
      std::memcpy(&x_sampling, rest + 8, 4);
      std::memcpy(&y_sampling, rest + 12, 4);
      if (pixel_type < 0 || pixel_type > 2)
        return fmt::format("channel {}: pixel type {} (0 uint, 1 half, 2 float)", n, pixel_type);
      if (x_sampling < 1 || y_sampling < 1 || x_sampling > kMaxImageSide ||
          y_sampling > kMaxImageSide)
        return fmt::format("channel {}: sampling {} x {}", n, x_sampling, y_sampling);
      if (pixel_bytes)
        *pixel_bytes += (pixel_type == 1 ? 2.0 : 4.0) / (double(x_sampling) * y_sampling);
      if (used > size) break;
    }
    if (used != size)
      return fmt::format("the channel list takes {} bytes, {} declared", used, size);
    return std::nullopt;
  }
  if (type == "preview") {  // uint32 width, height, then 4 bytes per pixel
    uint32_t w = 0, h = 0;
    if (!read_u32(w) || !read_u32(h)) return std::string("truncated");
    if (8 + 4 * uint64_t(w) * h != size)
      return fmt::format("a {}x{} preview does not fit {} bytes", w, h, size);
    return std::nullopt;
  }
  if (type == "stringvector") {  // (int32 length, bytes)* filling the declared size
    uint64_t used = 0;
    while (used < size) {
      uint32_t len = 0;
      if (!read_u32(len)) return std::string("truncated");
      used += 4 + uint64_t(len);
      if (used > size) return fmt::format("a string of {} bytes overruns the value", len);
      f.seekg(std::streamoff(len), std::ios::cur);
    }
    return std::nullopt;
  }
  return std::nullopt;  // string, floatvector, unknown types: read by the declared size
}

// The attributes every OpenEXR header has (OpenEXR file layout, "Header Attributes") and
// their types.
const std::map<std::string, std::string> kStandardExrAttributes{
    {"channels", "chlist"},        {"compression", "compression"}, {"dataWindow", "box2i"},
    {"displayWindow", "box2i"},    {"lineOrder", "lineOrder"},     {"pixelAspectRatio", "float"},
    {"screenWindowCenter", "v2f"}, {"screenWindowWidth", "float"}, {"tiles", "tiledesc"},
    {"chunkCount", "int"}};

void check_exr_header(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  unsigned char magic[8];
  if (!f.read(reinterpret_cast<char*>(magic), 8)) return;  // too short: OIIO says so
  if (!(magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01)) return;
  const bool multipart = (magic[5] & 0x10) != 0;  // version flag bit 12
  std::error_code ec;
  const uint64_t file_size = fs::file_size(path, ec);
  if (ec) return;
  auto read_string = [&](std::string& out) {
    out.clear();
    for (int n = 0; n < 256; ++n) {  // names are at most 255 bytes (31 in old files)
      const int c = f.get();
      if (c == EOF) return false;
      if (c == 0) return true;
      out.push_back(char(c));
    }
    return false;
  };
  auto damaged = [&](const std::string& why) {
    return InputError(fmt::format("{}: damaged OpenEXR header ({})", path, why));
  };
  for (int part = 0; part < 1 << 16; ++part) {
    std::string name, type;
    bool first = true;
    // What OpenEXR sizes its chunk offset table by (it allocates the table, 8 bytes per
    // chunk, when it opens the file; fuzz finding F7: a 627-byte file declaring a 4 x
    // 704643073 scanline window asked for 1 GiB).
    std::optional<std::array<int32_t, 4>> window;
    std::optional<std::array<uint32_t, 2>> tile;
    std::optional<int32_t> chunk_count;
    bool has_channels = false;
    std::string part_type;  // multi-part files: "scanlineimage", "tiledimage", ...
    std::set<std::string> names;
    double pixel_bytes = 0;  // uncompressed bytes per pixel of all channels
    int compression = -1;
    for (;;) {
      if (!read_string(name)) throw damaged("unterminated attribute name");
      if (name.empty()) break;
      first = false;
      if (!read_string(type)) throw damaged(fmt::format("attribute '{}': bad type name", name));
      // A header is a map of names: OpenEXR's core library reads a second attribute of the
      // same name out of step with the file (fuzz finding F11: a repeated name made it take
      // value bytes as a 1.6 GB size).
      if (!names.insert(name).second)
        throw damaged(fmt::format("attribute '{}' appears twice", name));
      int32_t size = 0;
      if (!f.read(reinterpret_cast<char*>(&size), 4)) throw damaged("truncated");
      const uint64_t at = uint64_t(f.tellg());
      if (size < 0 || at + uint64_t(size) > file_size)
        throw damaged(fmt::format("attribute '{}' declares {} bytes, beyond the end of the file",
                                  name, size));
      // OpenEXR reads known types by their own structure, not by the declared size; where the
      // two disagree its reading goes out of step with the file and takes later bytes as
      // sizes (fuzzing found a 1444-byte file that allocated 1.9 GB that way).
      if (auto problem = exr_attribute_problem(f, type, uint32_t(size),
                                               name == "channels" ? &pixel_bytes : nullptr))
        throw damaged(fmt::format("attribute '{}' of type {}: {}", name, type, *problem));
      // A standard attribute of another type is not read as that attribute, and OpenEXR would
      // size its tables from defaults: refused like a missing one.
      if (auto it = kStandardExrAttributes.find(name);
          it != kStandardExrAttributes.end() && type != it->second)
        throw damaged(
            fmt::format("attribute '{}' has type {}, expected {}", name, type, it->second));
      has_channels = has_channels || name == "channels";
      f.clear();
      f.seekg(std::streamoff(at));
      if (name == "dataWindow" && type == "box2i") {
        window.emplace();
        f.read(reinterpret_cast<char*>(window->data()), 16);
      } else if (name == "tiles" && type == "tiledesc") {
        tile.emplace();
        f.read(reinterpret_cast<char*>(tile->data()), 8);
      } else if (name == "chunkCount" && type == "int") {
        chunk_count.emplace();
        f.read(reinterpret_cast<char*>(&*chunk_count), 4);
      } else if (name == "compression" && type == "compression") {
        compression = f.get();
      } else if (name == "type" && type == "string") {
        part_type.assign(size_t(size), '\0');
        f.read(part_type.data(), size);
      }
      f.clear();
      f.seekg(std::streamoff(at + uint64_t(size)));
    }
    if (!first && !window) throw damaged("no 'dataWindow' attribute");
    if (!first && !has_channels) throw damaged("no 'channels' attribute");
    // Tile description and storage must agree: OpenImageIO reads a scanline file that has a
    // 'tiles' attribute with a chunk height of 0 and divides by it (fuzz finding F9, SIGFPE).
    // Single part: version flag bit 9; multi-part: the part's 'type' ("tiledimage",
    // "deeptile").
    const bool tiled =
        multipart ? part_type.find("tile") != std::string::npos : (magic[5] & 0x02) != 0;
    if (!first && tiled != tile.has_value())
      throw damaged(tiled ? "a tiled image without a 'tiles' attribute"
                          : "a 'tiles' attribute in a scanline image");
    if (window) {
      const int64_t w = int64_t((*window)[2]) - (*window)[0] + 1,
                    h = int64_t((*window)[3]) - (*window)[1] + 1;
      if (auto problem = image_size_problem(w, h))
        throw InputError(fmt::format("{}: {}", path, *problem));
      // OpenImageIO allocates a whole tile per read (fuzz finding F10: a 4 x 2 image with
      // 16711428 x 4 tiles asked for 3.5 GB). Tiles larger than the image (beyond a 512-pixel
      // allowance for small images, whose writers often keep a default tile size) are refused.
      if (tile && (int64_t((*tile)[0]) > std::max<int64_t>(w, 512) ||
                   int64_t((*tile)[1]) > std::max<int64_t>(h, 512)))
        throw damaged(
            fmt::format("tiles of {}x{} for a {}x{} image", (*tile)[0], (*tile)[1], w, h));
      // The pixels must fit in the file: exactly without compression, and within a ratio no
      // codec reaches on real data otherwise (zlib's limit is about 1032:1), so a 2 KB file
      // cannot make the loader allocate gigabytes (fuzz finding F12: 29192 x 769 pixels of 28
      // channels declared in 2169 bytes, a 2.5 GB read buffer).
      const double raw = double(w) * double(h) * pixel_bytes;
      const double max_ratio = compression == 0 ? 1.0 : 65536.0;
      if (raw > double(file_size) * max_ratio)
        throw damaged(fmt::format("{}x{} pixels of {} bytes cannot be stored in {} bytes", w, h,
                                  pixel_bytes, file_size));
      // The fewest chunks such a window can have: 256 scanlines per chunk (DWAB, the most),
      // or the level-0 tiles. Their offsets alone must fit in the file.
      int64_t chunks = (h + 255) / 256;
      if (tile && (*tile)[0] > 0 && (*tile)[1] > 0)
        chunks = ((w + (*tile)[0] - 1) / (*tile)[0]) * ((h + (*tile)[1] - 1) / (*tile)[1]);
      if (chunk_count) chunks = std::max<int64_t>(chunks, *chunk_count);
      if (uint64_t(chunks) * 8 > file_size)
        throw damaged(
            fmt::format("{} chunks declared, the file cannot hold their {}-byte offset "
                        "table",
                        chunks, chunks * 8));
    }
    if (!multipart || first) return;  // single part: one header; multi-part: empty header ends
  }
}

int display_width(const ImageSpec& spec) {
  return spec.full_width > 0 && spec.full_height > 0 ? spec.full_width : spec.width;
}
int display_height(const ImageSpec& spec) {
  return spec.full_width > 0 && spec.full_height > 0 ? spec.full_height : spec.height;
}

// A frame is its image's display window. An OpenEXR data window inside it (a compositor's
// bounding box, a cropped region render) is read into it, the pixels outside it empty as
// OpenEXR defines them (pad_to_display_window); before, the data window was read as if it were
// the whole frame and written back at the origin, moved and with the frame's size lost, and
// with it the pixel positions the camera, jitter and lens refer to. A data window reaching
// outside the display window (overscan) would lose the pixels outside, and a display window
// off the origin would move the frame: both are refused, with the way to crop it.
std::optional<std::string> window_problem(const ImageSpec& spec) {
  if (spec.full_width <= 0 || spec.full_height <= 0) return std::nullopt;  // no display window
  const std::string data =
      fmt::format("data window {}x{} at ({}, {})", spec.width, spec.height, spec.x, spec.y);
  if (spec.full_x != 0 || spec.full_y != 0)
    return fmt::format(
        "display window {}x{} at ({}, {}), not at (0, 0), with its {}: crop it "
        "to the display window and move that to the origin first",
        spec.full_width, spec.full_height, spec.full_x, spec.full_y, data);
  if (spec.x < 0 || spec.y < 0 || int64_t(spec.x) + spec.width > spec.full_width ||
      int64_t(spec.y) + spec.height > spec.full_height)
    return fmt::format(
        "{} reaches outside the {}x{} display window (overscan), whose pixels a frame cannot "
        "hold: crop it to the display window first (oiiotool IN --croptofull -o OUT)",
        data, spec.full_width, spec.full_height);
  return image_size_problem(spec.full_width, spec.full_height);
}

bool data_is_display_window(const ImageSpec& spec) {
  return spec.full_width <= 0 || spec.full_height <= 0 ||
         (spec.x == 0 && spec.y == 0 && spec.width == spec.full_width &&
          spec.height == spec.full_height);
}

// The image of a data window (window_problem: inside the display window) placed in its display
// window, every other pixel `fill`.
template <class Img>
void pad_to_display_window(Img& img, const ImageSpec& spec, float fill) {
  if (data_is_display_window(spec)) return;
  using T = std::remove_reference_t<decltype(img.data()[0])>;
  Img full(spec.full_width, spec.full_height, img.channels(), T(fill));
  for (int c = 0; c < img.channels(); ++c)
    for (int y = 0; y < img.height(); ++y)
      std::copy(img.row(c, y), img.row(c, y) + img.width(), full.row(c, spec.y + y) + spec.x);
  img = std::move(full);
}

std::unique_ptr<ImageInput> open_input(const std::string& path) {
  check_regular_readable(path);
  check_exr_header(path);
  auto in = ImageInput::open(path);
  if (!in) {
    std::string e = OIIO::geterror();
    std::replace(e.begin(), e.end(), '\n', ' ');
    if (e.empty()) e = "damaged, truncated or not an image; the reader gives no reason";
    throw InputError(fmt::format("{}: unreadable image ({})", path, e));
  }
  const ImageSpec& spec = in->spec();
  if (spec.deep)
    throw InputError(
        fmt::format("{}: deep image (several samples per pixel) is not supported; "
                    "flatten it first",
                    path));
  // From the header, before any pixel buffer is allocated.
  if (auto problem = image_size_problem(spec.width, spec.height))
    throw InputError(fmt::format("{}: {}", path, *problem));
  if (auto problem = window_problem(spec)) throw InputError(fmt::format("{}: {}", path, *problem));
  return in;
}

// OpenEXR's core library (see kOiioConfigured) reads a truncated *uncompressed* file without
// an error (the missing lines come back as whatever the buffer held; compressed chunks do
// fail), so before reading one we check that its line table matches its size: a single-part
// scanline file of increasing line order is header, n offsets, then n chunks of (int32 y,
// int32 size, one line of pixels) ending at the end of the file. Files of other layouts are
// read as they are.
void check_uncompressed_exr_complete(ImageInput& in, const std::string& path) {
  const ImageSpec& spec = in.spec();
  if (std::strcmp(in.format_name(), "openexr") != 0 || spec.tile_width != 0 ||
      spec.get_string_attribute("compression") != "none" ||
      spec.get_string_attribute("openexr:lineOrder", "increasingY") != "increasingY")
    return;
  if (in.seek_subimage(1, 0)) {  // multi-part: chunks carry part numbers; not checked
    in.seek_subimage(0, 0);
    return;
  }
  in.seek_subimage(0, 0);
  const auto corrupt = [&] {
    return InputError(fmt::format(
        "{}: corrupt or truncated image data (its line table does not match the file size)", path));
  };
  std::error_code ec;
  const uint64_t size = fs::file_size(path, ec);
  const uint64_t n = uint64_t(spec.height), line = uint64_t(spec.width) * spec.pixel_bytes(true);
  if (ec || size < n * (8 + 8 + line)) throw corrupt();
  const uint64_t table = size - n * (8 + 8 + line);  // where the offset table must start
  std::ifstream f(path, std::ios::binary);
  auto u64_at = [&](uint64_t pos) {
    unsigned char b[8] = {};
    f.seekg(std::streamoff(pos));
    f.read(reinterpret_cast<char*>(b), 8);
    uint64_t v = 0;
    for (int i = 7; i >= 0; --i) v = (v << 8) | b[i];  // little-endian in the file
    return v;
  };
  const uint64_t last_chunk = size - (8 + line);
  const uint64_t last_header = u64_at(last_chunk);
  const uint64_t expect_header =
      uint64_t(uint32_t(spec.y + spec.height - 1)) | (uint64_t(uint32_t(line)) << 32);
  if (!f || u64_at(table) != table + 8 * n || u64_at(table + 8 * (n - 1)) != last_chunk ||
      last_header != expect_header)
    throw corrupt();
}

// Reads channels [cb, ce) of part (OpenImageIO subimage) `part` as `type` into `dst`
// (interleaved), with a one-line error.
void read_channel_range(ImageInput& in, const std::string& path, int part, int cb, int ce,
                        TypeDesc type, void* dst) {
  if (!in.read_image(part, 0, cb, ce, type, dst)) {
    std::string e = in.geterror();
    std::replace(e.begin(), e.end(), '\n', ' ');
    throw InputError(fmt::format("{}: corrupt or truncated image data ({})", path, e));
  }
}

const TypeDesc kMat44d(TypeDesc::DOUBLE, TypeDesc::MATRIX44);

// Pixel type of a channel in the file and in memory (both 4 bytes per value).
TypeDesc file_type(PixelType t) {
  return t == PixelType::U32 ? TypeDesc::UINT : TypeDesc::FLOAT;
}

// Where one plane comes from: a file channel and an optional second one added to it
// (PlaneSource::plus_name, -1 if none).
using PlaneIndex = std::array<int, 2>;

// Channels [first, last] of a file, read with their native pixel types, interleaved.
struct NativePixels {
  int first = 0;
  size_t stride = 0;           // bytes per pixel
  std::vector<size_t> offset;  // byte offset of channel first + k within a pixel
  std::vector<TypeDesc> type;  // its type in the file
  // Pixels, row-major; not zero-filled first (the read writes every byte or throws).
  std::unique_ptr<unsigned char[]> data;
  const unsigned char* at(int channel, size_t pixel) const {
    return data.get() + pixel * stride + offset[size_t(channel - first)];
  }
};

// Every channel of a file over the parts of a multi-part OpenEXR file (OpenImageIO's
// subimages), in part order. A channel is found by its name, and in a file of several parts
// also by "<part name>.<name>" (the part's "name" attribute before it), so that one name in two
// parts (each pass's R in a part of its own) stays reachable; a name that means two channels is
// refused where it is used. A frame is one size: every part has the first one's windows.
struct FileChannels {
  std::vector<std::string> names;  // as stored in their parts
  std::vector<TypeDesc> formats;
  std::vector<int> part, local;  // the part, and the channel's index within it
  std::vector<std::string> part_names;
  std::vector<bool> part_uncompressed;
  std::map<std::string, int> index;  // name or part-qualified name -> channel; -1: ambiguous
  size_t parts() const { return part_names.size(); }
};
FileChannels file_channels(ImageInput& in, const std::string& path) {
  FileChannels fc;
  const ImageSpec first = in.spec();
  for (int part = 0; part < (1 << 16) && (part == 0 || in.seek_subimage(part, 0)); ++part) {
    const ImageSpec& s = in.spec();
    if (part > 0 &&
        (s.deep || s.x != first.x || s.y != first.y || s.width != first.width ||
         s.height != first.height || s.full_x != first.full_x || s.full_y != first.full_y ||
         s.full_width != first.full_width || s.full_height != first.full_height)) {
      const std::string what =
          s.deep ? std::string("is deep (several samples per pixel)")
                 : fmt::format(
                       "has its data window {}x{} at ({}, {}) in a {}x{} display window, "
                       "the first part {}x{} at ({}, {}) in {}x{}: a frame's parts must "
                       "share their windows",
                       s.width, s.height, s.x, s.y, s.full_width, s.full_height, first.width,
                       first.height, first.x, first.y, first.full_width, first.full_height);
      const std::string name = s.get_string_attribute("name");
      in.seek_subimage(0, 0);
      throw InputError(fmt::format("{}: part {} ('{}') {}", path, part + 1, name, what));
    }
    fc.part_names.push_back(s.get_string_attribute("name"));
    fc.part_uncompressed.push_back(s.get_string_attribute("compression", "none") == "none");
    for (int c = 0; c < s.nchannels; ++c) {
      fc.names.push_back(s.channelnames[size_t(c)]);
      fc.formats.push_back(s.channelformat(c));
      fc.part.push_back(part);
      fc.local.push_back(c);
    }
  }
  (void)in.geterror();  // the failed seek past the last part leaves a message; nothing else does
  if (fc.parts() > 1) in.seek_subimage(0, 0);
  const auto add = [&](const std::string& name, int c) {
    const auto [it, fresh] = fc.index.emplace(name, c);
    if (!fresh && it->second != c) it->second = -1;
  };
  for (size_t c = 0; c < fc.names.size(); ++c) add(fc.names[c], int(c));
  if (fc.parts() > 1)
    for (size_t c = 0; c < fc.names.size(); ++c)
      if (const std::string& pn = fc.part_names[size_t(fc.part[c])]; !pn.empty())
        add(pn + "." + fc.names[c], int(c));
  return fc;
}

// Reads the channels marked in `wanted` (indexed as FileChannels). Compressed parts: one read
// over the range [first wanted, last wanted] of a part, as OpenEXR decompresses whole line
// blocks (all channels) per read. Uncompressed parts: one read per run of consecutive wanted
// channels, so channels in between are neither unpacked nor copied. Leaves `in` on its first
// part.
std::vector<NativePixels> read_native(ImageInput& in, const std::string& path,
                                      const FileChannels& fc, const std::vector<bool>& wanted) {
  const ImageSpec& spec = in.spec();
  const size_t pixels = size_t(spec.width) * size_t(spec.height);
  std::vector<std::pair<int, int>> runs;
  for (int c = 0; c < int(wanted.size()); ++c) {
    if (!wanted[size_t(c)]) continue;
    const int part = fc.part[size_t(c)];
    if (!runs.empty() && fc.part[size_t(runs.back().second)] == part &&
        (runs.back().second == c - 1 || !fc.part_uncompressed[size_t(part)]))
      runs.back().second = c;
    else
      runs.push_back({c, c});
  }
  std::vector<NativePixels> out;
  bool other_part = false;
  for (auto [first, last] : runs) {
    NativePixels px;
    px.first = first;
    for (int c = first; c <= last; ++c) {
      px.offset.push_back(px.stride);
      px.type.push_back(fc.formats[size_t(c)]);
      px.stride += fc.formats[size_t(c)].size();
    }
    px.data = std::make_unique_for_overwrite<unsigned char[]>(px.stride * pixels);
    const int part = fc.part[size_t(first)];
    read_channel_range(in, path, part, fc.local[size_t(first)], fc.local[size_t(last)] + 1,
                       TypeDesc::UNKNOWN, px.data.get());
    other_part = other_part || part != 0;
    out.push_back(std::move(px));
  }
  if (other_part) in.seek_subimage(0, 0);
  return out;
}

// The run holding file channel `c`.
const NativePixels& run_of(const std::vector<NativePixels>& runs, int c) {
  for (const NativePixels& px : runs)
    if (c >= px.first && c < px.first + int(px.type.size())) return px;
  AI_CHECK(false);
  return runs.front();
}

// One value of a float channel (half, float or double in the file), as float.
float native_float(const NativePixels& px, int channel, size_t pixel) {
  const unsigned char* p = px.at(channel, pixel);
  switch (px.type[size_t(channel - px.first)].basetype) {
    case TypeDesc::HALF: {
      half h;
      std::memcpy(&h, p, sizeof h);
      return float(h);
    }
    case TypeDesc::DOUBLE: {
      double d;
      std::memcpy(&d, p, sizeof d);
      return float(d);
    }
    default: {
      float f;
      std::memcpy(&f, p, sizeof f);
      return f;
    }
  }
}

// Copies the planes of one channel, through its layout mapping, out of `px` into `img`.
template <class Img>
void read_planes(const std::vector<NativePixels>& runs, const std::string& path,
                 const ChannelInfo& r, const ChannelSource& src,
                 const std::vector<PlaneIndex>& file_index, int width, int height, Img& img) {
  using T = std::remove_reference_t<decltype(img.data()[0])>;
  img = Img::uninitialized(width, height, r.planes);  // every pixel is written below (or throws)
  const size_t npix = img.plane_size();
  for (int c = 0; c < r.planes; ++c) {
    const int fc = file_index[size_t(c)][0];
    T* dst = img.plane(c);
    const PlaneSource& ps = src.planes[size_t(c)];
    const NativePixels& px = run_of(runs, fc);
    const TypeDesc ft = px.type[size_t(fc - px.first)];
    const unsigned char* base = px.at(fc, 0);
    const size_t stride = px.stride;
    if constexpr (std::is_same_v<T, uint32_t>) {
      if (ft.basetype == TypeDesc::UINT) {
        for (size_t i = 0; i < npix; ++i) std::memcpy(&dst[i], base + i * stride, sizeof(uint32_t));
        continue;
      }
      // Ids stored as float (Blender's IndexOB) are labels: checked to be whole numbers.
      for (size_t i = 0; i < npix; ++i) {
        const float v = native_float(px, fc, i);
        if (!(v >= 0.0f && v <= 4294967040.0f && v == std::floor(v)))
          throw InputError(fmt::format(
              "{}: channel {} ({}) holds {} at pixel ({}, {}); a float id must be a whole "
              "number >= 0",
              path, ps.file_name, r.name, v, i % size_t(width), i / size_t(width)));
        dst[i] = uint32_t(v);
      }
    } else {
      // Identity planes stored as float are copied, never computed, so our own files load
      // bit-exactly (keeps -0 and NaN payloads); Layout::map refuses conversions of uint
      // channels.
      const int fc2 = file_index[size_t(c)][1];
      if (ft.basetype == TypeDesc::FLOAT && fc2 < 0 && ps.identity()) {
        for (size_t i = 0; i < npix; ++i) std::memcpy(&dst[i], base + i * stride, sizeof(float));
        continue;
      }
      for (size_t i = 0; i < npix; ++i) {
        float v = native_float(px, fc, i);
        if (fc2 >= 0) v += native_float(run_of(runs, fc2), fc2, i);
        dst[i] = ps.identity() ? v : float(ps.scale * v + ps.offset);
      }
    }
  }
}

// Why a file channel of type `have` cannot be read as a plane of type `want`, or nothing.
// OpenImageIO converts integer pixels to float as normalised values (a uint depth of 4
// would read as 1e-9), so float channels stored as integers are refused.
std::optional<std::string> pixel_type_problem(PixelType want, TypeDesc have) {
  const auto b = TypeDesc::BASETYPE(have.basetype);
  if (want == PixelType::F32) {
    if (b == TypeDesc::HALF || b == TypeDesc::FLOAT || b == TypeDesc::DOUBLE) return std::nullopt;
    return fmt::format(
        "is stored as {}; expected half or float (integer pixels would be "
        "rescaled to [0, 1])",
        have.c_str());
  }
  // A float id is read as float and must hold whole numbers (read_planes).
  if (b == TypeDesc::UINT || b == TypeDesc::HALF || b == TypeDesc::FLOAT) return std::nullopt;
  return fmt::format("is stored as {}; expected uint or float (an integer id)", have.c_str());
}

// Where each mapped channel's planes are in the file: the header-only half of read_frame.
struct ChannelPlan {
  const ChannelSource* src;
  std::vector<PlaneIndex> file_index;  // one per plane
};

std::vector<ChannelPlan> plan_channels(const FileChannels& fc, const std::string& path,
                                       ChannelSet required, std::string_view required_by,
                                       const Layout& layout) {
  const std::string by =
      required_by.empty() ? std::string("required") : fmt::format("required by {}", required_by);
  for (const ChannelInfo& r : kChannelTable)
    if (required.contains(r.key) && !layout.find(r.key))
      throw InputError(fmt::format("{}: layout '{}' has no source for {} ({})", path, layout.name(),
                                   r.name, by));
  std::vector<ChannelPlan> plan;
  for (const ChannelSource& src : layout.sources()) {
    const ChannelInfo& r = channel_info(src.key);
    std::vector<PlaneIndex> idx;
    std::vector<std::string> missing;
    for (const PlaneSource& ps : src.planes) {
      PlaneIndex i{-1, -1};
      for (int k = 0; k < 2; ++k) {
        const std::string& fn = k == 0 ? ps.file_name : ps.plus_name;
        if (fn.empty() && k == 1) continue;  // no second channel (an empty first is missing)
        auto it = fc.index.find(fn);
        if (it == fc.index.end()) {
          missing.push_back(fn);
        } else if (it->second < 0) {
          std::vector<std::string> parts, qualified;
          for (size_t c = 0; c < fc.names.size(); ++c)
            if (fc.names[c] == fn) {
              const std::string& pn = fc.part_names[size_t(fc.part[c])];
              parts.push_back(fmt::format("'{}'", pn));
              qualified.push_back(pn + "." + fn);
            }
          throw InputError(fmt::format(
              "{}: channel {} ({}) is in the parts {}: name the one meant, {}, in a --map", path,
              fn, r.name, fmt::join(parts, " and "), fmt::join(qualified, " or ")));
        } else {
          i[size_t(k)] = it->second;
        }
      }
      if (i[0] >= 0) idx.push_back(i);
    }
    if (!missing.empty()) {
      // Absent optional channels stay empty; a partial one is an error either way.
      if (required.contains(src.key))
        throw InputError(fmt::format("{}: missing channel(s) {} ({}, {})", path,
                                     fmt::join(missing, " "), r.name, by));
      if (!idx.empty())
        throw InputError(fmt::format("{}: missing channel(s) {} ({} is only partly present)", path,
                                     fmt::join(missing, " "), r.name));
      continue;
    }
    for (size_t c = 0; c < idx.size(); ++c)
      for (int k = 0; k < 2; ++k) {
        if (idx[c][size_t(k)] < 0) continue;
        const PixelType want = k == 0 ? r.type : PixelType::F32;  // sums are float
        if (auto problem = pixel_type_problem(want, fc.formats[size_t(idx[c][size_t(k)])]))
          throw InputError(fmt::format("{}: channel {} ({}) {}", path,
                                       k == 0 ? src.planes[c].file_name : src.planes[c].plus_name,
                                       r.name, *problem));
      }
    plan.push_back({&src, std::move(idx)});
  }
  return plan;
}

}  // namespace

// ReadPolicy's rules (see io.h), applied to every loaded plane.
void repair_non_finite(Frame& f, const std::string& path, const ReadPolicy& policy) {
  // `what` follows the count: "<path>: <n> <what>".
  auto warn = [&](size_t n, std::string_view what) {
    if (n > 0 && policy.warn) policy.warn(fmt::format("warning: {}: {} {}", path, n, what));
  };
  if (!f.color.empty()) {
    size_t bad = 0;
    for (int c = 0; c < 3; ++c)
      for (int y = 0; y < f.height; ++y)
        for (int x = 0; x < f.width; ++x)
          if (!std::isfinite(f.color.at(x, y, c))) {
            if (policy.refuse_non_finite_color)
              throw InputError(fmt::format("{}: non-finite color at pixel ({}, {})", path, x, y));
            ++bad;
          }
    warn(bad, "non-finite color values (replaced by the neighbourhood mean before use)");
  }
  if (!f.depth.empty()) {
    size_t bad = 0;
    for (float& d : f.depth.data()) {
      if (std::isnan(d) || d <= 0.0f) ++bad;
      // Anything larger, infinite, NaN or not in front of the camera is background depth.
      if (!(d > 0.0f && d < kBackgroundDepth)) d = kBackgroundDepth;
    }
    warn(bad, "depth values NaN or <= 0 set to background");
  }
  for (const ChannelInfo& r : kChannelTable) {
    if (r.key == Channel::color || r.key == Channel::depth || r.type != PixelType::F32) continue;
    ImageF* img = f.plane_set(r.key);
    if (!img || img->empty()) continue;
    size_t bad = 0;
    for (float& v : img->data())
      if (!std::isfinite(v)) v = 0.0f, ++bad;
    warn(bad, fmt::format("non-finite {} values set to 0", r.name));
  }
}

namespace {

void set_matrix(ImageSpec& spec, const char* name, const Mat4& m) {
  double v[16];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) v[i * 4 + j] = m.m[i][j];  // row-major in the file
  spec.attribute(name, kMat44d, v);
}

bool get_matrix(const ImageSpec& spec, const char* name, Mat4& m) {
  double v[16];
  if (!spec.getattribute(name, kMat44d, v)) {
    float f[16];
    if (!spec.getattribute(name, TypeDesc::TypeMatrix44, f)) return false;
    for (int i = 0; i < 16; ++i) v[i] = f[i];
  }
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) m.m[i][j] = v[i * 4 + j];
  return true;
}

}  // namespace

void InputRegistry::add(const std::string& path) {
  canonical_.push_back(canonical_or_absolute(path));
}

bool InputRegistry::contains(const std::string& path) const {
  const std::string c = canonical_or_absolute(path);
  return std::find(canonical_.begin(), canonical_.end(), c) != canonical_.end();
}

void InputRegistry::check_writable(const std::string& path) const {
  if (contains(path))
    throw InputError(fmt::format("{}: refusing to overwrite an input file", path));
}

std::string frame_path(const std::string& dir, int frame, const std::string& name) {
  return (fs::path(dir) / fmt::format("{}.{:04d}.exr", name, frame)).string();
}

void set_io_threads(int threads) {
  (void)kOiioConfigured;
  OIIO::attribute("threads", threads);
  OIIO::attribute("exr_threads", threads);  // 0 = as many as the hardware has
}

void check_exr_compression(const std::string& c) {
  static const char* const kNames[] = {"none",  "rle", "zips", "zip",  "piz",
                                       "pxr24", "b44", "b44a", "dwaa", "dwab"};
  const std::string name = c.substr(0, c.find(':'));
  bool known = false;
  for (const char* n : kNames) known = known || name == n;
  if (known && c.size() > name.size()) {
    const std::string level = c.substr(name.size() + 1);
    known = !level.empty() && level.size() <= 4 &&
            std::all_of(level.begin(), level.end(), [](char ch) { return ch >= '0' && ch <= '9'; });
  }
  if (!known)
    throw SettingsError(fmt::format(
        "--compression '{}': expected one of {} (optionally NAME:LEVEL, e.g. zip:4, dwaa:45)", c,
        fmt::join(kNames, "|")));
}

void write_frame(const std::string& path, const Frame& f, const InputRegistry* inputs,
                 const FrameWriteOptions& options) {
  validate_frame(f, path);
  check_exr_compression(options.compression);
  // Every present channel in table order, with its table pixel type.
  struct Chan {
    const char* name;
    const void* plane;
    PixelType type;
  };
  std::vector<Chan> chans;
  for (const ChannelInfo& r : kChannelTable)
    f.visit(r.key, [&](const auto& img) {
      static_assert(sizeof(img.data()[0]) == sizeof(uint32_t), "interleaving copies 4 bytes");
      if (img.empty()) return;
      for (int c = 0; c < r.planes; ++c) chans.push_back({r.exr[size_t(c)], img.plane(c), r.type});
    });

  ImageSpec spec(f.width, f.height, int(chans.size()), TypeDesc::FLOAT);
  spec.channelnames.clear();
  spec.channelformats.clear();
  const int ncolor = f.color.empty() ? 0 : 3;  // color comes first (table order)
  for (size_t c = 0; c < chans.size(); ++c) {
    spec.channelnames.push_back(chans[c].name);
    spec.channelformats.push_back(options.half_color && int(c) < ncolor ? TypeDesc::HALF
                                                                        : file_type(chans[c].type));
  }
  spec.attribute("compression", options.compression);
  if (f.camera_known) {  // an unknown camera stays unknown when read back
    set_matrix(spec, "afterimage:view", f.view);
    set_matrix(spec, "afterimage:projection", f.projection);
  }
  const double jitter[2] = {f.jitter.x, f.jitter.y};
  spec.attribute("afterimage:jitter", TypeDesc(TypeDesc::DOUBLE, TypeDesc::VEC2), jitter);
  spec.attribute("afterimage:frame", f.index);
  spec.attribute("afterimage:time", TypeDesc::DOUBLE, &f.time);
  // Which release wrote the frame (scripts/golden.sh leaves it out of its comparison).
  spec.attribute("afterimage:version", AFTERIMAGE_VERSION_STRING);
  if (f.lens_known) {  // an unknown lens stays unknown when read back
    spec.attribute("afterimage:lens_focal_mm", TypeDesc::DOUBLE, &f.lens.focal_length_mm);
    spec.attribute("afterimage:lens_f_number", TypeDesc::DOUBLE, &f.lens.f_number);
    spec.attribute("afterimage:lens_focus_distance", TypeDesc::DOUBLE, &f.lens.focus_distance);
    spec.attribute("afterimage:lens_sensor_width_mm", TypeDesc::DOUBLE, &f.lens.sensor_width_mm);
    spec.attribute("afterimage:lens_blades", f.lens.blades);
    spec.attribute("afterimage:lens_blade_rotation_deg", TypeDesc::DOUBLE,
                   &f.lens.blade_rotation_deg);
  }
  spec.attribute("afterimage:camera_cut", int(f.camera_cut));

  // Interleave in the file's per-channel formats: 4 bytes (float or uint32) or 2 (half color,
  // clamped to half's range so that a bright HDR value never becomes infinite).
  const size_t nch = chans.size(), npix = size_t(f.width) * f.height;
  std::vector<size_t> offset(nch);
  size_t stride = 0;
  for (size_t c = 0; c < nch; ++c) offset[c] = stride, stride += spec.channelformat(int(c)).size();
  std::vector<unsigned char> buf(npix * stride);
  for (size_t c = 0; c < nch; ++c) {
    unsigned char* dst = buf.data() + offset[c];
    if (spec.channelformat(int(c)) == TypeDesc::HALF) {
      const float* src = static_cast<const float*>(chans[c].plane);
      for (size_t i = 0; i < npix; ++i) {
        const half h(std::isnan(src[i]) ? src[i] : std::clamp(src[i], -65504.0f, 65504.0f));
        std::memcpy(dst + i * stride, &h, sizeof h);
      }
    } else {
      const uint32_t* src = static_cast<const uint32_t*>(chans[c].plane);
      for (size_t i = 0; i < npix; ++i) std::memcpy(dst + i * stride, &src[i], sizeof(uint32_t));
    }
  }
  atomic_write(path, spec, inputs,
               [&](ImageOutput& out) { return out.write_image(TypeDesc::UNKNOWN, buf.data()); });
}

Frame read_frame(const std::string& path, const std::vector<std::string>& required,
                 InputRegistry* inputs, const Layout& layout) {
  ChannelSet set;
  for (const std::string& key : required) {
    const ChannelInfo* r = find_channel(key);
    if (!r) throw SettingsError(fmt::format("{}: unknown channel '{}' required", path, key));
    set.insert(r->key);
  }
  return read_frame(path, set, "", inputs, layout);
}

namespace {
// The camera metadata of a file (missing attributes keep FrameHeader's defaults).
void read_header(const ImageSpec& spec, FrameHeader& f) {
  const bool view = get_matrix(spec, "afterimage:view", f.view);
  f.camera_known = get_matrix(spec, "afterimage:projection", f.projection) && view;
  double jitter[2] = {0, 0};
  if (spec.getattribute("afterimage:jitter", TypeDesc(TypeDesc::DOUBLE, TypeDesc::VEC2), jitter))
    f.jitter = {jitter[0], jitter[1]};
  f.index = spec.get_int_attribute("afterimage:frame", 0);
  double t = 0;
  if (spec.getattribute("afterimage:time", TypeDesc::DOUBLE, &t)) f.time = t;
  spec.getattribute("afterimage:lens_focal_mm", TypeDesc::DOUBLE, &f.lens.focal_length_mm);
  // Our files always carry the f-number (0 for a pinhole); other renderers' never do.
  f.lens_known = spec.getattribute("afterimage:lens_f_number", TypeDesc::DOUBLE, &f.lens.f_number);
  spec.getattribute("afterimage:lens_focus_distance", TypeDesc::DOUBLE, &f.lens.focus_distance);
  spec.getattribute("afterimage:lens_sensor_width_mm", TypeDesc::DOUBLE, &f.lens.sensor_width_mm);
  f.lens.blades = spec.get_int_attribute("afterimage:lens_blades", 0);
  spec.getattribute("afterimage:lens_blade_rotation_deg", TypeDesc::DOUBLE,
                    &f.lens.blade_rotation_deg);
  f.camera_cut = spec.get_int_attribute("afterimage:camera_cut", 0) != 0;
}
}  // namespace

FrameHeader check_frame_header(const std::string& path, ChannelSet required,
                               std::string_view required_by, const Layout& layout) {
  auto in = open_input(path);
  plan_channels(file_channels(*in, path), path, required, required_by, layout);
  FrameHeader header;
  read_header(in->spec(), header);
  validate_header(header, path);
  header.width = display_width(in->spec());
  header.height = display_height(in->spec());
  return header;
}

Frame read_frame(const std::string& path, ChannelSet required, std::string_view required_by,
                 InputRegistry* inputs, const Layout& layout, const ReadPolicy& policy) {
  auto in = open_input(path);
  if (inputs) inputs->add(path);
  const ImageSpec& spec = in->spec();  // the first part's (read_native returns to it)
  // Every check the header allows comes before the first pixel is read.
  const FileChannels fc = file_channels(*in, path);
  const std::vector<ChannelPlan> plan = plan_channels(fc, path, required, required_by, layout);
  check_uncompressed_exr_complete(*in, path);
  Frame f;
  f.width = display_width(spec);
  f.height = display_height(spec);
  auto loaded = [&](const ChannelPlan& p) {
    return policy.load.empty() || policy.load.contains(p.src->key) || required.contains(p.src->key);
  };
  std::vector<bool> wanted(fc.names.size(), false);
  for (const ChannelPlan& p : plan)
    if (loaded(p))
      for (const PlaneIndex& pi : p.file_index)
        for (int fc : pi)
          if (fc >= 0) wanted[size_t(fc)] = true;
  const std::vector<NativePixels> runs = read_native(*in, path, fc, wanted);
  for (const ChannelPlan& p : plan) {
    if (!loaded(p)) continue;
    const ChannelInfo& r = channel_info(p.src->key);
    f.visit(p.src->key, [&](auto& img) {
      read_planes(runs, path, r, *p.src, p.file_index, spec.width, spec.height, img);
      pad_to_display_window(img, spec, r.fill);
    });
  }
  repair_non_finite(f, path, policy);

  read_header(spec, f);
  validate_frame(f, path);
  return f;
}

namespace {

std::string lower_extension(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

bool has_kind_extension(const fs::path& p, SequenceKind kind) {
  const std::string ext = lower_extension(p);
  if (kind == SequenceKind::exr) return p.extension() == ".exr";  // ours and Blender's: lower case
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg";
}

// <stem><sep><digits> of a frame file name without its extension: (stem, digits), or nothing.
std::optional<std::pair<std::string, std::string>> split_frame_name(const std::string& base) {
  size_t d = base.size();
  while (d > 0 && base[d - 1] >= '0' && base[d - 1] <= '9') --d;
  if (d == base.size() || d < 2 || (base[d - 1] != '.' && base[d - 1] != '_')) return {};
  return std::pair{base.substr(0, d - 1), base.substr(d)};
}

// Whether `dir` holds a frame file of `kind` (errors listing the directory: false).
bool holds_frames(const std::string& dir, SequenceKind kind) {
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (has_kind_extension(it->path(), kind) && split_frame_name(it->path().stem().string()))
      return true;
  return false;
}

}  // namespace

SequenceKind sequence_kind(const std::string& dir) {
  return !holds_frames(dir, SequenceKind::exr) && holds_frames(dir, SequenceKind::display)
             ? SequenceKind::display
             : SequenceKind::exr;
}

std::vector<SequenceFile> scan_sequence(const std::string& dir, const std::string& name,
                                        SequenceKind kind) {
  if (name.find('/') != std::string::npos || name.find('\0') != std::string::npos)
    throw SettingsError(fmt::format("--name '{}': must be a file-name stem (no '/')", name));
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(fmt::format("{}: not a directory", dir));
  // <stem><sep><digits>.<ext> with sep '.' (ours) or '_' (Blender's ####); the stem is
  // compared literally (a name may hold any character, pattern characters included).
  std::map<std::string, std::vector<SequenceFile>> by_stem;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!has_kind_extension(it->path(), kind)) continue;
    const auto parts = split_frame_name(it->path().stem().string());
    if (!parts) continue;
    const auto& [stem, digits] = *parts;
    if (!name.empty() && stem != name) continue;
    if (digits.size() > 9)
      throw InputError(
          fmt::format("{}: frame number {} has more than 9 digits", it->path().string(), digits));
    by_stem[stem].push_back({std::stoi(digits), it->path().string()});
  }
  if (ec) throw InputError(fmt::format("{}: cannot list directory: {}", dir, ec.message()));
  if (name.empty() && by_stem.size() > 1) {
    std::vector<std::string> stems;
    for (const auto& [stem, files] : by_stem) stems.push_back(stem);
    throw InputError(fmt::format("{}: several sequences ({}); choose one with --name", dir,
                                 fmt::join(stems, ", ")));
  }
  std::vector<SequenceFile> found;
  if (!by_stem.empty()) found = std::move(by_stem.begin()->second);
  if (found.empty()) {
    const std::string n = name.empty() ? "NAME" : name;
    if (kind == SequenceKind::display)
      throw InputError(
          fmt::format("{}: no frames named {}.NNNN.png, .jpg or .jpeg (or {}_NNNN)", dir, n, n));
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      if (!has_kind_extension(it->path(), SequenceKind::display)) continue;
      const std::string ext = lower_extension(it->path());
      throw InputError(fmt::format(
          "{}: holds {} display images (8-bit, tonemapped), not EXR frames; frames are read "
          "as linear EXR (resolve --out-format exr); only eval scores display images",
          dir, ext == ".png" ? "PNG" : "JPEG"));
    }
    throw InputError(fmt::format("{}: no frames named {}.NNNN.exr or {}_NNNN.exr", dir, n, n));
  }
  std::sort(found.begin(), found.end(), [](const SequenceFile& a, const SequenceFile& b) {
    return a.number != b.number ? a.number < b.number : a.path < b.path;
  });
  for (size_t i = 1; i < found.size(); ++i)
    if (found[i].number == found[i - 1].number)
      throw InputError(fmt::format("{}: frame number {} also in {}; remove one of them",
                                   found[i].path, found[i].number, found[i - 1].path));
  return found;
}

std::string sequence_output_name(const SequenceFile& in, const std::string& name,
                                 std::string_view ext) {
  if (name.empty()) {
    fs::path p = fs::path(in.path).filename();
    p.replace_extension(ext);
    return p.string();
  }
  if (name.find_first_of(std::string_view("/\\\0", 3)) != std::string::npos || name == "." ||
      name == "..")
    throw SettingsError(fmt::format("--out-name '{}': must be a file-name stem (no '/')", name));
  return fmt::format("{}.{:04d}{}", name, in.number, ext);
}

std::vector<std::string> list_sequence(const std::string& dir, const std::string& name) {
  std::vector<std::string> out;
  for (auto& f : scan_sequence(dir, name)) out.push_back(std::move(f.path));
  return out;
}

void check_same_size(const Frame& f, int width, int height, const std::string& path) {
  if (f.width != width || f.height != height)
    throw InputError(fmt::format("{}: size {}x{} differs from the sequence's {}x{}", path, f.width,
                                 f.height, width, height));
}

ImageF read_channels(const std::string& path, InputRegistry* inputs) {
  auto in = open_input(path);
  if (inputs) inputs->add(path);
  check_uncompressed_exr_complete(*in, path);
  const ImageSpec& spec = in->spec();
  const int nc = spec.nchannels;
  std::vector<float> buf(size_t(spec.width) * spec.height * nc);
  read_channel_range(*in, path, 0, 0, nc, TypeDesc::FLOAT, buf.data());
  ImageF img(spec.width, spec.height, nc);
  const size_t npix = img.plane_size();
  for (int c = 0; c < nc; ++c) {
    float* dst = img.plane(c);
    for (size_t i = 0; i < npix; ++i) dst[i] = buf[i * nc + c];
  }
  pad_to_display_window(img, spec, 0.0f);
  return img;
}

ImageF read_rgb(const std::string& path, bool decode_srgb, InputRegistry* inputs) {
  ImageF all = read_channels(path, inputs);
  auto in = open_input(path);
  const TypeDesc fmt = in->spec().format;
  const bool is_integer = fmt.basetype == TypeDesc::UINT8 || fmt.basetype == TypeDesc::UINT16;
  ImageF rgb(all.width(), all.height(), 3);
  for (int c = 0; c < 3; ++c) {
    const float* src = all.plane(std::min(c, all.channels() >= 3 ? c : 0));
    std::copy(src, src + all.plane_size(), rgb.plane(c));
  }
  if (is_integer && decode_srgb)
    for (float& v : rgb.data()) v = srgb_decode(v);
  return rgb;
}

void write_rgb(const std::string& path, const ImageF& img, const InputRegistry* inputs) {
  AI_CHECK(img.channels() >= 3);
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  const bool ldr = ext == ".png" || ext == ".jpg" || ext == ".jpeg";
  ImageSpec spec(img.width(), img.height(), 3, ldr ? TypeDesc::UINT8 : TypeDesc::FLOAT);
  if (!ldr) spec.attribute("compression", "zip");
  const size_t npix = img.plane_size();
  std::vector<float> buf(npix * 3);
  for (int c = 0; c < 3; ++c)
    for (size_t i = 0; i < npix; ++i) buf[i * 3 + c] = img.plane(c)[i];
  atomic_write(path, spec, inputs,
               [&](ImageOutput& out) { return out.write_image(TypeDesc::FLOAT, buf.data()); });
}

std::vector<unsigned char> encode_png(const ImageF& display_rgb) {
  // A unique, exclusively created file (never a predictable name in a shared /tmp), removed
  // on every exit.
  TempFile tmp((fs::temp_directory_path() / "afterimage-encode.png").string());
  write_rgb(tmp.path(), display_rgb);
  std::ifstream f(tmp.path(), std::ios::binary);
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)), {});
  if (f.bad() || bytes.empty())
    throw OutputError(fmt::format("{}: cannot read back the encoded PNG", tmp.path()));
  return bytes;
}

void write_text(const std::string& path, std::string_view text, const InputRegistry* inputs) {
  if (inputs) inputs->check_writable(path);
  write_text_atomic(path, text);
}

std::vector<std::string> file_channel_names(const std::string& path) {
  auto in = open_input(path);
  const FileChannels fc = file_channels(*in, path);
  std::vector<std::string> names = fc.names;
  for (const auto& [name, c] : fc.index)
    if (c >= 0 && name != fc.names[size_t(c)]) names.push_back(name);
  return names;
}

std::string describe_file(const std::string& path) {
  auto in = open_input(path);
  const ImageSpec& spec = in->spec();
  std::string s = fmt::format("file: {}\nformat: {}\nsize: {}x{}\n", path, in->format_name(),
                              display_width(spec), display_height(spec));
  if (!data_is_display_window(spec))
    s += fmt::format("data window: {}x{} at ({}, {}) (the pixels outside it are empty)\n",
                     spec.width, spec.height, spec.x, spec.y);
  s += fmt::format("channels ({}):", spec.nchannels);
  for (int c = 0; c < spec.nchannels; ++c)
    s += fmt::format(" {}({})", spec.channelnames[c], spec.channelformat(c).c_str());
  s += "\n";
  for (const auto& p : spec.extra_attribs)
    s += fmt::format("{}: {}\n", p.name().string(), spec.metadata_val(p, true));
  // A multi-part file's other parts (the header above is the first part's).
  const FileChannels fc = file_channels(*in, path);
  if (fc.parts() > 1)
    s += fmt::format(
        "parts: {} (the channels above are part 1's, '{}'; a channel is also named "
        "PART.CHANNEL)\n",
        fc.parts(), fc.part_names[0]);
  for (size_t part = 1; part < fc.parts(); ++part) {
    std::string list;
    size_t n = 0;
    for (size_t c = 0; c < fc.names.size(); ++c)
      if (fc.part[c] == int(part)) {
        list += fmt::format(" {}({})", fc.names[c], fc.formats[c].c_str());
        ++n;
      }
    s += fmt::format("part {} ('{}'), channels ({}):{}\n", part + 1, fc.part_names[part], n, list);
  }
  return s;
}

}  // namespace afterimage::io
