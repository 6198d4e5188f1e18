#include "taa/taa_method.h"

#include <utility>

namespace afterimage::taa {

TaaMethod::TaaMethod(std::string label, const TaaSettings& settings, Exec exec)
    : label_(std::move(label)), resolver_(settings, exec) {}

ChannelSet TaaMethod::required_channels() const {
  // Depth and motion drive reprojection, dilation and rejection; ids are used when present.
  return {Channel::color, Channel::depth, Channel::motion};
}

ChannelSet TaaMethod::used_channels() const {
  return {Channel::color, Channel::depth, Channel::motion, Channel::id, Channel::temporal_change};
}

Frame TaaMethod::process(const Frame& frame) {
  Frame out = frame.header_only();
  out.color = resolver_.process(frame);
  return out;
}

}  // namespace afterimage::taa
