// Built-in animated scenes, each built around one TAA failure mode (DESIGN.md §4):
//  * thin:   slow camera pan over sub-pixel poles and wires, a ground with a high-frequency
//            checker (shading aliasing) and a glossy sphere under a small bright light
//            (specular flicker);
//  * motion: a box crossing the foreground at ~10 px/frame in front of a textured wall
//            (disocclusion / ghosting), spinning objects, a camera dolly;
//  * orbit:  the camera orbits a group of objects under a gradient sky (every pixel moves;
//            the sky moves by rotation only).
// and the failure modes TAA users hit, each alone (not in the demo's default list):
//  * light:   a moving light and a blinking emissive panel over still geometry and camera
//             (zero motion: only rectification can react);
//  * sparkle: bump-mapped glossy surfaces under a small bright light, a firefly emitter;
//  * moire:   fine textures at grazing angles, far above Nyquist toward the horizon;
//  * blades:  thin swaying grass blades (sub-pixel geometry with object motion);
//  * cut:     hard camera cuts (Frame::camera_cut) every 16 frames from frame 8;
//  * penumbra: wide soft shadows (the shading cache's scene);
//  * focus:   a shallow-focus lens (f/1.4 at 3 m) with near and far objects (depth of field);
//  * bokeh:   a five-blade lens wide open with bright highlights in front of and behind the
//             focus (the polygon bokeh).
// and the path tracer's (render --path-trace; SVGF's noisy input):
//  * room:       a closed room lit by a ceiling quad light, a sliding box, a camera dolly;
//  * room_light: the room with a lamp that switches on at frame 6 and off at frame 22.
// Frame k is at time k / 30 s. The `static` variant freezes everything (camera included)
// at t = 0, so consecutive frames differ only by jitter.
#pragma once

#include <string>
#include <vector>

#include "render/scene.h"

namespace afterimage::render {

// Which set a scene belongs to for the default TAA preset (issue 10): the scenes it was tuned
// on, the ones held out to validate it, or neither (scenes of other techniques).
enum class TaaSplit { None, Tuning, Validation };

// One built-in scene: the registry entry the CLI, the demo and the tests read, so a scene
// name is spelled only there (DESIGN.md §2).
struct SceneInfo {
  const char* name;         // as accepted by `render --scene`
  const char* description;  // one paragraph for reports: what the scene stresses
  Scene (*make)(bool is_static);
  bool in_default_demo;  // run by `demo` without --scenes (keeps the demo a few minutes)
  TaaSplit taa_split;
};

// Every built-in scene, in a stable order (thin, motion, orbit, light, sparkle, moire,
// blades, cut, penumbra, focus, bokeh, room, room_light).
const std::vector<SceneInfo>& builtin_scenes();

// The names of builtin_scenes(), in order.
std::vector<std::string> builtin_scene_names();

// The names of the scenes with in_default_demo, in order (thin, motion, orbit, light, sparkle,
// moire, blades, cut, penumbra, focus).
std::vector<std::string> default_demo_scene_names();

// The scene's TAA split (TaaSplit::None for names not in the registry).
TaaSplit taa_split_of(const std::string& name);

// Throws SettingsError for unknown names (listing the valid ones).
Scene make_builtin_scene(const std::string& name, bool is_static = false);

}  // namespace afterimage::render
