#include "frame/frame.h"

#include <cmath>

#include <fmt/format.h>

#include "core/error.h"

namespace afterimage {

Frame Frame::allocate(int width, int height) {
  Frame f;
  f.width = width;
  f.height = height;
  f.color = ImageF(width, height, 3);
  f.depth = ImageF(width, height, 1, kBackgroundDepth);
  f.normal = ImageF(width, height, 3);
  f.albedo = ImageF(width, height, 3);
  f.motion = ImageF(width, height, 2);
  f.id = ImageU32(width, height, 1);
  return f;
}

namespace {
void check_shape(const ImageF& img, int channels, int w, int h, const char* name,
                 const std::string& what) {
  if (img.empty()) return;  // optional channel group absent
  if (img.channels() != channels || img.width() != w || img.height() != h)
    throw InputError(fmt::format("{}: {} is {}x{}x{}, expected {}x{}x{}", what, name, img.width(),
                                 img.height(), img.channels(), w, h, channels));
}
}  // namespace

void validate_frame(const Frame& f, const std::string& what) {
  if (f.width <= 0 || f.height <= 0)
    throw InputError(fmt::format("{}: empty frame ({}x{})", what, f.width, f.height));
  if (!f.has_color()) throw InputError(fmt::format("{}: missing color channels R G B", what));
  check_shape(f.color, 3, f.width, f.height, "color", what);
  check_shape(f.depth, 1, f.width, f.height, "depth", what);
  check_shape(f.normal, 3, f.width, f.height, "normal", what);
  check_shape(f.albedo, 3, f.width, f.height, "albedo", what);
  check_shape(f.motion, 2, f.width, f.height, "motion", what);
  if (!f.id.empty() && (f.id.width() != f.width || f.id.height() != f.height))
    throw InputError(fmt::format("{}: id is {}x{}, expected {}x{}", what, f.id.width(),
                                 f.id.height(), f.width, f.height));
  if (std::abs(f.jitter.x) > 0.5 + 1e-6 || std::abs(f.jitter.y) > 0.5 + 1e-6)
    throw InputError(
        fmt::format("{}: jitter ({}, {}) outside [-0.5, 0.5]", what, f.jitter.x, f.jitter.y));
}

}  // namespace afterimage
