// The held-out check of the default TAA preset (issue 10): the built-in scenes are split into
// the ones the preset was tuned on and the ones kept apart to validate it
// (render::SceneInfo::taa_split). The demo averages every TAA row over each set and states,
// for the validation set, whether the default is at least as good as every anchor preset on
// mean FLIP on each scene, how much better than the best anchor it is on average (the issue
// asks for 10%), and how its mean temporal error compares with the best anchor's.
#pragma once

#include <string>
#include <vector>

#include "eval/report.h"

namespace afterimage {

// One scene's main-table rows and the set it belongs to.
struct SplitScene {
  std::string scene;
  bool validation = false;  // false: a tuning scene
  std::vector<MethodSummary> rows;
};

struct SplitVerdict {
  // Each TAA row's aggregates averaged over the tuning / validation scenes (rows every scene of
  // the set has; sections empty when the set ran no scene).
  SceneSection tuning, validation;
  // Validation scenes on which an anchor has a lower mean FLIP than the default:
  // "cut: hdrp .0163 < .0174".
  std::vector<std::string> losses;
  std::string best_anchor;           // lowest mean FLIP over the validation scenes
  double flip_gain = 0.0;            // 1 - default / best anchor (mean FLIP); target >= 0.10
  std::string best_temporal_anchor;  // lowest mean temporal error
  double temporal_ratio = 0.0;       // default / that anchor's mean temporal error; target <= 1
  bool judged = false;               // false: no validation scene, or a row missing
  std::string text() const;          // the lines the demo prints and reports
};

// `default_label` and `anchor_labels` are table row labels (run/methods.h method_label).
SplitVerdict judge_taa_split(const std::vector<SplitScene>& scenes,
                             const std::string& default_label,
                             const std::vector<std::string>& anchor_labels);

}  // namespace afterimage
