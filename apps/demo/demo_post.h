// The demo's camera-effect sections (issue 12): a post pass (dof, motion_blur) applied to the
// ray tracer's effect-free reference, scored against the reference rendered with the physical
// effect (thin lens, shutter), beside the effect-free image itself.
#pragma once

#include <string>
#include <vector>

#include "core/parallel.h"
#include "eval/evaluate.h"
#include "metrics/metrics.h"

namespace afterimage {

struct PostEffectDemo {
  std::vector<MethodEvaluation> rows;
  std::string description;
};

// `section` = "STAGE:SCENE" (e.g. "dof:focus", "motion_blur:motion"): `frames` frames of the
// scene at width x height with `spp` samples per pixel, the truth rendered with the effect
// (dof: the scene's lens; motion_blur: a 360-degree shutter) and the stage run over the frames
// in order with its default settings (motion_blur: the same shutter; dof: a second row with
// mode=diffusion). SettingsError for an unknown stage or scene.
PostEffectDemo evaluate_post_effect(const std::string& section, int width, int height, int frames,
                                    int spp, const metrics::MetricsSettings& ms, const Exec& ex);

}  // namespace afterimage
