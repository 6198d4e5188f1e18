#include "frame/frame.h"

#include <cmath>

#include <fmt/format.h>

#include "core/error.h"

namespace afterimage {

namespace {
// The table's own invariants, checked at compile time so a malformed row does not build.
constexpr bool rows_are_consistent() {
  for (size_t i = 0; i < kChannelTable.size(); ++i) {
    const ChannelInfo& r = kChannelTable[i];
    if (size_t(r.key) != i || r.planes < 1 || r.planes > kMaxPlanes) return false;
    for (int p = 0; p < kMaxPlanes; ++p)
      if ((r.exr[size_t(p)] != nullptr) != (p < r.planes)) return false;
  }
  return true;
}
static_assert(rows_are_consistent(),
              "channels.inc: each row needs 1..kMaxPlanes EXR names, as many as its planes");

template <class Want, class Img>
Want* typed_as(Img& img) {
  if constexpr (std::is_same_v<std::remove_const_t<Img>, std::remove_const_t<Want>>)
    return &img;
  else
    return nullptr;
}
}  // namespace

const ChannelInfo* find_channel(std::string_view name) {
  for (const ChannelInfo& r : kChannelTable)
    if (name == r.name) return &r;
  return nullptr;
}

ChannelSet core_channels() {
  ChannelSet s;
  for (const ChannelInfo& r : kChannelTable)
    if (r.core) s.insert(r.key);
  return s;
}

Frame Frame::allocate(int width, int height) {
  return allocate(width, height, core_channels());
}

Frame Frame::allocate(int width, int height, ChannelSet channels) {
  Frame f;
  f.width = width;
  f.height = height;
  for (const ChannelInfo& r : kChannelTable)
    if (channels.contains(r.key)) f.allocate_channel(r.key);
  return f;
}

void Frame::allocate_channel(Channel c) {
  const ChannelInfo& r = channel_info(c);
  visit(c, [&](auto& img) {
    using Img = std::remove_reference_t<decltype(img)>;
    using T = std::remove_reference_t<decltype(img.data()[0])>;
    img = Img(width, height, r.planes, T(r.fill));
  });
}

ImageF* Frame::plane_set(Channel c) {
  ImageF* p = nullptr;
  visit(c, [&](auto& img) { p = typed_as<ImageF>(img); });
  return p;
}
const ImageF* Frame::plane_set(Channel c) const {
  return const_cast<Frame*>(this)->plane_set(c);  // read-only view of the same lookup
}
ImageU32* Frame::plane_set_u32(Channel c) {
  ImageU32* p = nullptr;
  visit(c, [&](auto& img) { p = typed_as<ImageU32>(img); });
  return p;
}
const ImageU32* Frame::plane_set_u32(Channel c) const {
  return const_cast<Frame*>(this)->plane_set_u32(c);
}

bool Frame::has(Channel c) const {
  bool present = false;
  visit(c, [&](const auto& img) { present = img.channels() == channel_info(c).planes; });
  return present;
}

Frame Frame::header_only() const {
  Frame f;
  static_cast<FrameHeader&>(f) = *this;
  return f;
}

void Frame::adopt_missing_channels(Frame&& from) {
  // An output of another size (upsampling) has no G-buffer of its own size to take.
  if (width != from.width || height != from.height) return;
#define AFTERIMAGE_CHANNEL(key, ...) \
  if (key.empty() && !from.key.empty()) key = std::move(from.key);
#include "frame/channels.inc"
}

void validate_header(const FrameHeader& f, const std::string& what) {
  // Header values are refused, not repaired: a camera has no safe substitute, and NaN would
  // pass every range test below (abs(NaN) > 0.5 is false).
  auto finite_matrix = [](const Mat4& m) {
    for (const auto& row : m.m)
      for (double v : row)
        if (!std::isfinite(v)) return false;
    return true;
  };
  if (!finite_matrix(f.view))
    throw InputError(fmt::format("{}: camera view matrix is not finite", what));
  if (!finite_matrix(f.projection))
    throw InputError(fmt::format("{}: camera projection matrix is not finite", what));
  if (!std::isfinite(f.time)) throw InputError(fmt::format("{}: time is not finite", what));
  const ThinLens& l = f.lens;
  if (!std::isfinite(l.focal_length_mm) || !std::isfinite(l.f_number) ||
      !std::isfinite(l.focus_distance) || !std::isfinite(l.sensor_width_mm) ||
      !std::isfinite(l.blade_rotation_deg))
    throw InputError(fmt::format("{}: lens parameters are not finite", what));
  if (l.blades != 0 && (l.blades < 3 || l.blades > 16))
    throw InputError(
        fmt::format("{}: lens blades {} (expected 0 = disc or 3..16)", what, l.blades));
  if (!(std::abs(f.jitter.x) <= 0.5 + 1e-6) || !(std::abs(f.jitter.y) <= 0.5 + 1e-6))
    throw InputError(
        fmt::format("{}: jitter ({}, {}) outside [-0.5, 0.5]", what, f.jitter.x, f.jitter.y));
}

void validate_frame(const Frame& f, const std::string& what) {
  if (f.width <= 0 || f.height <= 0)
    throw InputError(fmt::format("{}: empty frame ({}x{})", what, f.width, f.height));
  if (!f.has_color()) throw InputError(fmt::format("{}: missing color channels R G B", what));
  for (const ChannelInfo& r : kChannelTable)
    f.visit(r.key, [&](const auto& img) {
      if (img.empty()) return;  // optional channel absent
      if (img.channels() != r.planes || img.width() != f.width || img.height() != f.height)
        throw InputError(fmt::format("{}: {} is {}x{}x{}, expected {}x{}x{}", what, r.name,
                                     img.width(), img.height(), img.channels(), f.width, f.height,
                                     r.planes));
    });
  validate_header(f, what);
}

}  // namespace afterimage
