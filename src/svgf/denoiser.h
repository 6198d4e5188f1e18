// SVGF as a SequenceMethod (frame/sequence_method.h): Schied, Kaplanyan, Wyman, Patney,
// Chaitanya, Burgess, Liu, Dachsbacher, Lefohn, Salvi, "Spatiotemporal Variance-Guided
// Filtering: Real-Time Reconstruction for Path-Traced Global Illumination", HPG 2017; the
// variance estimation as seed 001 explains it. Per frame:
//   1. sanitise: a non-finite input value (color, emission, albedo, diffuse, specular) is
//      repaired from its finite 3x3 neighbours and the pixel's history is reset (length 0), so
//      NaN / Inf never enters history and the repaired value is not reused by any pixel;
//   2. demodulate: signals (settings.h Split) direct and indirect / max(albedo, eps), diffuse
//      and specular, or one combined signal (color - emission) / max(albedo, eps);
//   3. reproject (reproject/): the 2x2 bilinear taps around p + motion (+ the jitter change)
//      each tested for depth (slope-scaled), normal and object id and renormalised; if none
//      passes, the consistent pixels of the 3x3 around it with equal weights; else no history;
//   4. accumulate color and luminance moments with alpha = max(alpha_min, 1/(n+1)), n the
//      reprojected history length (svgf_kernels.h);
//   5. variance: temporal once n >= 4, else spatial 7x7 (5x5 in the afterimage preset;
//      filter.h estimate_variance);
//   6. 5 à-trous iterations of the 5x5 kernel (the afterimage preset: 3 of a 3x3 one; filter.h
//      atrous_iteration); the first one's output is the next frame's color history;
//   7. remodulate and add the emission.
// Options beyond the paper (history_clamp.h, off in svgf-paper): a firefly rank clamp of the
// demodulated signal after step 2, a fast history beside the long one whose local box clamps
// the long history in step 4, and alphas / cap stated in seconds, converted per frame.
// History is dropped on the first frame, a camera cut, a size change and a change of the
// signal split. TAA afterwards is the pipeline's (`afterimage run --pipeline svgf,taa`).
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/parallel.h"
#include "frame/sequence_method.h"
#include "svgf/filter.h"
#include "svgf/settings.h"

namespace afterimage::svgf {

// Milliseconds of the stages of the last frame (steady clock; bench and reports).
struct SvgfTimings {
  double prepare_ms = 0;     // sanitise checks, depth gradient
  double accumulate_ms = 0;  // demodulate, reproject, accumulate
  double variance_ms = 0;
  double atrous_ms = 0;      // every iteration, the last one with the remodulation
  double remodulate_ms = 0;  // keep this frame's G-buffer for the next
  double total_ms = 0;
};

class SvgfDenoiser final : public SequenceMethod {
 public:
  // `label` is the registry name ("svgf:afterimage+sigma_l=8"). SettingsError for bad settings.
  explicit SvgfDenoiser(const SvgfSettings& settings = {}, Exec exec = {},
                        std::string label = "svgf");

  std::string name() const override { return label_; }
  // Color, depth, normal and motion; albedo, emission, diffuse, specular, id and depth_gradient
  // when the frame has them.
  ChannelSet required_channels() const override;
  ChannelSet used_channels() const override;
  // The output carries the filtered color, and the temporal_change channel (A-SVGF lambda)
  // when lambda was computed (temporal_gradient with a gradient channel). InputError on
  // inconsistent channel shapes or a diffuse_specular split without those channels.
  Frame process(const Frame& frame) override;
  void reset() override;
  // core/state_file.h file of kind "svgf": sizes, signal count, history color, moments, length
  // and the previous G-buffer. load_state changes nothing unless the file is valid.
  void save_state(const std::string& path) const override;
  void load_state(const std::string& path) override;
  std::string settings_json() const override { return settings_.to_json(); }
  std::string describe_settings() const override { return settings_.describe(); }
  void set_exec(const Exec& exec) override { exec_ = exec; }

  const SvgfSettings& settings() const { return settings_; }
  // Inspection (tests, reports), of the last frame: history length n per pixel (0 = reset
  // this frame), the luminance variance per signal that entered the à-trous, the accumulated
  // moments (2 planes per signal: mean, central variance) and the color history.
  const ImageF& history_length() const { return length_; }
  const ImageF& variance() const { return variance_; }
  const ImageF& moments() const { return moments_; }
  const ImageF& color_history() const { return history_; }
  int signals() const { return signals_; }
  Split split() const { return split_; }
  const SvgfTimings& last_timings() const { return timings_; }
  // The settings the last frame ran with: *_seconds converted at its time step
  // (history_clamp.h); the fast history of the fast-history clamp (empty when off).
  const SvgfSettings& frame_settings() const { return frame_settings_; }
  const ImageF& fast_history() const { return fast_; }
  // A-SVGF: lambda per pixel of the last frame that used the gradient channel (gradient.h).
  const ImageF& gradient_lambda() const { return lambda_; }

 private:
  SvgfSettings settings_;
  Exec exec_;
  std::string label_;
  std::string loaded_from_;  // state file loaded since the last frame (size check)
  SvgfTimings timings_;

  // --- State (what save_state writes) ---
  int width_ = 0, height_ = 0, signals_ = 0;
  Split split_ = Split::Auto;  // the split of the history's signals (never Auto once set)
  bool valid_ = false;
  int64_t frames_ = 0;
  double prev_jitter_[2] = {0, 0};
  ImageF history_;      // 3S planes: first à-trous iteration's output
  ImageF moments_;      // 2S planes: per signal mean, central variance of luminance
  ImageF length_;       // 1 plane: history length n (0: no history)
  ImageF prev_depth_;   // 1 plane
  ImageF prev_normal_;  // 3 planes
  ImageU32 prev_id_;    // 1 plane, empty if the frame had no ids
  ImageF fast_;         // 3S planes: the fast history (fast_history_clamp only)
  double prev_time_ = std::numeric_limits<double>::quiet_NaN();  // last frame's time, seconds

  // --- Scratch (not state) ---
  ImageF acc_, tmp_, next_history_, next_moments_, next_length_, variance_, var_a_, var_b_;
  ImageF gradient_, depth_clean_, normal_clean_, invalid_;
  ImageF sanitized_[5], invalid_parts_[5];
  ImageF next_prev_depth_, next_prev_normal_;
  ImageF luminance_, gradient_strata_, lambda_, relight_;  // A-SVGF (gradient.h)
  ImageU32 next_prev_id_;
  SvgfSettings frame_settings_;
  ImageF next_fast_, long_prev_, alpha_, firefly_, firefly_lum_;
};

}  // namespace afterimage::svgf
