// `afterimage run --pipeline taa,bloom,tonemap` (issue 12): one temporal method from the method
// registry (run/methods.h) followed by stateless post passes (post/), always in the
// DESIGN.md order — temporal, dof, motion_blur, bloom, flare, tonemap, sharpen — whatever
// order the user lists them in. Each stage's settings come from its own parameter table
// through "stage.key=value" assignments, so a misspelt key or an out-of-range value is a
// one-line SettingsError naming the stage. The whole chain is a SequenceMethod, so `run`
// reuses every check and writer of `resolve` (run/sequence.h).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/image.h"
#include "core/parallel.h"
#include "frame/sequence_method.h"
#include "post/row_pass.h"
#include "run/sequence.h"

namespace afterimage {

// A pass over one frame's color (the frame gives the G-buffer some passes need).
class PostStage {
 public:
  virtual ~PostStage() = default;
  virtual void set(const std::string& assignment) = 0;  // "key=value" of the stage's table
  virtual void validate() const = 0;
  virtual ImageF apply(const Frame& frame, const ImageF& color, const Exec& ex) const = 0;
  // The next frame of a sequence (frames in order; camera_cut starts a new one). Stateless
  // stages are apply(); a stage that reads earlier frames (motion_blur's camera split and
  // trail) overrides this, reset() and keeps_frames(). apply() then sees no earlier frame.
  virtual ImageF process(const Frame& frame, const ImageF& color, const Exec& ex) {
    return apply(frame, color, ex);
  }
  virtual void reset() {}
  // True when process() depends on earlier frames with the current settings.
  virtual bool keeps_frames() const { return false; }
  // True when the stage moves pixels with weights from the G-buffer alone (dof, motion_blur):
  // the frames' coverage alpha then goes through a twin of the stage, the same settings, fed
  // the alpha as its color (run/alpha.h). The other stages leave the alpha as it is.
  virtual bool filters_alpha() const { return false; }
  virtual std::string settings_json() const = 0;
  // One line per key: "key = value   default D, range R -- doc" (--list-settings).
  virtual std::string describe_settings() const = 0;
  // G-buffer channels the pass reads from the input frame (color comes from the chain).
  virtual ChannelSet required_channels() const { return {}; }
  // SequenceMethod::check_header for this stage: InputError for a frame it cannot process,
  // judged by the header alone (dof's lens, motion_blur's camera), before anything is written.
  virtual void check_header(const FrameHeader&, const WarnFn& /*note*/) const {}
  // Fusion (post/row_pass.h). A stage that can run as a pass over each finished row of the
  // stage before it returns itself as a RowPass, empty for the others: tonemap (per pixel)
  // and flare (the light of `radiance`, the fusing stage's input: bloom's, DESIGN.md §1). A
  // stage that can run a RowPass on each row it finishes (bloom, flare) says so and takes it
  // in process(); run_post_stages then skips the stages it ran.
  virtual post::RowPass row_pass(const Exec&, const ImageF& /*radiance*/) const { return {}; }
  virtual bool fuses_row_pass() const { return false; }
  // `then` may be empty (process() alone).
  virtual ImageF process(const Frame& frame, const ImageF& color, const Exec& ex,
                         const post::RowPass& then) {
    return post::apply_row_pass(process(frame, color, ex), then, ex);
  }
  // The same values from a color the caller gives up (run_post_stages' own frames between
  // stages): a stage may write its output over it (bloom and flare composite in place).
  virtual ImageF process_owned(const Frame& frame, ImageF& color, const Exec& ex,
                               const post::RowPass& then) {
    return process(frame, std::as_const(color), ex, then);
  }
};

// Runs `stages` in order on `color` (process(): frames in order), the stages that can run row
// by row fused into the stage before them where that one can run them (post/row_pass.h).
// flare adds the light of the radiance before bloom (bloom's input, or flare's own without
// bloom) to bloom's output: the two are separate paths of the light entering the lens.
ImageF run_post_stages(const std::vector<PostStage*>& stages, const Frame& frame,
                       const ImageF& color, const Exec& ex);
// The same from a color the caller gives up: the first stage may write over it too.
ImageF run_post_stages(const std::vector<PostStage*>& stages, const Frame& frame, ImageF&& color,
                       const Exec& ex);

// The depth and motion of `in` at the chain's color size (width x height), for the post
// stages after a temporal upscaler (taau): each output pixel takes the input pixel under its
// centre (nearest; depth is not interpolated, as a blend of a near and a far depth is a surface
// at neither), motion vectors scaled to output pixels. The header follows the size (jitter
// scaled too); the lens is the same (a CoC in pixels grows with the width).
Frame gbuffer_at_size(const Frame& in, int width, int height, const Exec& ex = {});

struct PostStageInfo {
  std::string name;  // "tonemap"
  // Position in the DESIGN.md chain: dof 10, motion_blur 20, bloom 30, flare 40, tonemap 60,
  // sharpen 70 (the temporal stage comes before all).
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

// The widest pipeline there is, for `run --list-settings` without --pipeline: the first
// denoiser (svgf), the first resolve method (taa, the default technique; a pipeline holds one of
// each) and every post stage.
std::string widest_pipeline();

// What the 8-bit writer does to the chain's output: reinhard (no tonemap stage: linear HDR),
// clamp (a tonemap stage left the sRGB encoding to the writer) or encoded (a tonemap stage
// encoded sRGB and a sharpen stage sharpened the encoded values, as in an EXR run; or
// tonemap.srgb=false asked for linear display values, which the writer then only clips).
Tonemap display_transform(const PipelineSpec& spec);

// The chain as one SequenceMethod. `display_output`: the frames are written as 8-bit display
// images; a tonemap stage then encodes sRGB as display_transform says.
std::unique_ptr<SequenceMethod> make_pipeline_method(const PipelineSpec& spec, const Exec& exec,
                                                     bool display_output = false);

}  // namespace afterimage
