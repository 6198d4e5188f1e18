#include "io/layouts.h"

#include "io/io.h"

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"

namespace afterimage::io {

namespace fs = std::filesystem;

namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// "A" or "A+B" into a plane source.
PlaneSource plane_of(const std::string& spec) {
  PlaneSource ps;
  const size_t plus = spec.find('+');
  ps.file_name = spec.substr(0, plus);
  if (plus != std::string::npos) ps.plus_name = spec.substr(plus + 1);
  return ps;
}

const ChannelInfo& channel_named(const std::string& key, const std::string& what) {
  const ChannelInfo* r = find_channel(key);
  if (!r) throw SettingsError(fmt::format("{}: unknown channel key '{}'", what, key));
  return *r;
}

void map_planes(Layout& l, const ChannelInfo& r, const std::vector<std::string>& specs,
                const std::vector<double>& scale, const std::vector<double>& offset) {
  std::vector<std::string> names;
  std::vector<PlaneSource> conv;
  for (size_t i = 0; i < specs.size(); ++i) {
    PlaneSource ps = plane_of(specs[i]);
    names.push_back(ps.file_name);
    if (i < scale.size()) ps.scale = scale[i];
    if (i < offset.size()) ps.offset = offset[i];
    conv.push_back(ps);
  }
  l.map(r.key, names, conv);
}

}  // namespace

std::vector<std::string> channel_names(const std::string& path) {
  return file_channel_names(path);  // through io.cpp's checked open (regular file, header)
}

Layout detect_layout(const std::vector<std::string>& names, std::string* why) {
  auto has = [&](const char* n) { return std::find(names.begin(), names.end(), n) != names.end(); };
  if (has("R") && has("G") && has("B")) {
    if (why) *why = "R G B";
    return afterimage_layout();
  }
  for (const std::string& n : names)
    if (ends_with(n, ".Combined.R")) {
      if (why) *why = n;
      return blender_layout(n.substr(0, n.size() - std::string(".Combined.R").size()));
    }
  const std::vector<std::string> some(
      names.begin(), names.begin() + std::ptrdiff_t(std::min<size_t>(names.size(), 6)));
  throw InputError(fmt::format(
      "cannot recognise the layout from the channels ({}{}); name the color's with --map "
      "color=R,G,B (a grey Y: color=Y,Y,Y), or give --layout blender[:LAYER] or a JSON file",
      some.empty() ? "none" : fmt::format("{}", fmt::join(some, " ")),
      names.size() > 6 ? " ..." : ""));
}

Layout layout_from_json_text(const std::string& text, const std::string& what) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw SettingsError(fmt::format("{}: not JSON: {}", what, e.what()));
  }
  try {
    Layout l(j.value("name", fs::path(what).stem().string()));
    l.set_camera_in_header(j.value("camera_in_header", false));
    for (const auto& [key, v] : j.at("channels").items()) {
      const ChannelInfo& r = channel_named(key, what);
      if (v.is_array()) {
        map_planes(l, r, v.get<std::vector<std::string>>(), {}, {});
        continue;
      }
      map_planes(l, r, v.at("names").get<std::vector<std::string>>(),
                 v.value("scale", std::vector<double>{}), v.value("offset", std::vector<double>{}));
      if (v.contains("convention")) l.set_convention(r.key, v.at("convention").get<std::string>());
    }
    return l;
  } catch (const nlohmann::json::exception& e) {
    throw SettingsError(fmt::format("{}: bad layout: {}", what, e.what()));
  }
}

Layout layout_from_json_file(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw InputError(fmt::format("{}: cannot read layout file", path));
  std::stringstream ss;
  ss << f.rdbuf();
  return layout_from_json_text(ss.str(), path);
}

void apply_map(Layout& layout, const std::string& spec) {
  const size_t eq = spec.find('=');
  if (eq == std::string::npos || eq == 0)
    throw SettingsError(fmt::format("--map '{}': expected key=CH1,CH2[:convention]", spec));
  const ChannelInfo& r = channel_named(spec.substr(0, eq), "--map " + spec);
  std::string rest = spec.substr(eq + 1), convention;
  if (const size_t colon = rest.find(':'); colon != std::string::npos) {
    convention = rest.substr(colon + 1);
    rest = rest.substr(0, colon);
  }
  std::vector<std::string> specs;
  std::stringstream ss(rest);
  for (std::string item; std::getline(ss, item, ',');) specs.push_back(item);
  map_planes(layout, r, specs, {}, {});
  if (!convention.empty()) layout.set_convention(r.key, convention);
}

Layout resolve_layout(const std::string& spec, const std::vector<std::string>& maps,
                      const std::string& first_file, std::string* note) {
  if (note) note->clear();
  Layout l("auto");
  if (spec.empty() || spec == "auto") {
    std::string why;
    try {
      l = detect_layout(channel_names(first_file), &why);
      // Our own files are the quiet default; any other recognised layout is said once.
      if (note && !l.camera_in_header())
        *note = fmt::format("layout {} (auto: {} has {})", l.name(), first_file, why);
    } catch (const InputError& e) {
      // Channels of no layout we know, the color named by --map: our names for the rest.
      const bool maps_color = std::any_of(
          maps.begin(), maps.end(), [](const std::string& m) { return m.rfind("color=", 0) == 0; });
      if (!maps_color) throw InputError(fmt::format("{}: {}", first_file, e.what()));
      l = afterimage_layout();
      l.set_camera_in_header(false);  // another tool's files: frame numbers, sidecar, no camera
      if (note)
        *note = fmt::format(
            "layout afterimage with --map (auto: {} has no R G B or "
            "<layer>.Combined.R)",
            first_file);
    }
  } else if (spec == "afterimage") {
    l = afterimage_layout();
  } else if (spec == "blender") {
    // The first view layer of the file.
    std::string why;
    for (const std::string& n : channel_names(first_file))
      if (ends_with(n, ".Combined.R")) {
        l = blender_layout(n.substr(0, n.size() - std::string(".Combined.R").size()));
        why = n;
        break;
      }
    if (why.empty()) throw InputError(fmt::format("{}: no <layer>.Combined.R channel", first_file));
  } else if (spec.rfind("blender:", 0) == 0) {
    l = blender_layout(spec.substr(8));
  } else if (ends_with(spec, ".json")) {
    l = layout_from_json_file(spec);
  } else {
    throw SettingsError(fmt::format(
        "--layout '{}': expected auto, afterimage, blender[:LAYER] or a .json file", spec));
  }
  for (const std::string& m : maps) apply_map(l, m);
  return l;
}

}  // namespace afterimage::io
