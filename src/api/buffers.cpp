// The caller's buffers (BufferView: any strides, f32 / f16 / u32) to the modules' planar
// images and back, and a FrameInput to a Frame (api/convert.h).
#include <Imath/half.h>
#include <fmt/format.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "api/convert.h"
#include "core/error.h"
#include "core/limits.h"
#include "frame/conventions.h"
#include "io/io.h"

namespace afterimage {
inline namespace v0 {

namespace {
size_t element_size(DataType t) {
  return t == DataType::f16 ? 2 : 4;
}
}  // namespace

BufferView BufferView::interleaved(void* data, int width, int height, int channels, DataType type) {
  BufferView b;
  b.data = data;
  b.type = type;
  b.width = width;
  b.height = height;
  b.channels = channels;
  return b;
}

BufferView BufferView::planar(void* data, int width, int height, int channels, DataType type) {
  BufferView b = interleaved(data, width, height, channels, type);
  const auto e = std::ptrdiff_t(element_size(type));
  b.pixel_stride = e;
  b.row_stride = e * width;
  b.channel_stride = e * width * height;
  return b;
}

}  // namespace v0
}  // namespace afterimage

namespace afterimage::api {

namespace {

// The strides with the packed interleaved defaults filled in.
struct Strides {
  std::ptrdiff_t pixel, row, channel;
};
Strides strides_of(const BufferView& b) {
  const auto e = std::ptrdiff_t(element_size(b.type));
  Strides s;
  s.channel = b.channel_stride ? b.channel_stride : e;
  s.pixel = b.pixel_stride ? b.pixel_stride : e * b.channels;
  s.row = b.row_stride ? b.row_stride : s.pixel * b.width;
  return s;
}

const char* type_name(DataType t) {
  switch (t) {
    case DataType::f32:
      return "f32";
    case DataType::f16:
      return "f16";
    case DataType::u32:
      return "u32";
  }
  return "?";
}

// Element (x, y, c) of `b`.
inline const unsigned char* element(const BufferView& b, const Strides& s, int x, int y, int c) {
  return static_cast<const unsigned char*>(b.data) + y * s.row + x * s.pixel + c * s.channel;
}

float load_float(const BufferView& b, const unsigned char* p) {
  switch (b.type) {
    case DataType::f32: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case DataType::f16: {
      Imath::half h;
      std::memcpy(&h, p, 2);
      return float(h);
    }
    case DataType::u32: {
      uint32_t v;
      std::memcpy(&v, p, 4);
      return float(v);
    }
  }
  return 0.0f;
}

}  // namespace

Exec to_exec(const ExecOptions& o) {
  if (auto problem = thread_count_problem(o.threads))
    throw SettingsError(fmt::format("ExecOptions::threads: {}", *problem));
  Exec e;
  e.threads = o.threads;
  e.simd = o.simd;
  return e;
}

void check_view(const BufferView& b, const std::string& what, int min_channels, int max_channels,
                int width, int height) {
  if (!b.data) throw InputError(fmt::format("{}: no buffer (data is null)", what));
  if (b.width <= 0 || b.height <= 0)
    throw InputError(fmt::format("{}: size {}x{} is not positive", what, b.width, b.height));
  if (width > 0 && (b.width != width || b.height != height))
    throw InputError(
        fmt::format("{}: size {}x{}, expected {}x{}", what, b.width, b.height, width, height));
  if (b.channels < min_channels || b.channels > max_channels)
    throw InputError(
        min_channels == max_channels
            ? fmt::format("{}: {} channels, expected {}", what, b.channels, min_channels)
            : fmt::format("{}: {} channels, expected {} to {}", what, b.channels, min_channels,
                          max_channels));
  if (b.type != DataType::f32 && b.type != DataType::f16 && b.type != DataType::u32)
    throw InputError(fmt::format("{}: unknown data type {}", what, int(b.type)));
  const Strides s = strides_of(b);
  if (s.pixel < 0 || s.row < 0 || s.channel < 0)
    throw InputError(fmt::format("{}: negative strides are not supported", what));
  const auto e = std::ptrdiff_t(element_size(b.type));
  if (s.channel % e || s.pixel % e || s.row % e)
    throw InputError(fmt::format("{}: strides must be multiples of the {} element size ({} bytes)",
                                 what, type_name(b.type), e));
}

BufferView channel_view(const BufferView& b, int c) {
  const Strides s = strides_of(b);
  BufferView v = b;
  v.data = static_cast<unsigned char*>(b.data) + c * s.channel;
  v.channels = 1;
  v.pixel_stride = s.pixel;
  v.row_stride = s.row;
  v.channel_stride = s.channel;
  return v;
}

ImageF to_image(const BufferView& b, int channels) {
  const Strides s = strides_of(b);
  ImageF img = ImageF::uninitialized(b.width, b.height, channels);
  for (int c = 0; c < channels; ++c)
    for (int y = 0; y < b.height; ++y) {
      float* row = img.row(c, y);
      if (b.type == DataType::f32 && s.pixel == 4) {
        std::memcpy(row, element(b, s, 0, y, c), size_t(b.width) * 4);
        continue;
      }
      for (int x = 0; x < b.width; ++x) row[x] = load_float(b, element(b, s, x, y, c));
    }
  return img;
}

ImageU32 to_ids(const BufferView& b, const std::string& what) {
  const Strides s = strides_of(b);
  ImageU32 img = ImageU32::uninitialized(b.width, b.height, 1);
  for (int y = 0; y < b.height; ++y)
    for (int x = 0; x < b.width; ++x) {
      const unsigned char* p = element(b, s, x, y, 0);
      if (b.type == DataType::u32) {
        std::memcpy(&img.at(x, y, 0), p, 4);
        continue;
      }
      const float v = load_float(b, p);
      if (!(v >= 0.0f && v <= 4294967040.0f && v == std::floor(v)))
        throw InputError(
            fmt::format("{}: id {} at pixel ({}, {}) is not a whole number >= 0", what, v, x, y));
      img.at(x, y, 0) = uint32_t(v);
    }
  return img;
}

void write_image(const ImageF& img, const BufferView& out, float fill) {
  const Strides s = strides_of(out);
  for (int c = 0; c < out.channels; ++c)
    for (int y = 0; y < out.height; ++y) {
      auto* base = static_cast<unsigned char*>(out.data) + y * s.row + c * s.channel;
      const float* row = c < img.channels() ? img.row(c, y) : nullptr;
      for (int x = 0; x < out.width; ++x) {
        const float v = row ? row[x] : fill;
        unsigned char* p = base + x * s.pixel;
        if (out.type == DataType::f16) {
          const Imath::half h(v);
          std::memcpy(p, &h, 2);
        } else {
          std::memcpy(p, &v, 4);
        }
      }
    }
}

void write_ids(const ImageU32& img, const BufferView& out) {
  const Strides s = strides_of(out);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      unsigned char* p = static_cast<unsigned char*>(out.data) + y * s.row + x * s.pixel;
      const uint32_t v = img.at(x, y, 0);
      if (out.type == DataType::u32) {
        std::memcpy(p, &v, 4);
      } else {
        const float f = float(v);
        std::memcpy(p, &f, 4);
      }
    }
}

