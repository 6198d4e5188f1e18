#include "frame/layout.h"

#include <algorithm>

#include <fmt/format.h>

#include "core/error.h"
#include "frame/conventions.h"

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
  for (const std::string& n : file_names)
    if (n.empty())  // a plane must come from somewhere (an empty name used to skip a plane)
      throw SettingsError(
          fmt::format("layout '{}': {} has an empty file channel name", name_, r.name));
  ChannelSource src{key, {}, {}};
  for (size_t p = 0; p < file_names.size(); ++p) {
    PlaneSource ps = conversions.empty() ? PlaneSource{} : conversions[p];
    ps.file_name = file_names[p];
    // Integer ids are labels: scaling them has no meaning and would not round-trip.
    if (r.type == PixelType::U32 && (!ps.identity() || !ps.plus_name.empty()))
      throw SettingsError(
          fmt::format("layout '{}': {} holds integers and cannot be converted", name_, r.name));
    src.planes.push_back(std::move(ps));
  }
  if (key == Channel::alpha) alpha_given_ = true;
  if (key == Channel::color && !alpha_given_) {
    const std::string a = alpha_channel_beside(src.planes[0].file_name);
    if (a.empty())
      std::erase_if(sources_, [](const ChannelSource& s) { return s.key == Channel::alpha; });
    else
      put({Channel::alpha, {PlaneSource{a}}, {}});
  }
  put(std::move(src));
  return *this;
}

void Layout::put(ChannelSource src) {
  const Channel key = src.key;
  std::erase_if(sources_, [&](const ChannelSource& s) { return s.key == key; });
  // Keep table order so reads (and their error messages) follow the table.
  auto at = std::find_if(sources_.begin(), sources_.end(),
                         [&](const ChannelSource& s) { return s.key > key; });
  sources_.insert(at, std::move(src));
}

Layout& Layout::unmap(Channel key) {
  if (key == Channel::alpha) alpha_given_ = true;
  std::erase_if(sources_, [&](const ChannelSource& s) { return s.key == key; });
  return *this;
}

std::string alpha_channel_beside(const std::string& color_red) {
  const size_t dot = color_red.rfind('.');
  const std::string name = color_red.substr(0, dot == std::string::npos ? 0 : dot + 1) + "A";
  return name == color_red ? "" : name;
}

Layout& Layout::set_convention(Channel key, const std::string& convention) {
  auto it = std::find_if(sources_.begin(), sources_.end(),
                         [&](const ChannelSource& s) { return s.key == key; });
  const char* what = channel_info(key).name;
  if (it == sources_.end())
    throw SettingsError(fmt::format("layout '{}': {} is not mapped", name_, what));
  if (key == Channel::motion || key == Channel::motion_next) {
    const MotionConvention c = parse_motion_convention(convention);
    if (c.units == MotionUnits::Pixels) {
      // Pixel conventions are affine per plane: fold them into the planes, so io::read_frame
      // alone reads them right. ours = sign * (file - offset) / scale.
      for (int a = 0; a < 2; ++a) {
        PlaneSource& ps = it->planes[size_t(a)];
        const double sign = (a == 1 && c.y_up ? -1.0 : 1.0) *
                            (c.direction == MotionDirection::FromOther ? -1.0 : 1.0);
        const double sc = a == 0 ? c.scale.x : c.scale.y, off = a == 0 ? c.offset.x : c.offset.y;
        ps.scale = sign / sc;
        ps.offset = -sign * off / sc;
      }
      it->convention.clear();
      return *this;
    }
  } else if (key == Channel::depth)
    parse_depth_convention(convention);
  else {
    throw SettingsError(fmt::format(
        "layout '{}': {} has no conventions (only motion, motion_next, depth)", name_, what));
  }
  it->convention = convention;
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
    l.set_camera_in_header(true);
    return l;
  }();
  return layout;
}

Layout blender_layout(const std::string& view_layer) {
  Layout l("blender:" + view_layer);
  auto names = [&](const char* pass, const char* comps) {
    std::vector<std::string> v;
    for (const char* c = comps; *c; ++c) v.push_back(fmt::format("{}.{}.{}", view_layer, pass, *c));
    return v;
  };
  auto sum = [&](const char* a, const char* b) {
    std::vector<PlaneSource> v;
    for (const std::string& n : names(b, "RGB")) v.push_back({"", 1.0, 0.0, n});
    return std::pair{names(a, "RGB"), v};
  };
  l.map(Channel::color, names("Combined", "RGB"));  // and alpha <- Combined.A
  l.map(Channel::depth, names("Depth", "Z"));       // planar view depth; sky is 1e10 already
  l.map(Channel::normal, names("Normal", "XYZ"));
  l.map(Channel::albedo, names("DiffCol", "RGB"));
  l.map(Channel::id, names("IndexOB", "X"));  // float pass_index; the reader rounds it
  l.map(Channel::motion, names("Vector", "XY")).set_convention(Channel::motion, "blender");
  l.map(Channel::motion_next, names("Vector", "ZW"))
      .set_convention(Channel::motion_next, "blender-next");
  l.map(Channel::emission, names("Emit", "RGB"));
  const auto [diff, diff_plus] = sum("DiffDir", "DiffInd");
  l.map(Channel::diffuse, diff, diff_plus);
  const auto [spec, spec_plus] = sum("GlossDir", "GlossInd");
  l.map(Channel::specular, spec, spec_plus);
  return l;
}

}  // namespace afterimage
