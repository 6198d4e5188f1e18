// The lamp-switch lag of denoising pipelines (issue 11's A-SVGF test), shared by the tests
// that measure it: path-traced room_light (the lamp switches on at frame 6) rendered with
// A-SVGF gradient samples (render --gradients), references of `ref_spp` samples, and per
// pipeline the frames until the display error is within 1.2x its steady state
// (metrics/temporal.h lag_frames).
#pragma once

#include <vector>

#include "core/image.h"
#include "frame/frame.h"
#include "metrics/temporal.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "run/methods.h"
#include "run/post_pipeline.h"

namespace afterimage::test {

inline constexpr int kLampSwitchFrame = 6;  // room_light's lamp switches on here

struct LampSwitchSequence {
  std::vector<Frame> noisy;  // 1 spp, with the gradient channel
  std::vector<ImageF> refs;  // path-traced references
};

inline LampSwitchSequence render_lamp_switch(int w, int h, int frames, int ref_spp) {
  render::RenderSettings rs;
  rs.width = w;
  rs.height = h;
  rs.path_trace = render::PathTraceSettings{};
  rs.gradients = true;
  const render::Scene scene = render::make_builtin_scene("room_light");  // r keeps a reference
  render::SceneRenderer r(scene, rs, {});
  LampSwitchSequence s;
  for (int t = 0; t < frames; ++t) {
    s.noisy.push_back(r.gbuffer(t));
    s.refs.push_back(r.reference(t, ref_spp).color);
  }
  return s;
}

// The lag of a pipeline ("svgf:afterimage,taa") on the sequence; `errors` (if given) receives
// the per-frame display error.
inline int lamp_switch_lag(const LampSwitchSequence& s, const char* pipeline,
                           std::vector<double>* errors = nullptr) {
  auto m = make_pipeline_method(parse_pipeline(pipeline, {}), {});
  std::vector<double> e;
  for (size_t t = 0; t < s.noisy.size(); ++t)
    e.push_back(metrics::display_error_frame(m->process(s.noisy[t]).color, s.refs[t]));
  if (errors) *errors = e;
  return metrics::lag_frames(e, kLampSwitchFrame);
}

}  // namespace afterimage::test
