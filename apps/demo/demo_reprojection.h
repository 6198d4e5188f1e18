// The demo's reprojection sections (issue 13; seed 004 "Reprojection Techniques"): the
// reverse reprojection shading cache (cost against error, scored against shading every pixel
// every frame) and forward reprojection (frames synthesised from earlier rendered frames,
// scored against the frames the renderer really drew).
#pragma once

#include <string>
#include <vector>

#include "core/parallel.h"
#include "eval/evaluate.h"
#include "metrics/metrics.h"

namespace afterimage {

struct ShadingCacheDemo {
  std::vector<MethodEvaluation> rows;  // scored against full shading
  double full_ms_per_frame = 0;        // shading every pixel every frame (the truth's cost)
  std::string description;             // for the report section
};

// `scene` rendered at width x height for `frames` frames with soft shadows (16 light samples)
// four ways beside full shading: the cache in reuse mode (defaults), reuse without change
// detection, the averaging cache at 1 light sample per frame, and 1 light sample without a
// cache. Each row's label states the fraction of pixels shaded and of shadow rays traced; its
// ms/frame is the whole G-buffer frame (primary rays, cache, shading).
ShadingCacheDemo evaluate_shading_cache(const std::string& scene, int width, int height, int frames,
                                        const metrics::MetricsSettings& ms, const Exec& ex);

struct ExtrapolationDemo {
  std::vector<MethodEvaluation> rows;  // scored on the synthesised frames only
  std::string description;
};

// `scene` rendered without jitter (with motion_next) for `frames` frames; every odd frame
// synthesised from its neighbours as `afterimage extrapolate --skip 1` does — extrapolated
// with each hole fill, interpolated with the default fill — beside repeating the last
// rendered frame (what a missed deadline shows without reprojection), each scored against
// the frames the renderer really drew. Row labels state the mean hole fraction; ms/frame is
// the synthesis of one frame.
ExtrapolationDemo evaluate_extrapolation(const std::string& scene, int width, int height,
                                         int frames, const metrics::MetricsSettings& ms,
                                         const Exec& ex);

}  // namespace afterimage
