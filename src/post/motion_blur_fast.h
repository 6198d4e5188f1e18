// Motion blur's fast schedule (motion_blur_fast.cpp): the pass that motion_blur_reference states
// plainly, bit for bit the same.
#pragma once

#include "core/image.h"
#include "core/parallel.h"
#include "frame/frame.h"
#include "post/motion_blur.h"

namespace afterimage::post {

// motion_blur (motion_blur.h) with the previous frame's camera `previous` (null: none).
ImageF motion_blur_fast(const Frame& f, const ImageF& color, const MotionBlurSettings& s,
                        const FrameHeader* previous, const Exec& exec);

}  // namespace afterimage::post
