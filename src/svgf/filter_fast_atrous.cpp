#include "svgf/filter_fast.h"

namespace afterimage::svgf::fast {

void atrous_iteration(const Guide& g, const ImageF& color, const ImageF& variance, int step,
                      const SvgfSettings& s, ImageF& out_color, ImageF& out_variance,
                      const Exec& exec) {
  const int w = color.width(), h = color.height(), S = variance.channels();
  AtrousContext k = atrous_context(g, color, variance, step, s);
  for (int sg = 0; sg < S; ++sg) {
    for (int ch = 0; ch < 3; ++ch) k.out_color[3 * sg + ch] = out_color.plane(3 * sg + ch);
    k.out_var[sg] = out_variance.plane(sg);
  }
  dispatch(S, s, [&](auto signals, auto sigma_n) {
    dispatch_kernel(s, [&](auto radius) {
      constexpr int kR = decltype(radius)::value;
      // The taps reach kR steps; the 3x3 Gaussian 1 pixel.
      for_each_block(exec, w, h, kR * step, [&](auto d, int x, int y, auto inside) {
        atrous_block<decltype(signals)::value, decltype(sigma_n)::value, kR, inside.value, false>(
            d, k, x, y);
      });
    });
  });
}

}  // namespace afterimage::svgf::fast
