// Named conventions of other tools' motion vectors and depth, each converted to ours
// (DESIGN.md §3: motion = p_prev - p_curr in pixels, y down, unjittered; depth = linear view
// depth -z_view). One converter per quantity, driven by data: a convention is its units,
// direction, y axis and an affine encoding, not a code path.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "frame/frame.h"

namespace afterimage {

enum class MotionUnits { Pixels, Uv, Ndc };  // Uv spans [0,1] per axis, Ndc [-1,1]
// ToOther: other - current (ours for the previous frame); FromOther: current - other.
enum class MotionDirection { ToOther, FromOther };

struct MotionConvention {
  std::string name;
  MotionUnits units = MotionUnits::Pixels;
  MotionDirection direction = MotionDirection::ToOther;
  bool y_up = false;
  // Encoding in the file: file = scale * value + offset, value in `units` (per axis).
  Vec2d scale{1.0, 1.0}, offset{0.0, 0.0};
  std::string source;  // where the definition comes from
};

// Registry: afterimage, blender, blender-next, unity, unreal, fsr2.
const std::vector<MotionConvention>& motion_conventions();
// "name" or "name:sx:sy" (sx, sy multiply the registered scale, e.g. FSR2's
// motionVectorScale given as its inverse). Throws SettingsError on unknown names.
MotionConvention parse_motion_convention(std::string_view spec);

// A file value in convention `c` to ours (to the same other frame), for a width x height
// image; and back (for tests and writers).
Vec2d motion_to_afterimage(Vec2d file, const MotionConvention& c, int width, int height);
Vec2d motion_from_afterimage(Vec2d ours, const MotionConvention& c, int width, int height);
// The whole 2-plane image in place.
void convert_motion(ImageF& motion, const MotionConvention& c);

enum class DepthKind {
  Linear,           // -z_view (ours)
  RayDistance,      // |p_view|: needs the projection (and the jitter of the sample)
  Hardware,         // window depth in [0, 1], near -> 0, far -> 1 (D3D / GL glDepthRange(0, 1))
  HardwareReversed  // near -> 1, far -> 0 (reversed-Z); far may be infinite
};
struct DepthConvention {
  std::string name;
  DepthKind kind = DepthKind::Linear;
  // Hardware depth: near/far planes; 0 = take them from the frame's projection.
  double near_plane = 0.0, far_plane = 0.0;
};
// "linear", "ray", "hardware[:near:far]", "hardware-reversed[:near:far]" (far may be "inf").
DepthConvention parse_depth_convention(std::string_view spec);

// Hardware depth of view depth d for planes n, f (far = +inf allowed for reversed), and back.
double hardware_depth(double d, double n, double f, bool reversed);
double depth_from_hardware(double z01, double n, double f, bool reversed);
// Near and far planes of a perspective projection built like Camera::projection (GL style).
void planes_of_projection(const Mat4& p, double& n, double& f);

// Converts `f.depth` in place to linear view depth. RayDistance and Hardware without planes
// need f.projection (and use f.jitter for the sample position); throws InputError naming
// `what` when the frame has no camera. Values at the clear depth or beyond far become
// kBackgroundDepth.
void convert_depth(Frame& f, const DepthConvention& c, bool camera_known, const std::string& what);

// Background pixels (depth == kBackgroundDepth) get the motion of a direction at infinity
// under the camera change `cur` -> `other` (DESIGN.md §3: rotation only). Writes `motion`
// (other = previous frame) or `motion_next` (other = next). Perspective cameras only;
// returns false (and leaves the plane) for orthographic ones.
bool fill_background_motion(Frame& f, const FrameHeader& other, ImageF& plane);

}  // namespace afterimage
