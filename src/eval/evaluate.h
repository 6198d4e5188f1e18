// Scoring output sequences against references (`afterimage eval`, and the demo): streams
// frames through metrics::SequenceEvaluator, derives disocclusion masks from the G-buffer
// for the ghosting curve, and builds the report's figures (worst-region crops, FLIP maps).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "eval/report.h"
#include "frame/frame.h"
#include "io/sequence_input.h"
#include "metrics/metrics.h"

namespace afterimage {

// One method's evaluation plus what the report's figures need (its last measured frame).
struct MethodEvaluation {
  std::string label;
  std::string command;
  double ms_per_frame = -1;
  metrics::SequenceMetrics metrics;
  ImageF last_output;             // linear HDR, last frame (display values if display_referred)
  bool display_referred = false;  // scored as display images (MetricsSettings)
};

// Streams one method: call add() per frame in order, then finish().
class MethodEvaluator {
 public:
  MethodEvaluator(std::string label, const metrics::MetricsSettings& s, const Exec& ex);
  // `gbuffer` (depth, id, motion of this frame; may be null) yields disocclusion masks.
  void add(const ImageF& output, const ImageF& reference, const Frame* gbuffer);
  // The same against a reference prepared once for every row (metrics::prepare_reference with
  // this evaluator's settings).
  void add(const ImageF& output, const metrics::PreparedReference& reference, const Frame* gbuffer);
  // A warm-up frame without output (metrics::SequenceEvaluator::skip_frame): no scores, its
  // G-buffer still ages the disocclusions.
  void skip(const Frame* gbuffer);
  // `last_output`: the method's last frame (linear HDR), kept for the report's figures.
  MethodEvaluation finish(const ImageF& last_output, const std::string& command = "",
                          double ms_per_frame = -1);
  const std::string& label() const { return label_; }

 private:
  // This frame's disocclusion mask from `gbuffer` and the previous one (all 0 on the first
  // frame), or nothing without depth, ids and motion; keeps the G-buffer for the next frame.
  std::optional<metrics::Mask> disocclusion(const Frame* gbuffer);

  std::string label_;
  Exec ex_;
  metrics::SequenceEvaluator eval_;
  bool display_referred_ = false;
  ImageF prev_depth_;
  ImageU32 prev_id_;
};

MethodSummary to_summary(const MethodEvaluation& e);

// Figures for a scene: crops of every method and the reference at the `regions` windows of
// largest summed LDR-FLIP error on the last frame, and a FLIP heatmap per method.
std::vector<Figure> make_figures(const std::vector<MethodEvaluation>& methods,
                                 const ImageF& last_reference,
                                 const metrics::DisplaySettings& display, int regions = 2,
                                 const Exec& ex = {});

// Magma-like colormap of a value in [0, 1] (FLIP's visualisation), as display RGB.
Vec3f magma(float t);

// Metric settings of `afterimage eval` and the demo: warm-up of 16 frames (one Halton cycle).
inline metrics::MetricsSettings default_eval_metrics() {
  metrics::MetricsSettings m;
  m.warmup = 16;
  return m;
}

// `afterimage eval`: every output directory against one reference directory.
struct EvalOptions {
  // Directories of frame.NNNN.exr, or of display images frame.NNNN.png / .jpg (`resolve
  // --out-format png|jpg`), scored as display-referred (metrics::MetricsSettings).
  std::vector<std::string> outputs;
  std::vector<std::string> labels;  // defaults to the directory names
  std::string reference;
  // Directory whose frames carry depth/id/motion for the ghosting masks; default: each
  // output's own frames if they carry them (resolve --keep-gbuffer), else the reference's.
  std::string gbuffer;
  // How the reference and G-buffer frames are read (io/sequence_input.h); outputs are always
  // recognised automatically (ours after `resolve`, or a tool's raw input).
  std::string layout = "auto";
  std::vector<std::string> maps;
  std::string jitter;       // --jitter of the G-buffer sequence: none | haltonN[:start]
  std::string jitter_file;  // camera sidecar of the G-buffer sequence
  io::NoteFn note;          // one-line notes (layout chosen, camera unknown)
  metrics::MetricsSettings metrics = default_eval_metrics();
  // Frames scored: t % every == offset (`--every N[:OFFSET]`; e.g. 2:1 scores only the frames
  // `extrapolate --skip 1` synthesised). Warm-up and the temporal metrics count scored frames.
  int every = 1, every_offset = 0;
  std::string json_path, report_path;
  std::string command_line;
};
struct EvalResult {
  std::vector<MethodEvaluation> methods;
  ImageF last_reference;
  std::string reference_layout;  // io::SequenceReader::layout_choice of --ref
};
EvalResult run_eval(const EvalOptions& o, const Exec& ex);
nlohmann::json eval_to_json(const std::vector<MethodEvaluation>& methods,
                            const metrics::MetricsSettings& s);
// One line per method: label and the aggregate metrics, aligned (terminal output).
std::string format_eval_table(const std::vector<MethodEvaluation>& methods);

}  // namespace afterimage
