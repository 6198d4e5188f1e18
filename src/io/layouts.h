// Choosing a layout for a sequence (DESIGN.md §3 "Files"): by name, from a JSON file, or
// recognised from the channel names; inline --map overrides. (Frame files of other tools'
// naming, name_0001.exr, are listed by io::scan_sequence.)
#pragma once

#include <string>
#include <vector>

#include "frame/layout.h"

namespace afterimage::io {

// Channel names of an image file, in file order. Throws InputError if unreadable.
std::vector<std::string> channel_names(const std::string& path);

// Recognises our layout (R, G, B present) or Blender's (a "<layer>.Combined.R" channel, the
// first such layer). `why` receives the deciding channel. Throws InputError otherwise.
Layout detect_layout(const std::vector<std::string>& names, std::string* why = nullptr);

// A JSON layout file:
//   {"name": "mytool", "camera_in_header": false,
//    "channels": {"color": ["R", "G", "B"],
//                 "motion": {"names": ["vel.X", "vel.Y"], "convention": "unity"},
//                 "diffuse": {"names": ["DiffDir.R+DiffInd.R", ...], "scale": [..], "offset":
//                 [..]}}}
// Channel keys are the table's (frame/channels.inc); "A+B" sums two file channels.
Layout layout_from_json_text(const std::string& text, const std::string& what);
Layout layout_from_json_file(const std::string& path);

// Applies one --map override "key=CH1,CH2[:convention]" (CH may be "A+B").
void apply_map(Layout& layout, const std::string& spec);

// `spec`: "auto" (recognised from `first_file`), "afterimage", "blender[:<view layer>]"
// ("blender" alone takes the file's first layer) or a .json path; then `maps` applied in
// order. `note` receives a one-line account of an automatic choice of a foreign layout
// ("" for our own files and for explicit choices).
Layout resolve_layout(const std::string& spec, const std::vector<std::string>& maps,
                      const std::string& first_file, std::string* note = nullptr);

}  // namespace afterimage::io
