#include <memory>

#include "svgf/filter_fast.h"

namespace afterimage::svgf::fast {

void atrous_iteration_remodulated(const Guide& g, const ImageF& color, const ImageF& variance,
                                  int step, const SvgfSettings& s, const RemodulationInputs& r,
                                  ImageF& out, ImageF* filtered, const Exec& exec) {
  const int w = color.width(), h = color.height(), S = variance.channels();
  AtrousContext k = atrous_context(g, color, variance, step, s);
  for (int sg = 0; sg < S; ++sg) k.factor[sg] = r.factor[sg];
  k.albedo_epsilon = r.albedo_epsilon;
  for (int ch = 0; ch < 3; ++ch) {
    k.emission[ch] = r.emission ? r.emission->plane(ch) : nullptr;
    k.albedo[ch] = r.albedo ? r.albedo->plane(ch) : nullptr;
    k.in_color[ch] = r.color->plane(ch);
    k.out[ch] = out.plane(ch);
  }
  // Per row: the à-trous blocks (subnormals flushed) write the filtered color to `filtered` or
  // to a row buffer (in L1 / L2: the full-image planes of the last iteration are neither written
  // nor read back), then the row is remodulated with the caller's floating-point mode.
  dispatch(S, s, [&](auto signals, auto sigma_n) {
    dispatch_kernel(s, [&](auto radius) {
      constexpr int kS = decltype(signals)::value, kR = decltype(radius)::value;
      parallel_rows(exec, h, [&](int y) {
        std::unique_ptr<float[]> buffer;
        float* rp[3 * kMaxSignals] = {};
        if (!filtered) buffer.reset(new float[size_t(3 * kS) * size_t(w)]);
        for (int ch = 0; ch < 3 * kS; ++ch)
          rp[ch] = filtered ? filtered->row(ch, y) : buffer.get() + size_t(ch) * size_t(w);
        for_each_block_of_row(exec, w, h, kR * step, y, [&](auto d, int x, int yy, auto inside) {
          atrous_block<kS, decltype(sigma_n)::value, kR, inside.value, true>(d, k, x, yy, rp);
        });
        for_each_lane_block(exec, w, [&](auto d, int x) { remodulate_block<kS>(d, k, rp, x, y); });
      });
    });
  });
}

}  // namespace afterimage::svgf::fast
