// TAAU as a SequenceMethod (frame/sequence_method.h): an Upscaler behind the generic
// interface, so `resolve --upscale`, the demo and the bench run it by name ("taau:<preset>").
// Its output frames are larger than its inputs (output_size).
#pragma once

#include <string>
#include <utility>

#include "frame/sequence_method.h"
#include "taau/upscaler.h"

namespace afterimage::taau {

class TaauMethod final : public SequenceMethod {
 public:
  TaauMethod(std::string label, const TaauSettings& settings, Exec exec = {});

  std::string name() const override { return label_; }
  ChannelSet required_channels() const override;
  ChannelSet used_channels() const override;
  std::pair<int, int> output_size(int width, int height) const override {
    return upscaler_.settings().output_size(width, height);
  }
  Frame process(const Frame& frame) override;
  void reset() override { upscaler_.reset(); }
  void save_state(const std::string& path) const override { upscaler_.save_state(path); }
  void load_state(const std::string& path) override { upscaler_.load_state(path); }
  std::string settings_json() const override { return upscaler_.settings().to_json(); }
  std::string describe_settings() const override { return upscaler_.settings().describe(); }
  void set_exec(const Exec& exec) override { upscaler_.set_exec(exec); }

  const Upscaler& upscaler() const { return upscaler_; }

 private:
  std::string label_;
  Upscaler upscaler_;
};

}  // namespace afterimage::taau
