// The camera's part of a pixel's motion, for motion blur's camera/object split
// (camera_max_radius, object_max_radius, camera_rotation=false; motion_blur.h). One statement
// for the plain pass (motion_blur_reference.cpp) and the fast one (motion_blur_fast.cpp).
#pragma once

#include "core/math.h"
#include "frame/frame.h"
#include "post/motion_blur.h"
#include "reproject/forward.h"

namespace afterimage::post {

// The camera displacement of a pixel (p_prev - p_curr) and the part of it the blur uses.
struct CameraMotion {
  Vec2d full{0, 0};  // through depth, from this frame's camera to the previous one
  Vec2d blur{0, 0};  // `full`, or with camera_rotation=false its translation-only twin
};

class CameraMotionSplit {
 public:
  // No previous camera of this frame's size: nothing is known about the camera's motion, so
  // all of the motion is object motion (camera part zero).
  CameraMotionSplit(const Frame& f, const MotionBlurSettings& s, const FrameHeader* previous);
  // Pixel (x, y) at depth `depth`; zero where the camera is unknown or the reprojection fails.
  // Motion vectors are for unjittered positions: the camera part is taken at the pixel center.
  CameraMotion at(int x, int y, float depth) const;

 private:
  bool known_ = false, rotation_ = true;
  reproject::CameraTransfer full_, translation_;
};

}  // namespace afterimage::post