namespace {
Mat4 matrix_of(const float (&m)[16]) {
  Mat4 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r.m[size_t(i)][size_t(j)] = double(m[i * 4 + j]);
  return r;
}
void store_matrix(const Mat4& m, float (&out)[16]) {
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) out[i * 4 + j] = float(m.m[size_t(i)][size_t(j)]);
}
}  // namespace

void apply_camera(const FrameCamera& c, FrameHeader& h) {
  h.camera_known = c.known;
  if (c.known) {
    h.view = matrix_of(c.view);
    h.projection = matrix_of(c.projection);
  }
  h.jitter = {double(c.jitter_x), double(c.jitter_y)};
  h.index = c.index;
  h.time = c.time;
  h.camera_cut = c.cut;
  h.lens_known = c.lens_known;
  if (c.lens_known) {
    h.lens.focal_length_mm = c.lens.focal_length_mm;
    h.lens.f_number = c.lens.f_number;
    h.lens.focus_distance = c.lens.focus_distance;
    h.lens.sensor_width_mm = c.lens.sensor_width_mm;
    h.lens.blades = c.lens.blades;
    h.lens.blade_rotation_deg = c.lens.blade_rotation_deg;
  }
}

FrameCamera camera_of(const FrameHeader& h) {
  FrameCamera c;
  c.known = h.camera_known;
  store_matrix(h.view, c.view);
  store_matrix(h.projection, c.projection);
  c.jitter_x = float(h.jitter.x);
  c.jitter_y = float(h.jitter.y);
  c.index = h.index;
  c.time = h.time;
  c.cut = h.camera_cut;
  c.lens_known = h.lens_known;
  c.lens.focal_length_mm = h.lens.focal_length_mm;
  c.lens.f_number = h.lens.f_number;
  c.lens.focus_distance = h.lens.focus_distance;
  c.lens.sensor_width_mm = h.lens.sensor_width_mm;
  c.lens.blades = h.lens.blades;
  c.lens.blade_rotation_deg = h.lens.blade_rotation_deg;
  return c;
}

