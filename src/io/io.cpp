#include "io/io.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <string_view>
#include <type_traits>

#include "core/atomic_file.h"
#include "core/color.h"
#include "core/error.h"

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

std::unique_ptr<ImageInput> open_input(const std::string& path) {
  if (!fs::exists(path)) throw InputError(fmt::format("{}: no such file", path));
  auto in = ImageInput::open(path);
  if (!in) {
    std::string e = OIIO::geterror();
    std::replace(e.begin(), e.end(), '\n', ' ');
    throw InputError(fmt::format("{}: unreadable image ({})", path, e));
  }
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

// Reads the planes of one channel through its layout mapping into `img`. `file_index[c]`
// holds the file channel of plane c and of its optional plus_name (-1 if none).
template <class Img>
void read_planes(ImageInput& in, const std::string& path, const ChannelInfo& r,
                 const ChannelSource& src, const std::vector<std::array<int, 2>>& file_index,
                 int width, int height, Img& img) {
  using T = std::remove_reference_t<decltype(img.data()[0])>;
  img = Img(width, height, r.planes);
  std::vector<T> tmp(img.plane_size());
  std::vector<float> tmp2;
  for (int c = 0; c < r.planes; ++c) {
    const int fc = file_index[size_t(c)][0];
    T* dst = img.plane(c);
    const PlaneSource& ps = src.planes[size_t(c)];
    if constexpr (std::is_same_v<T, uint32_t>) {
      // Ids stored as float (Blender's IndexOB) are labels: round them; OIIO would
      // otherwise rescale a float to the full integer range.
      if (in.spec().channelformat(fc).is_floating_point()) {
        tmp2.resize(tmp.size());
        read_channel_range(in, path, fc, fc + 1, TypeDesc::FLOAT, tmp2.data());
        for (size_t i = 0; i < tmp2.size(); ++i)
          dst[i] = tmp2[i] > 0.0f ? uint32_t(std::lround(std::min(tmp2[i], 4294967295.0f))) : 0u;
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

Frame read_frame(const std::string& path, ChannelSet required, std::string_view required_by,
                 InputRegistry* inputs, const Layout& layout) {
  const std::string by =
      required_by.empty() ? std::string("required") : fmt::format("required by {}", required_by);
  for (const ChannelInfo& r : kChannelTable)
    if (required.contains(r.key) && !layout.find(r.key))
      throw InputError(fmt::format("{}: layout '{}' has no source for {} ({})", path, layout.name(),
                                   r.name, by));
  auto in = open_input(path);
  if (inputs) inputs->add(path);
  const ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0) throw InputError(fmt::format("{}: empty image", path));
  Frame f;
  f.width = spec.width;
  f.height = spec.height;

  std::map<std::string, int> index;
  for (int c = 0; c < spec.nchannels; ++c) index[spec.channelnames[c]] = c;

  for (const ChannelSource& src : layout.sources()) {
    const ChannelInfo& r = channel_info(src.key);
    std::vector<std::array<int, 2>> idx;
    std::vector<std::string> missing;
    for (const PlaneSource& ps : src.planes) {
      std::array<int, 2> i{-1, -1};
      for (int k = 0; k < 2; ++k) {
        const std::string& fn = k == 0 ? ps.file_name : ps.plus_name;
        if (fn.empty()) continue;
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
    f.visit(src.key,
            [&](auto& img) { read_planes(*in, path, r, src, idx, f.width, f.height, img); });
  }
  // Loader convention: anything larger, infinite or NaN is background depth.
  if (!f.depth.empty())
    for (float& d : f.depth.data())
      if (!(d < kBackgroundDepth)) d = kBackgroundDepth;

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
  validate_frame(f, path);
  return f;
}

std::vector<std::string> list_sequence(const std::string& dir, const std::string& name) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(fmt::format("{}: not a directory", dir));
  const std::regex re(name + R"(\.(\d+)\.exr)");
  std::vector<std::pair<int, std::string>> found;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    std::smatch m;
    const std::string fn = e.path().filename().string();
    if (std::regex_match(fn, m, re)) found.push_back({std::stoi(m[1]), e.path().string()});
  }
  if (found.empty()) throw InputError(fmt::format("{}: no frames named {}.NNNN.exr", dir, name));
  std::sort(found.begin(), found.end());
  std::vector<std::string> out;
  for (auto& [n, p] : found) out.push_back(p);
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
