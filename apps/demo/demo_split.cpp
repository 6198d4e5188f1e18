#include "apps/demo/demo_split.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace afterimage {

namespace {

const MethodSummary* find_row(const SplitScene& s, const std::string& label) {
  for (const auto& r : s.rows)
    if (r.label == label) return &r;
  return nullptr;
}

double flip_of(const SplitScene& s, const std::string& label) {
  const MethodSummary* r = find_row(s, label);
  return r ? r->aggregate.at("flip") : std::nan("");
}

// Mean of each row's aggregates over `scenes`, for the rows every one of them has (in the first
// scene's order). ms_per_frame is averaged too; per-frame series are not.
SceneSection average_rows(const std::vector<const SplitScene*>& scenes, const std::string& name) {
  SceneSection sec;
  sec.name = name;
  if (scenes.empty()) return sec;
  std::string list;
  for (const SplitScene* s : scenes) list += (list.empty() ? "" : ", ") + s->scene;
  sec.description =
      fmt::format("Mean of each row's scene means over {} scene(s): {}.", scenes.size(), list);
  for (const auto& first : scenes.front()->rows) {
    MethodSummary m;
    m.label = first.label;
    m.command = first.command;
    bool everywhere = true;
    double ms = 0;
    for (const SplitScene* s : scenes) {
      const MethodSummary* r = find_row(*s, first.label);
      if (!r) {
        everywhere = false;
        break;
      }
      for (const auto& [k, v] : r->aggregate) m.aggregate[k] += v / double(scenes.size());
      ms += r->ms_per_frame / double(scenes.size());
    }
    if (!everywhere) continue;
    m.ms_per_frame = first.ms_per_frame < 0 ? -1 : ms;
    sec.methods.push_back(std::move(m));
  }
  return sec;
}

double aggregate_of(const SceneSection& sec, const std::string& label, const std::string& key) {
  for (const auto& m : sec.methods)
    if (m.label == label) {
      const auto it = m.aggregate.find(key);
      return it == m.aggregate.end() ? std::nan("") : it->second;
    }
  return std::nan("");
}

}  // namespace

SplitVerdict judge_taa_split(const std::vector<SplitScene>& scenes,
                             const std::string& default_label,
                             const std::vector<std::string>& anchor_labels) {
  SplitVerdict v;
  std::vector<const SplitScene*> tuning, validation;
  for (const auto& s : scenes) (s.validation ? validation : tuning).push_back(&s);
  v.tuning = average_rows(tuning, "TAA presets over the tuning scenes");
  v.validation = average_rows(validation, "TAA presets over the validation scenes (held out)");
  if (validation.empty() || anchor_labels.empty() ||
      std::isnan(aggregate_of(v.validation, default_label, "flip")))
    return v;
  for (const auto& a : anchor_labels)
    if (std::isnan(aggregate_of(v.validation, a, "flip"))) return v;

  for (const SplitScene* s : validation) {
    const double own = flip_of(*s, default_label);
    for (const auto& a : anchor_labels) {
      const double other = flip_of(*s, a);
      if (other < own)
        v.losses.push_back(fmt::format("{}: {} {:.4f} < {:.4f}", s->scene, a, other, own));
    }
  }
  double best = INFINITY, best_t = INFINITY;
  for (const auto& a : anchor_labels) {
    const double f = aggregate_of(v.validation, a, "flip");
    const double t = aggregate_of(v.validation, a, "temporal_error");
    if (f < best) best = f, v.best_anchor = a;
    if (t < best_t) best_t = t, v.best_temporal_anchor = a;
  }
  v.flip_gain = 1.0 - aggregate_of(v.validation, default_label, "flip") / best;
  v.temporal_ratio = aggregate_of(v.validation, default_label, "temporal_error") / best_t;
  v.judged = true;
  return v;
}

std::string SplitVerdict::text() const {
  if (!judged) return "";
  std::string t = fmt::format(
      "default vs anchors on the validation scenes (issue 10: no loss on any scene, mean FLIP "
      "10% below the best anchor's, mean temporal error at most the best anchor's):\n"
      "  mean FLIP {:+.1f}% vs {} (the best anchor){}\n"
      "  mean temporal error {:.2f}x {}'s (the lowest)\n",
      -100.0 * flip_gain, best_anchor, flip_gain >= 0.10 ? "" : " - short of -10%", temporal_ratio,
      best_temporal_anchor);
  if (losses.empty()) {
    t += "  no scene where an anchor has the lower FLIP\n";
  } else {
    t += "  scenes where an anchor has the lower FLIP:\n";
    for (const auto& l : losses) t += "    " + l + "\n";
  }
  return t;
}

}  // namespace afterimage
