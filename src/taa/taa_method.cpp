#include "taa/taa_method.h"

#include <utility>

namespace afterimage::taa {

TaaMethod::TaaMethod(std::string label, const TaaSettings& settings, Exec exec)
    : label_(std::move(label)), resolver_(settings, exec) {}

std::vector<std::string> TaaMethod::required_channels() const {
  // Depth and motion drive reprojection, dilation and rejection; ids and normals are used
  // when present.
  return {"color", "depth", "motion"};
}

Frame TaaMethod::process(const Frame& frame) {
  Frame out = frame;
  out.color = resolver_.process(frame);
  return out;
}

}  // namespace afterimage::taa
