// Scalar parts of the reprojection module.
#include <algorithm>
#include <cmath>

#include "reproject/history.h"

namespace afterimage::reproject {

std::optional<PixelCoord> nearest_history_pixel(int x, int y, float mx, float my, int width,
                                                int height) {
  if (!std::isfinite(mx) || !std::isfinite(my)) return std::nullopt;
  const float qx = float(x) + 0.5f + mx, qy = float(y) + 0.5f + my;
  if (!(qx >= 0.0f && qx < float(width) && qy >= 0.0f && qy < float(height))) return std::nullopt;
  return PixelCoord{std::min(int(std::floor(qx)), width - 1),
                    std::min(int(std::floor(qy)), height - 1)};
}

}  // namespace afterimage::reproject
