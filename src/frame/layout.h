// Layouts: how another tool's files spell our channels (DESIGN.md §3 "Files"). A layout is
// data — per channel key, the file channel names to read each plane from and an affine
// conversion per plane (value = scale * file + offset) — so a foreign convention such as a
// +Y-up motion vector (scale -1 on y) never needs a new code path in the loader.
#pragma once

#include <string>
#include <vector>

#include "frame/frame.h"

namespace afterimage {

struct PlaneSource {
  std::string file_name;  // channel name in the file
  double scale = 1.0;
  double offset = 0.0;
  // Optional second file channel added before the conversion: value = scale * (file_name +
  // plus_name) + offset (Blender splits light into DiffDir + DiffInd).
  std::string plus_name;
  bool identity() const { return scale == 1.0 && offset == 0.0 && plus_name.empty(); }
};

struct ChannelSource {
  Channel key;
  std::vector<PlaneSource> planes;  // one per plane of the channel, in plane order
  // Named convention applied after reading (io::SequenceReader), when the per-plane affine
  // map cannot express it (UV units need the image size, ray distance the camera): a motion
  // convention for motion / motion_next, a depth convention for depth
  // (frame/conventions.h); "" = ours. Pixel-unit motion conventions are folded into the
  // planes' scale/offset by set_convention instead.
  std::string convention;
};

class Layout {
 public:
  explicit Layout(std::string name) : name_(std::move(name)) {}

  // Reads `key` from `file_names` (one per plane) with optional per-plane conversions
  // (empty = identity). Replaces an earlier mapping of `key`. Throws SettingsError if the
  // counts do not match the channel table or a uint channel is given a conversion. Mapping
  // color also maps alpha to the A beside the color's R (alpha_channel_beside), unless alpha
  // was mapped or unmapped itself: a renderer writes coverage next to its color.
  Layout& map(Channel key, const std::vector<std::string>& file_names,
              const std::vector<PlaneSource>& conversions = {});
  // Drops `key`: it is never read with this layout.
  Layout& unmap(Channel key);
  // Sets the named convention of a mapped motion, motion_next or depth channel (checked
  // against frame/conventions.h; pixel-unit motion conventions become per-plane affine
  // maps, replacing earlier conversions); throws SettingsError otherwise.
  Layout& set_convention(Channel key, const std::string& convention);
  // Whether the files carry our camera header (view, projection, jitter).
  Layout& set_camera_in_header(bool v) {
    camera_in_header_ = v;
    return *this;
  }
  bool camera_in_header() const { return camera_in_header_; }

  const std::string& name() const { return name_; }
  // The mapping of `key`, or nullptr when this layout cannot read it.
  const ChannelSource* find(Channel key) const;
  // Mappings in channel-table order.
  const std::vector<ChannelSource>& sources() const { return sources_; }

 private:
  void put(ChannelSource src);  // replaces the mapping of src.key, in table order

  std::string name_;
  std::vector<ChannelSource> sources_;
  bool camera_in_header_ = false;
  bool alpha_given_ = false;  // alpha mapped or unmapped by name: no longer follows color
};

// The coverage alpha beside the color's red channel `color_red`: its last name component
// replaced by A ("A" beside "R", "ViewLayer.Combined.A" beside "ViewLayer.Combined.R",
// "rgba.A" beside "rgba.R"), or "" where that would be the red's own name.
std::string alpha_channel_beside(const std::string& color_red);

// Our own files: every table row under its EXR names, no conversion.
const Layout& afterimage_layout();

// Blender (Cycles) OpenEXR MultiLayer files of view layer `view_layer`, as measured in
// tests/data/blender/README.md: color <- Combined.RGB, alpha <- Combined.A, depth <- Depth.Z
// (planar, sky 1e10), normal <- Normal.XYZ, albedo <- DiffCol.RGB, id <- IndexOB.X, motion <-
// Vector.XY and motion_next <- Vector.ZW (conventions "blender", "blender-next"), emission <-
// Emit.RGB, diffuse <- DiffDir + DiffInd, specular <- GlossDir + GlossInd.
Layout blender_layout(const std::string& view_layer = "ViewLayer");

}  // namespace afterimage
