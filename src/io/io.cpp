#include "io/io.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
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
std::optional<std::string> exr_attribute_problem(std::istream& f, const std::string& type,
                                                 uint32_t size) {
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
    for (;;) {
      if (!read_string(name)) throw damaged("unterminated attribute name");
      if (name.empty()) break;
      first = false;
      if (!read_string(type)) throw damaged(fmt::format("attribute '{}': bad type name", name));
      int32_t size = 0;
      if (!f.read(reinterpret_cast<char*>(&size), 4)) throw damaged("truncated");
      const uint64_t at = uint64_t(f.tellg());
      if (size < 0 || at + uint64_t(size) > file_size)
        throw damaged(fmt::format("attribute '{}' declares {} bytes, beyond the end of the file",
                                  name, size));
      // OpenEXR reads known types by their own structure, not by the declared size; where the
      // two disagree its reading goes out of step with the file and takes later bytes as
      // sizes (fuzzing found a 1444-byte file that allocated 1.9 GB that way).
      if (auto problem = exr_attribute_problem(f, type, uint32_t(size)))
        throw damaged(fmt::format("attribute '{}' of type {}: {}", name, type, *problem));
      f.clear();
      f.seekg(std::streamoff(at + uint64_t(size)));
    }
    if (!multipart || first) return;  // single part: one header; multi-part: empty header ends
  }
}