Frame to_frame(const FrameInput& in, const std::string& what, const WarnFn& note) {
  check_view(in.color, what + ": color", 3, 4);
  // Named conventions are checked first: a misspelt one fails even on a frame without motion.
  if (in.motion_convention != "afterimage") parse_motion_convention(in.motion_convention);
  if (in.depth_convention != "linear") parse_depth_convention(in.depth_convention);
  const int w = in.color.width, h = in.color.height;
  Frame f;
  f.width = w;
  f.height = h;
  apply_camera(in.camera, f);
  f.color = to_image(in.color, 3);
  auto take = [&](Channel key, const BufferView& b, const std::string& name) {
    const ChannelInfo& r = channel_info(key);
    check_view(b, fmt::format("{}: {}", what, name), r.planes, r.planes, w, h);
    if (r.type == PixelType::U32)
      *f.plane_set_u32(key) = to_ids(b, fmt::format("{}: {}", what, name));
    else
      *f.plane_set(key) = to_image(b, r.planes);
  };
  if (in.color.channels == 4 && in.alpha.empty()) f.alpha = to_image(channel_view(in.color, 3), 1);
  const std::pair<Channel, const BufferView*> named[] = {
      {Channel::depth, &in.depth},   {Channel::normal, &in.normal}, {Channel::albedo, &in.albedo},
      {Channel::motion, &in.motion}, {Channel::id, &in.id},         {Channel::alpha, &in.alpha}};
  for (const auto& [key, view] : named)
    if (!view->empty()) take(key, *view, channel_info(key).name);
  for (const auto& [name, view] : in.extra) {
    const ChannelInfo* r = find_channel(name);
    if (!r) {
      std::string known;
      for (const ChannelInfo& c : kChannelTable)
        known += (known.empty() ? "" : ", ") + std::string(c.name);
      throw SettingsError(
          fmt::format("{}: unknown channel '{}' (channels: {})", what, name, known));
    }
    if (r->key == Channel::color)
      throw SettingsError(fmt::format("{}: give color as FrameInput::color", what));
    if (f.has(r->key)) throw SettingsError(fmt::format("{}: channel '{}' given twice", what, name));
    take(r->key, view, name);
  }
  // As a file is read (io::SequenceReader): non-finite values repaired, then the conventions.
  io::ReadPolicy policy;
  policy.warn = note;
  io::repair_non_finite(f, what, policy);
  if (in.motion_convention != "afterimage") {
    const MotionConvention mc = parse_motion_convention(in.motion_convention);
    if (!f.motion.empty()) convert_motion(f.motion, mc);
    if (!f.motion_next.empty()) convert_motion(f.motion_next, mc);
  }
  if (!f.depth.empty() && in.depth_convention != "linear")
    convert_depth(f, parse_depth_convention(in.depth_convention), f.camera_known, what);
  validate_frame(f, what);
  return f;
}

}  // namespace afterimage::api
