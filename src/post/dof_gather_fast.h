// The depth-of-field gather's fast schedule (dof_gather_fast.cpp): the gather that
// dof_reference states plainly, bit for bit the same.
#pragma once

#include "camera/camera.h"
#include "core/image.h"
#include "core/parallel.h"
#include "frame/frame.h"
#include "post/dof.h"

namespace afterimage::post {

// The gather (mode=gather, full or half resolution) of `color` over frame f's depths, with the
// lens `thin` that checked_dof_input returned.
ImageF dof_gather_fast(const Frame& f, const ImageF& color, const DofSettings& s,
                       const ThinLens& thin, const Exec& exec);

}  // namespace afterimage::post
