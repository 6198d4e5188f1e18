// TAA as a SequenceMethod (frame/sequence_method.h): a TemporalResolver behind the generic
// interface, so every command, the demo and the bench run it by name ("taa:<preset>").
#pragma once

#include <string>

#include "frame/sequence_method.h"
#include "taa/resolver.h"

namespace afterimage::taa {

class TaaMethod final : public SequenceMethod {
 public:
  // `label` is the registry name the method was made from, e.g. "taa:ue4+alpha=0.1".
  TaaMethod(std::string label, const TaaSettings& settings, Exec exec = {});

  std::string name() const override { return label_; }
  ChannelSet required_channels() const override;
  ChannelSet used_channels() const override;
  Frame process(const Frame& frame) override;
  void reset() override { resolver_.reset(); }
  void save_state(const std::string& path) const override { resolver_.save_state(path); }
  void load_state(const std::string& path) override { resolver_.load_state(path); }
  std::string settings_json() const override { return resolver_.settings().to_json(); }
  std::string describe_settings() const override { return resolver_.settings().describe(); }
  void set_exec(const Exec& exec) override { resolver_.set_exec(exec); }
  PlaneTraffic last_traffic() const override { return resolver_.last_traffic(); }

  const TemporalResolver& resolver() const { return resolver_; }

 private:
  std::string label_;
  TemporalResolver resolver_;
};

}  // namespace afterimage::taa
