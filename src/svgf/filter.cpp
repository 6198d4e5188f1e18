// filter.h's stages: the shapes checked, then the plain specification (reference.h) with
// --simd off, else the fast schedule (filter_fast.h). The two are bit-identical
// (svgf_filter_test), so the choice changes no output.
#include "svgf/filter.h"

#include "core/error.h"
#include "svgf/filter_fast.h"
#include "svgf/reference.h"

namespace afterimage::svgf {

namespace {
void check_guide(const Guide& g, int w, int h) {
  AI_CHECK(g.depth && g.normal && g.gradient);
  AI_CHECK(g.depth->width() == w && g.depth->height() == h && g.depth->channels() == 1);
  AI_CHECK(g.normal->width() == w && g.normal->height() == h && g.normal->channels() == 3);
  AI_CHECK(g.gradient->width() == w && g.gradient->height() == h && g.gradient->channels() == 2);
}
}  // namespace

void depth_gradient(const ImageF& depth, ImageF& out, const Exec& exec) {
  AI_CHECK(depth.channels() == 1);
  ensure_shape(out, depth.width(), depth.height(), 2);
  if (depth.width() == 0) return;
  if (!exec.simd) return reference::depth_gradient(depth, out, exec);
  fast::depth_gradient(depth, out, exec);
}

void estimate_variance(const Guide& g, const ImageF& moments, const ImageF& length,
                       const SvgfSettings& s, ImageF& variance, const Exec& exec) {
  const int w = moments.width(), h = moments.height(), S = moments.channels() / 2;
  AI_CHECK(S >= 1 && S <= kMaxSignals && moments.channels() == 2 * S);
  AI_CHECK(length.width() == w && length.height() == h && length.channels() == 1);
  check_guide(g, w, h);
  AI_CHECK(s.spatial_radius >= 0 && s.spatial_radius <= fast::kMaxSpatialRadius);
  ensure_shape(variance, w, h, S);
  if (!exec.simd) return reference::estimate_variance(g, moments, length, s, variance, exec);
  fast::estimate_variance(g, moments, length, s, variance, exec);
}

void atrous_iteration(const Guide& g, const ImageF& color, const ImageF& variance, int step,
                      const SvgfSettings& s, ImageF& out_color, ImageF& out_variance,
                      const Exec& exec) {
  const int w = color.width(), h = color.height(), S = variance.channels();
  AI_CHECK(S >= 1 && S <= kMaxSignals && color.channels() == 3 * S);
  AI_CHECK(variance.width() == w && variance.height() == h);
  AI_CHECK(&out_color != &color && &out_variance != &variance && step >= 1);
  check_guide(g, w, h);
  ensure_shape(out_color, w, h, 3 * S);
  ensure_shape(out_variance, w, h, S);
  if (!exec.simd)
    return reference::atrous_iteration(g, color, variance, step, s, out_color, out_variance, exec);
  fast::atrous_iteration(g, color, variance, step, s, out_color, out_variance, exec);
}

void atrous_iteration_remodulated(const Guide& g, const ImageF& color, const ImageF& variance,
                                  int step, const SvgfSettings& s, const RemodulationInputs& r,
                                  ImageF& out, ImageF* filtered, const Exec& exec) {
  const int w = color.width(), h = color.height(), S = variance.channels();
  AI_CHECK(S >= 1 && S <= kMaxSignals && color.channels() == 3 * S);
  AI_CHECK(variance.width() == w && variance.height() == h);
  AI_CHECK(&out != &color && filtered != &color && filtered != &out && step >= 1);
  AI_CHECK(r.color && r.color->width() == w && r.color->height() == h && r.color->channels() == 3);
  for (const ImageF* p : {r.emission, r.albedo})
    AI_CHECK(!p || (p->width() == w && p->height() == h && p->channels() == 3));
  for (int sg = 0; sg < S; ++sg) AI_CHECK(r.factor[sg] == Remodulation::One || r.albedo);
  check_guide(g, w, h);
  ensure_shape(out, w, h, 3);
  if (filtered) ensure_shape(*filtered, w, h, 3 * S);
  if (!exec.simd)
    return reference::atrous_iteration_remodulated(g, color, variance, step, s, r, out, filtered,
                                                   exec);
  fast::atrous_iteration_remodulated(g, color, variance, step, s, r, out, filtered, exec);
}

}  // namespace afterimage::svgf
