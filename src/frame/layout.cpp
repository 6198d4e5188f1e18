#include "frame/layout.h"

#include <algorithm>

#include <fmt/format.h>

#include "core/error.h"

namespace afterimage {

Layout& Layout::map(Channel key, const std::vector<std::string>& file_names,
                    const std::vector<PlaneSource>& conversions) {
  const ChannelInfo& r = channel_info(key);
  if (int(file_names.size()) != r.planes)
    throw SettingsError(fmt::format("layout '{}': {} has {} plane(s), got {} file channel name(s)",
                                    name_, r.name, r.planes, file_names.size()));
  if (!conversions.empty() && conversions.size() != file_names.size())
    throw SettingsError(fmt::format("layout '{}': {} has {} plane(s), got {} conversion(s)", name_,
                                    r.name, r.planes, conversions.size()));
  ChannelSource src{key, {}};
  for (size_t p = 0; p < file_names.size(); ++p) {
    PlaneSource ps = conversions.empty() ? PlaneSource{} : conversions[p];
    ps.file_name = file_names[p];
    // Integer ids are labels: scaling them has no meaning and would not round-trip.
    if (r.type == PixelType::U32 && !ps.identity())
      throw SettingsError(
          fmt::format("layout '{}': {} holds integers and cannot be converted", name_, r.name));
    src.planes.push_back(std::move(ps));
  }
  unmap(key);
  // Keep table order so reads (and their error messages) follow the table.
  auto at = std::find_if(sources_.begin(), sources_.end(),
                         [&](const ChannelSource& s) { return s.key > key; });
  sources_.insert(at, std::move(src));
  return *this;
}

Layout& Layout::unmap(Channel key) {
  std::erase_if(sources_, [&](const ChannelSource& s) { return s.key == key; });
  return *this;
}

const ChannelSource* Layout::find(Channel key) const {
  for (const ChannelSource& s : sources_)
    if (s.key == key) return &s;
  return nullptr;
}

const Layout& afterimage_layout() {
  static const Layout layout = [] {
    Layout l("afterimage");
    for (const ChannelInfo& r : kChannelTable)
      l.map(r.key, std::vector<std::string>(r.exr.begin(), r.exr.begin() + r.planes));
    return l;
  }();
  return layout;
}

}  // namespace afterimage
