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
  bool identity() const { return scale == 1.0 && offset == 0.0; }
};

struct ChannelSource {
  Channel key;
  std::vector<PlaneSource> planes;  // one per plane of the channel, in plane order
};

class Layout {
 public:
  explicit Layout(std::string name) : name_(std::move(name)) {}

  // Reads `key` from `file_names` (one per plane) with optional per-plane conversions
  // (empty = identity). Replaces an earlier mapping of `key`. Throws SettingsError if the
  // counts do not match the channel table or a uint channel is given a conversion.
  Layout& map(Channel key, const std::vector<std::string>& file_names,
              const std::vector<PlaneSource>& conversions = {});
  // Drops `key`: it is never read with this layout.
  Layout& unmap(Channel key);

  const std::string& name() const { return name_; }
  // The mapping of `key`, or nullptr when this layout cannot read it.
  const ChannelSource* find(Channel key) const;
  // Mappings in channel-table order.
  const std::vector<ChannelSource>& sources() const { return sources_; }

 private:
  std::string name_;
  std::vector<ChannelSource> sources_;
};

// Our own files: every table row under its EXR names, no conversion.
const Layout& afterimage_layout();

}  // namespace afterimage