std::unique_ptr<ImageInput> open_input(const std::string& path) {
  check_regular_readable(path);
  check_exr_header(path);
  auto in = ImageInput::open(path);
  if (!in) {
    std::string e = OIIO::geterror();
    std::replace(e.begin(), e.end(), '\n', ' ');
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
  return in;
}

// Reads channels [cb, ce) as `type` into `dst` (interleaved), with a one-line error.
void read_channel_range(ImageInput& in, const std::string& path, int cb, int ce, TypeDesc type,
                        void* dst) {
  if (!in.read_image(0, 0, cb, ce, type, dst)) {
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

// Reads the planes of one channel through its layout mapping into `img`.
template <class Img>
void read_planes(ImageInput& in, const std::string& path, const ChannelInfo& r,
                 const ChannelSource& src, const std::vector<PlaneIndex>& file_index, int width,
                 int height, Img& img) {
  using T = std::remove_reference_t<decltype(img.data()[0])>;
  img = Img(width, height, r.planes);
  std::vector<T> tmp(img.plane_size());
  std::vector<float> tmp2;
  for (int c = 0; c < r.planes; ++c) {
    const int fc = file_index[size_t(c)][0];
    T* dst = img.plane(c);
    const PlaneSource& ps = src.planes[size_t(c)];
    if constexpr (std::is_same_v<T, uint32_t>) {
      // Ids stored as float (Blender's IndexOB) are labels: read as float and checked to be
      // whole numbers (OIIO would rescale a float to the full integer range).
      if (in.spec().channelformat(fc).is_floating_point()) {
        tmp2.resize(tmp.size());
        read_channel_range(in, path, fc, fc + 1, TypeDesc::FLOAT, tmp2.data());
        for (size_t i = 0; i < tmp2.size(); ++i) {
          const float v = tmp2[i];
          if (!(v >= 0.0f && v <= 4294967040.0f && v == std::floor(v)))
            throw InputError(fmt::format(
                "{}: channel {} ({}) holds {} at pixel ({}, {}); a float id must be a whole "
                "number >= 0",
                path, ps.file_name, r.name, v, i % size_t(width), i / size_t(width)));
          dst[i] = uint32_t(v);
        }
        continue;
      }
    }
    read_channel_range(in, path, fc, fc + 1, file_type(r.type), tmp.data());
    // Identity planes are copied, never computed, so our own files load bit-exactly
    // (keeps -0 and NaN payloads); Layout::map refuses conversions of uint channels.
    if constexpr (std::is_same_v<T, float>) {
      if (const int fc2 = file_index[size_t(c)][1]; fc2 >= 0) {
        tmp2.resize(tmp.size());
        read_channel_range(in, path, fc2, fc2 + 1, TypeDesc::FLOAT, tmp2.data());
        for (size_t i = 0; i < tmp.size(); ++i) tmp[i] += tmp2[i];
      }
      if (!ps.identity()) {
        for (size_t i = 0; i < tmp.size(); ++i) dst[i] = float(ps.scale * tmp[i] + ps.offset);
        continue;
      }
    }
    std::copy(tmp.begin(), tmp.end(), dst);
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

std::vector<ChannelPlan> plan_channels(const ImageSpec& spec, const std::string& path,
                                       ChannelSet required, std::string_view required_by,
                                       const Layout& layout) {
  const std::string by =
      required_by.empty() ? std::string("required") : fmt::format("required by {}", required_by);
  for (const ChannelInfo& r : kChannelTable)
    if (required.contains(r.key) && !layout.find(r.key))
      throw InputError(fmt::format("{}: layout '{}' has no source for {} ({})", path, layout.name(),
                                   r.name, by));
  std::map<std::string, int> index;
  for (int c = 0; c < spec.nchannels; ++c) index[spec.channelnames[size_t(c)]] = c;

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
        auto it = index.find(fn);
        if (it != index.end())
          i[size_t(k)] = it->second;
        else
          missing.push_back(fn);
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
        if (auto problem = pixel_type_problem(want, spec.channelformat(idx[c][size_t(k)])))
          throw InputError(fmt::format("{}: channel {} ({}) {}", path,
                                       k == 0 ? src.planes[c].file_name : src.planes[c].plus_name,
                                       r.name, *problem));
      }
    plan.push_back({&src, std::move(idx)});
  }
  return plan;
}

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

void write_frame(const std::string& path, const Frame& f, const InputRegistry* inputs) {
  validate_frame(f, path);
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
  for (const auto& c : chans) {
    spec.channelnames.push_back(c.name);
    spec.channelformats.push_back(file_type(c.type));
  }
  spec.attribute("compression", "zip");
  set_matrix(spec, "afterimage:view", f.view);
  set_matrix(spec, "afterimage:projection", f.projection);
  const double jitter[2] = {f.jitter.x, f.jitter.y};
  spec.attribute("afterimage:jitter", TypeDesc(TypeDesc::DOUBLE, TypeDesc::VEC2), jitter);
  spec.attribute("afterimage:frame", f.index);
  spec.attribute("afterimage:time", TypeDesc::DOUBLE, &f.time);
  spec.attribute("afterimage:lens_focal_mm", TypeDesc::DOUBLE, &f.lens.focal_length_mm);
  spec.attribute("afterimage:lens_f_number", TypeDesc::DOUBLE, &f.lens.f_number);
  spec.attribute("afterimage:lens_focus_distance", TypeDesc::DOUBLE, &f.lens.focus_distance);
  spec.attribute("afterimage:lens_sensor_width_mm", TypeDesc::DOUBLE, &f.lens.sensor_width_mm);
  spec.attribute("afterimage:camera_cut", int(f.camera_cut));

  // Interleave: every channel is 4 bytes (float or uint32), in native per-channel formats.
  const size_t nch = chans.size(), npix = size_t(f.width) * f.height;
  std::vector<uint32_t> buf(npix * nch);
  for (size_t c = 0; c < nch; ++c) {
    const uint32_t* src = static_cast<const uint32_t*>(chans[c].plane);
    for (size_t i = 0; i < npix; ++i) buf[i * nch + c] = src[i];
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
  get_matrix(spec, "afterimage:view", f.view);
  get_matrix(spec, "afterimage:projection", f.projection);
  double jitter[2] = {0, 0};
  if (spec.getattribute("afterimage:jitter", TypeDesc(TypeDesc::DOUBLE, TypeDesc::VEC2), jitter))
    f.jitter = {jitter[0], jitter[1]};
  f.index = spec.get_int_attribute("afterimage:frame", 0);
  double t = 0;
  if (spec.getattribute("afterimage:time", TypeDesc::DOUBLE, &t)) f.time = t;
  spec.getattribute("afterimage:lens_focal_mm", TypeDesc::DOUBLE, &f.lens.focal_length_mm);
  spec.getattribute("afterimage:lens_f_number", TypeDesc::DOUBLE, &f.lens.f_number);
  spec.getattribute("afterimage:lens_focus_distance", TypeDesc::DOUBLE, &f.lens.focus_distance);
  spec.getattribute("afterimage:lens_sensor_width_mm", TypeDesc::DOUBLE, &f.lens.sensor_width_mm);
  f.camera_cut = spec.get_int_attribute("afterimage:camera_cut", 0) != 0;
}
}  // namespace

FrameShape check_frame_header(const std::string& path, ChannelSet required,
                              std::string_view required_by, const Layout& layout) {
  auto in = open_input(path);
  plan_channels(in->spec(), path, required, required_by, layout);
  FrameHeader header;
  read_header(in->spec(), header);
  validate_header(header, path);
  return {in->spec().width, in->spec().height};
}

Frame read_frame(const std::string& path, ChannelSet required, std::string_view required_by,
                 InputRegistry* inputs, const Layout& layout, const ReadPolicy& policy) {
  auto in = open_input(path);
  if (inputs) inputs->add(path);
  const ImageSpec& spec = in->spec();
  // Every check the header allows comes before the first pixel is read.
  const std::vector<ChannelPlan> plan = plan_channels(spec, path, required, required_by, layout);
  Frame f;
  f.width = spec.width;
  f.height = spec.height;
  for (const ChannelPlan& p : plan) {
    const ChannelInfo& r = channel_info(p.src->key);
    f.visit(p.src->key, [&](auto& img) {
      read_planes(*in, path, r, *p.src, p.file_index, f.width, f.height, img);
    });
  }
  repair_non_finite(f, path, policy);

  read_header(spec, f);
  validate_frame(f, path);
  return f;
}

std::vector<SequenceFile> scan_sequence(const std::string& dir, const std::string& name) {
  if (name.find('/') != std::string::npos || name.find('\0') != std::string::npos)
    throw SettingsError(fmt::format("--name '{}': must be a file-name stem (no '/')", name));
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(fmt::format("{}: not a directory", dir));
  // <stem><sep><digits>.exr with sep '.' (ours) or '_' (Blender's ####); the stem is compared
  // literally (a name may hold any character, pattern characters included).
  std::map<std::string, std::vector<SequenceFile>> by_stem;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string fn = it->path().filename().string();
    constexpr std::string_view kExt = ".exr";
    if (fn.size() <= kExt.size() || fn.compare(fn.size() - kExt.size(), kExt.size(), kExt) != 0)
      continue;
    const std::string base = fn.substr(0, fn.size() - kExt.size());
    size_t d = base.size();
    while (d > 0 && base[d - 1] >= '0' && base[d - 1] <= '9') --d;
    if (d == base.size() || d < 2 || (base[d - 1] != '.' && base[d - 1] != '_')) continue;
    const std::string stem = base.substr(0, d - 1), digits = base.substr(d);
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
  const ImageSpec& spec = in->spec();
  const int nc = spec.nchannels;
  std::vector<float> buf(size_t(spec.width) * spec.height * nc);
  read_channel_range(*in, path, 0, nc, TypeDesc::FLOAT, buf.data());
  ImageF img(spec.width, spec.height, nc);
  const size_t npix = img.plane_size();
  for (int c = 0; c < nc; ++c) {
    float* dst = img.plane(c);
    for (size_t i = 0; i < npix; ++i) dst[i] = buf[i * nc + c];
  }
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

std::string describe_file(const std::string& path) {
  auto in = open_input(path);
  const ImageSpec& spec = in->spec();
  std::string s = fmt::format("file: {}\nformat: {}\nsize: {}x{}\nchannels ({}):", path,
                              in->format_name(), spec.width, spec.height, spec.nchannels);
  for (int c = 0; c < spec.nchannels; ++c)
    s += fmt::format(" {}({})", spec.channelnames[c], spec.channelformat(c).c_str());
  s += "\n";
  for (const auto& p : spec.extra_attribs)
    s += fmt::format("{}: {}\n", p.name().string(), spec.metadata_val(p, true));
  return s;
}

}  // namespace afterimage::io
