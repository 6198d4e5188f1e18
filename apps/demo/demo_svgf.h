// The demo's denoising section (issue 11): a path-traced scene (1 sample per pixel per frame)
// denoised by SVGF as the paper specifies (svgf:svgf-paper), by the project's preset
// (svgf:afterimage), by that preset followed by TAA (the pipeline `svgf,taa`), by TAA alone,
// by the spatial à-trous alone (no temporal accumulation), and by OpenCV's multi-frame
// non-local means (peers/opencv_nlm.h, the best h of a few), and A-SVGF (the scene rendered
// with gradient samples, svgf + TAA with temporal_gradient), beside the raw input — all scored
// against converged path-traced references of the same frames.
#pragma once

#include <string>
#include <vector>

#include "core/parallel.h"
#include "eval/evaluate.h"
#include "metrics/metrics.h"

namespace afterimage {

struct DenoiseDemo {
  std::vector<MethodEvaluation> rows;
  std::string description;
  // Where the scene's lights switch (room_light): the frame and the lag (metrics/temporal.h
  // lag_frames) of svgf + TAA and of A-SVGF + TAA; lag_step -1 otherwise.
  int lag_step = -1, lag_svgf = 0, lag_asvgf = 0;
};

// `frames` frames of `scene` (a path-traced built-in scene: room, room_light) at width x height,
// references at `reference_spp` samples per pixel. SettingsError for an unknown scene.
DenoiseDemo evaluate_denoise(const std::string& scene, int width, int height, int frames,
                             int reference_spp, const metrics::MetricsSettings& ms, const Exec& ex);

}  // namespace afterimage
