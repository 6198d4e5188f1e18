// The G-buffer frame handed to every temporal technique (DESIGN.md §1, §3).
#pragma once

#include <cstdint>
#include <string>

#include "camera/camera.h"
#include "core/image.h"
#include "core/math.h"

namespace afterimage {

// Linear view depth of background (sky) pixels; anything larger, infinite or NaN maps here.
constexpr float kBackgroundDepth = 1e10f;

struct Frame {
  int width = 0, height = 0;
  ImageF color;   // 3 planes, linear Rec.709 HDR
  ImageF depth;   // 1 plane, d = -z_view > 0; kBackgroundDepth for sky
  ImageF normal;  // 3 planes, world space unit; (0,0,0) for background
  ImageF albedo;  // 3 planes, linear RGB
  ImageF motion;  // 2 planes, p_prev - p_curr in pixels (y down), unjittered positions
  ImageU32 id;    // 1 plane, 0 = background

  // Camera of this frame. `projection` is always the unjittered one.
  Mat4 view = Mat4::identity();
  Mat4 projection = Mat4::identity();
  Vec2d jitter{0.0, 0.0};  // pixels in [-0.5, 0.5]^2, y down
  int index = 0;           // frame number
  double time = 0.0;       // seconds
  ThinLens lens;
  bool camera_cut = false;  // history must not be used across this frame

  // Allocates every buffer for width x height (zeros; depth = background).
  static Frame allocate(int width, int height);

  bool has_color() const { return color.channels() == 3; }
  bool has_depth() const { return depth.channels() == 1; }
  bool has_normal() const { return normal.channels() == 3; }
  bool has_albedo() const { return albedo.channels() == 3; }
  bool has_motion() const { return motion.channels() == 2; }
  bool has_id() const { return id.channels() == 1; }

  Vec3f color_at(int x, int y) const {
    return {color.at(x, y, 0), color.at(x, y, 1), color.at(x, y, 2)};
  }
  Vec2f motion_at(int x, int y) const { return {motion.at(x, y, 0), motion.at(x, y, 1)}; }
};

// Checks shapes and values (finite color, positive depth, motion finite); throws InputError
// naming `what` (file or frame) and the first problem found.
void validate_frame(const Frame& f, const std::string& what);

}  // namespace afterimage
