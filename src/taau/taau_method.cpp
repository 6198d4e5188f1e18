#include "taau/taau_method.h"

#include <utility>

namespace afterimage::taau {

TaauMethod::TaauMethod(std::string label, const TaauSettings& settings, Exec exec)
    : label_(std::move(label)), upscaler_(settings, exec) {}

ChannelSet TaauMethod::required_channels() const {
  return {Channel::color, Channel::depth, Channel::motion};
}

ChannelSet TaauMethod::used_channels() const {
  return required_channels();
}

Frame TaauMethod::process(const Frame& frame) {
  Frame out = frame.header_only();
  out.color = upscaler_.process(frame);
  out.width = out.color.width();
  out.height = out.color.height();
  return out;
}

}  // namespace afterimage::taau
