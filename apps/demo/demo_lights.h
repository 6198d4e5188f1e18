// The demo's light-effects section (issue 12): bloom, lens flare and glare on a built-in scene
// with small bright emitters, applied to the ray tracer's reference frames.
//
// Bloom has a ground truth for its approximation: the same scattering done exactly, by FFT
// convolution with the chain's own point-spread function (post::bloom_reference_fft with
// post::bloom_psf), so the mip chain is scored against it (beside the unbloomed image, the
// error of doing no bloom at all). Lens flare and glare have no physical reference here (our
// ray tracer has no lens elements and no eye), so they are shown as images with their cost
// per frame only, and the report says so.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "core/parallel.h"
#include "eval/report.h"
#include "metrics/metrics.h"

namespace afterimage {

struct LightEffectsDemo {
  SceneSection section;  // rows (scored: no bloom, bloom chain; shown: flare, glare), figures
  nlohmann::json json;   // eval_to_json of every row (flare and glare: metrics null)
  std::string table;     // the rows as printed on the terminal
};

// `frames` frames of `scene` at width x height, references at `spp` samples per pixel; bloom
// and flare with their default settings (glare: glare_intensity 0.05, the frame's vertical
// field of view). SettingsError for an unknown scene.
LightEffectsDemo evaluate_light_effects(const std::string& scene, int width, int height, int frames,
                                        int spp, const metrics::MetricsSettings& ms,
                                        const Exec& ex);

}  // namespace afterimage
