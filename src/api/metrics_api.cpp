// The C++ API's image metrics (include/afterimage/afterimage.hpp) over metrics/: the same
// functions and display transform as `afterimage compare`, so the numbers agree with it.
#include <fmt/format.h>

#include <string>
#include <utility>

#include "api/convert.h"
#include "core/error.h"
#include "metrics/display.h"
#include "metrics/flip.h"
#include "metrics/metrics.h"
#include "metrics/psnr.h"
#include "metrics/ssim.h"
#include "metrics/temporal.h"

namespace afterimage {
inline namespace v0 {

namespace {

// RGB of a view (an alpha channel is left out), finite (the same rule as eval and compare).
ImageF rgb(const BufferView& b, const std::string& what, int width = 0, int height = 0) {
  api::check_view(b, what, 3, 4, width, height);
  ImageF img = api::to_image(b, 3);
  metrics::require_finite(img, what);
  return img;
}

std::pair<ImageF, ImageF> pair(const BufferView& reference, const BufferView& test,
                               const char* what) {
  ImageF r = rgb(reference, fmt::format("{}: reference", what));
  ImageF t = rgb(test, fmt::format("{}: test", what), reference.width, reference.height);
  return {std::move(r), std::move(t)};
}

metrics::DisplaySettings display_for(Range range) {
  metrics::DisplaySettings d;
  if (range == Range::ldr) d.tonemap = false;  // already display-referred
  return d;
}

}  // namespace

PairScores compare(const BufferView& reference, const BufferView& test, Range range,
                   const ExecOptions& exec) {
  const auto [r, t] = pair(reference, test, "compare");
  const metrics::PairMetrics m = metrics::compare_images(
      r, t, range == Range::hdr ? metrics::DynamicRange::kHdr : metrics::DynamicRange::kLdr, {},
      api::to_exec(exec));
  PairScores s;
  s.psnr = m.psnr;
  s.psnr_linear = m.psnr_linear;
  s.ssim = m.ssim;
  s.flip = m.flip.mean;
  s.flip_kind = range == Range::hdr ? "HDR-FLIP" : "LDR-FLIP";
  return s;
}

double psnr(const BufferView& reference, const BufferView& test, Range range,
            const ExecOptions& exec) {
  const auto [r, t] = pair(reference, test, "psnr");
  const Exec ex = api::to_exec(exec);
  const metrics::DisplaySettings d = display_for(range);
  return metrics::psnr(metrics::to_display(r, d, ex), metrics::to_display(t, d, ex), 1.0, ex);
}

double ssim(const BufferView& reference, const BufferView& test, Range range,
            const ExecOptions& exec) {
  const auto [r, t] = pair(reference, test, "ssim");
  const Exec ex = api::to_exec(exec);
  const metrics::DisplaySettings d = display_for(range);
  return metrics::ssim_channels(metrics::to_display(r, d, ex), metrics::to_display(t, d, ex), {},
                                ex);
}

double ldr_flip(const BufferView& reference, const BufferView& test, double ppd,
                const ExecOptions& exec) {
  const auto [r, t] = pair(reference, test, "ldr_flip");
  const float p = ppd > 0 ? float(ppd) : metrics::flip_default_ppd();
  return metrics::ldr_flip(r, t, p, api::to_exec(exec)).mean;
}

double hdr_flip(const BufferView& reference, const BufferView& test, const ExecOptions& exec) {
  const auto [r, t] = pair(reference, test, "hdr_flip");
  return metrics::hdr_flip(r, t, {}, api::to_exec(exec)).mean;
}

double temporal_error(const BufferView& output_prev, const BufferView& output,
                      const BufferView& reference_prev, const BufferView& reference,
                      const ExecOptions& exec) {
  const int w = reference.width, h = reference.height;
  const ImageF rp = rgb(reference_prev, "temporal_error: reference_prev");
  const ImageF r = rgb(reference, "temporal_error: reference", rp.width(), rp.height());
  const ImageF op = rgb(output_prev, "temporal_error: output_prev", w, h);
  const ImageF o = rgb(output, "temporal_error: output", w, h);
  return metrics::temporal_error_frame(op, o, rp, r, api::to_exec(exec));
}

}  // namespace v0
}  // namespace afterimage
