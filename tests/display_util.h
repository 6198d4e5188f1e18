// Display-referred PSNR for scene tests: both images through the default display transform
// (Reinhard tonemap + sRGB, metrics/display.h), then PSNR with peak 1, as `eval` reports it.
#pragma once

#include "core/image.h"
#include "metrics/display.h"
#include "metrics/psnr.h"

namespace afterimage::test {

inline double display_psnr(const ImageF& reference, const ImageF& test) {
  const metrics::DisplaySettings ds;
  return metrics::psnr(metrics::to_display(reference, ds), metrics::to_display(test, ds));
}

}  // namespace afterimage::test
