// The G-buffer frame handed to every temporal technique (DESIGN.md §1, §3): a set of
// channels described by one table (frame/channels.inc).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>
#include <type_traits>

#include "camera/camera.h"
#include "core/image.h"
#include "core/math.h"

namespace afterimage {

// Linear view depth of background (sky) pixels; anything larger, infinite or NaN maps here.
constexpr float kBackgroundDepth = 1e10f;

// Channel keys, in table (= file write) order.
enum class Channel : uint8_t {
#define AFTERIMAGE_CHANNEL(key, ...) key,
#include "frame/channels.inc"
};
inline constexpr int kMaxPlanes = 4;

enum class PixelType : uint8_t { F32, U32 };

// Storage of a channel of pixel type T.
template <PixelType T>
using PlaneSet = std::conditional_t<T == PixelType::F32, ImageF, ImageU32>;

struct ChannelInfo {
  Channel key;
  const char* name;  // key as text ("motion"), for requirements and messages
  PixelType type;
  int planes;
  float fill;  // value of a freshly allocated plane
  bool core;   // allocated by Frame::allocate(w, h)
  const char* description;
  std::array<const char*, kMaxPlanes> exr;  // EXR channel names; [planes, kMaxPlanes) null
};

// The table, row i describing Channel(i).
inline constexpr auto kChannelTable = std::to_array<ChannelInfo>({
#define AFTERIMAGE_CHANNEL(key, type, planes, fill, core, description, ...) \
  {Channel::key, #key, PixelType::type, planes, fill, core, description, {__VA_ARGS__}},
#include "frame/channels.inc"
});
inline constexpr size_t kChannelCount = kChannelTable.size();

constexpr const ChannelInfo& channel_info(Channel c) {
  return kChannelTable[size_t(c)];
}
// The row whose key is `name` ("motion"), or nullptr.
const ChannelInfo* find_channel(std::string_view name);

// A small set of channel keys (requirements, allocation lists).
class ChannelSet {
 public:
  constexpr ChannelSet() = default;
  constexpr ChannelSet(std::initializer_list<Channel> cs) {
    for (Channel c : cs) insert(c);
  }
  constexpr void insert(Channel c) { bits_ |= uint32_t(1) << unsigned(c); }
  constexpr bool contains(Channel c) const { return (bits_ >> unsigned(c)) & 1u; }
  constexpr bool empty() const { return bits_ == 0; }
  constexpr bool operator==(const ChannelSet&) const = default;

 private:
  static_assert(kChannelCount <= 32, "ChannelSet holds at most 32 channels");
  uint32_t bits_ = 0;
};

// The six channels every rendered frame has (rows marked core).
ChannelSet core_channels();

// One member per table row, named by its key (f.color, f.depth, ..., f.motion_next); an
// empty image means the channel is absent. Meanings: the description column of the table.
// (A base rather than inline in Frame: an #include inside a class body derails clang-format
// for the rest of that class.)
struct FrameChannels {
#define AFTERIMAGE_CHANNEL(key, type, ...) PlaneSet<PixelType::type> key;
#include "frame/channels.inc"
};

// Size, camera and timing of a frame: everything but the pixels.
struct FrameHeader {
  int width = 0, height = 0;

  // Camera of this frame. `projection` is always the unjittered one.
  Mat4 view = Mat4::identity();
  Mat4 projection = Mat4::identity();
  Vec2d jitter{0.0, 0.0};  // pixels in [-0.5, 0.5]^2, y down
  int index = 0;           // frame number
  double time = 0.0;       // seconds
  ThinLens lens;
  // False when the files carry no lens (another renderer's, with no "lens" in the camera
  // sidecar): `lens` then holds ThinLens's defaults, which are nobody's camera, and the DoF
  // pass takes the lens from its settings or refuses (post::checked_dof_lens).
  bool lens_known = true;
  // False when the files carry no camera (another renderer's, with no view and projection in
  // a camera sidecar): `view` and `projection` then hold identities, and what needs the
  // camera's own motion (motion blur's camera / object split) refuses the frame.
  bool camera_known = true;
  bool camera_cut = false;  // history must not be used across this frame
};

struct Frame : FrameChannels, FrameHeader {
  // A frame with this header and no channels: where a method's output starts.
  Frame header_only() const;
  // Moves every channel that is absent here but present in `from` into this frame, so a
  // method's output takes over the rest of the input G-buffer without copying pixels. Does
  // nothing when the sizes differ (an upsampled output keeps only its own channels).
  void adopt_missing_channels(Frame&& from);

  // Allocates the core channels for width x height (each plane at its table fill: zeros,
  // depth = background); optional channels stay absent.
  static Frame allocate(int width, int height);
  // Allocates exactly `channels`.
  static Frame allocate(int width, int height, ChannelSet channels);
  // (Re)allocates one channel at its table fill.
  void allocate_channel(Channel c);

  // Generic access: the storage of `c`, or nullptr if `c` has the other pixel type.
  ImageF* plane_set(Channel c);
  const ImageF* plane_set(Channel c) const;
  ImageU32* plane_set_u32(Channel c);
  const ImageU32* plane_set_u32(Channel c) const;
  // Present = as many planes as the table says.
  bool has(Channel c) const;
  // Calls fn(image) with the storage of `c` (ImageF& or ImageU32&).
  template <class Fn>
  void visit(Channel c, Fn&& fn);
  template <class Fn>
  void visit(Channel c, Fn&& fn) const;

  bool has_color() const { return has(Channel::color); }
  bool has_depth() const { return has(Channel::depth); }
  bool has_normal() const { return has(Channel::normal); }
  bool has_albedo() const { return has(Channel::albedo); }
  bool has_motion() const { return has(Channel::motion); }
  bool has_id() const { return has(Channel::id); }

  Vec3f color_at(int x, int y) const {
    return {color.at(x, y, 0), color.at(x, y, 1), color.at(x, y, 2)};
  }
  Vec2f motion_at(int x, int y) const { return {motion.at(x, y, 0), motion.at(x, y, 1)}; }
};

// One switch over the table for both constnesses: fn receives the member of `c`.
template <class F, class Fn>
void visit_channel(F& f, Channel c, Fn&& fn) {
  switch (c) {
#define AFTERIMAGE_CHANNEL(key, ...) \
  case Channel::key:                 \
    fn(f.key);                       \
    return;
#include "frame/channels.inc"
  }
}
template <class Fn>
void Frame::visit(Channel c, Fn&& fn) {
  visit_channel(*this, c, fn);
}
template <class Fn>
void Frame::visit(Channel c, Fn&& fn) const {
  visit_channel(*this, c, fn);
}

// Checks structure only: a positive size, color present, every present channel with the
// table's plane count and the frame's width x height, and the header (validate_header). Pixel
// values are not inspected (loaders repair them, io::ReadPolicy; methods sanitise color).
// Throws InputError naming `what` (file or frame) and the first problem found.
void validate_frame(const Frame& f, const std::string& what);
// The header part of validate_frame: camera matrices, time and lens finite, jitter within
// [-0.5, 0.5] (NaN refused). Throws InputError "<what>: <problem>".
void validate_header(const FrameHeader& f, const std::string& what);

}  // namespace afterimage
