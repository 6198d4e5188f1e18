// `afterimage run --pipeline taa,bloom,tonemap` (issue 12): one temporal method from the method
// registry (pipeline/methods.h) followed by stateless post passes (post/), always in the
// DESIGN.md order — temporal, dof, motion_blur, bloom, flare, sharpen, tonemap — whatever
// order the user lists them in. Each stage's settings come from its own parameter table
// through "stage.key=value" assignments, so a misspelt key or an out-of-range value is a
// one-line SettingsError naming the stage. The whole chain is a SequenceMethod, so `run`
// reuses every check and writer of `resolve` (pipeline/sequence.h).
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/parallel.h"
#include "frame/sequence_method.h"

namespace afterimage {

// A pass over one frame's color (the frame gives the G-buffer some passes need).
class PostStage {
 public:
  virtual ~PostStage() = default;
  virtual void set(const std::string& assignment) = 0;  // "key=value" of the stage's table
  virtual void validate() const = 0;
  // The pass's output written into `out`, which is made the output's shape; its storage is
  // reused when it already has that shape, so a caller that keeps `out` between frames
  // allocates (and page-faults) nothing per frame. `out` must not be `color` (InputError).
  virtual void apply_into(const Frame& frame, const ImageF& color, ImageF& out,
                          const Exec& ex) const = 0;
  ImageF apply(const Frame& frame, const ImageF& color, const Exec& ex) const {
    ImageF out;
    apply_into(frame, color, out, ex);
    return out;
  }
  // The next frame of a sequence (frames in order; camera_cut starts a new one). Stateless
  // stages are apply_into(); a stage that reads earlier frames (motion_blur's camera split and
  // trail) overrides this, reset() and keeps_frames(). apply() then sees no earlier frame.
  virtual void process_into(const Frame& frame, const ImageF& color, ImageF& out, const Exec& ex) {
    apply_into(frame, color, out, ex);
  }
  ImageF process(const Frame& frame, const ImageF& color, const Exec& ex) {
    ImageF out;
    process_into(frame, color, out, ex);
    return out;
  }
  virtual void reset() {}
  // True when process() depends on earlier frames with the current settings.
  virtual bool keeps_frames() const { return false; }
  virtual std::string settings_json() const = 0;
  // G-buffer channels the pass reads from the input frame (color comes from the chain).
  virtual ChannelSet required_channels() const { return {}; }
};

// Stages run in order on one frame's color. A run of bloom, flare and tonemap (consecutive,
// the DESIGN.md order) is one fused pass (post/uber.h: the same bits as the three stages, one
// full-resolution write instead of three).
class PostChain {
 public:
  // The stages are not owned and must outlive the chain.
  explicit PostChain(std::vector<PostStage*> stages);
  // Every stage's apply_into() (stateless) or, with `sequence`, process_into() (the next
  // frame of a sequence) in turn, the last one into `out` (not `color`; a copy of the input
  // when there is no stage). The images between stages are the chain's own and keep their
  // storage from frame to frame; so does `out` when the caller keeps it.
  void run_into(const Frame& frame, const ImageF& color, ImageF& out, const Exec& ex,
                bool sequence);
  ImageF run(const Frame& frame, const ImageF& color, const Exec& ex, bool sequence) {
    ImageF out;
    run_into(frame, color, out, ex, sequence);
    return out;
  }

 private:
  std::vector<PostStage*> stages_;
  int fused_at_ = -1;              // index of a bloom, flare, tonemap run (-1: none)
  std::array<ImageF, 2> between_;  // outputs of the inner steps, in turn
};

struct PostStageInfo {
  std::string name;  // "tonemap"
  // Position in the DESIGN.md chain: dof 10, motion_blur 20, bloom 30, flare 40, sharpen 50,
  // tonemap 60 (the temporal stage comes before all).
  int order;
  std::string description;  // one line for --help
  std::function<std::unique_ptr<PostStage>()> make;
};

// The post stages that exist, in chain order.
const std::vector<PostStageInfo>& post_stages();

struct PipelineSpec {
  std::string temporal;                  // method spec ("taa:hdrp"); empty: none
  std::string denoise;                   // a denoiser run first ("svgf:afterimage"); empty: none
  std::vector<std::string> post;         // stage names in chain order
  std::vector<std::string> assignments;  // "stage.key=value"
};

// Parses "--pipeline taa:hdrp,tonemap" (comma list; a temporal stage is any method spec of the
// registry: taa[:preset], taau[:mode]; a denoiser, svgf[:preset], may come in addition and
// runs first) plus the --set assignments. SettingsError for unknown stages, two temporal
// stages of one kind, a repeated stage, an assignment to a stage not in the
// pipeline, or an empty pipeline.
PipelineSpec parse_pipeline(const std::string& stages, const std::vector<std::string>& sets);

// The chain as one SequenceMethod. `display_output`: the frames are written as 8-bit display
// images, so a tonemap stage leaves the sRGB encoding to the writer.
std::unique_ptr<SequenceMethod> make_pipeline_method(const PipelineSpec& spec, const Exec& exec,
                                                     bool display_output = false);

}  // namespace afterimage
