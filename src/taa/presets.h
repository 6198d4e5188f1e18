// Named TAA configurations, each reproducing a published technique with our building
// blocks (the source is cited at each preset in presets.cpp). Jitter sequences belong to
// the renderer (camera/), not to these settings.
#pragma once

#include <string>
#include <vector>

#include "taa/settings.h"

namespace afterimage::taa {

// Plain exponential accumulation, no rectification or rejection: ghosts persist. For tests.
TaaSettings preset_none();
// Uncharted 4 (Xu, SIGGRAPH 2016; seed 000): alpha 0.05, RGB min/max clamp, bilinear history,
// stencil-style object id rejection.
TaaSettings preset_uncharted4();
// UE4 (Karis, SIGGRAPH 2014; seeds 002/003): YCoCg, clip toward the filtered color, luma
// weighting, Catmull-Rom history, closest-depth cross dilation, alpha 0.04 rising with velocity.
TaaSettings preset_ue4();
// INSIDE (Pedersen / Playdead, GDC 2016): rounded 3x3 min/max, clip toward the box center,
// luma-difference feedback 0.88-0.97 (render with Halton 16 jitter).
TaaSettings preset_inside();
// Unity HDRP: variance box gamma 1.5, Blackman-Harris current filter, adaptive blend.
TaaSettings preset_hdrp();
// Salvi 2016 variance clipping: variance box intersected with min/max, gamma 1.0.
TaaSettings preset_variance();
// Our default: a combination of the above, tuned by measurement on the built-in scenes
// (the runs and numbers are in presets.cpp).
TaaSettings preset_afterimage();

// One named preset: the registry entry CLI help, validation, the demo and the tests read, so
// a preset name is spelled only there (DESIGN.md §2).
struct PresetInfo {
  const char* name;      // as accepted by --preset / make_preset
  const char* citation;  // the published technique it reproduces (one line)
  TaaSettings (*make)();
};

// Every preset, in a stable order: afterimage (the default) first.
const std::vector<PresetInfo>& taa_presets();

// The names of taa_presets(), in order.
std::vector<std::string> preset_names();
// Throws SettingsError for unknown names (the message lists the valid ones).
TaaSettings make_preset(const std::string& name);

}  // namespace afterimage::taa
