// What SvgfDenoiser's steps 2-4 (denoiser.h: demodulate, reproject, accumulate) read and write,
// as plain pointers to planes of w x h values: the lane blocks in denoiser.cpp and the plain
// pass in reference.h (reproject_and_accumulate, which --simd off runs) take the same context.
#pragma once

#include <cstdint>

#include "svgf/filter.h"
#include "svgf/settings.h"

namespace afterimage::svgf {

// Rows are independent: each row writes only its own pixels.
struct AccumulateContext {
  const SvgfSettings* s = nullptr;
  int w = 0, h = 0, signals = 1;
  // Signal s, channel c: plane `signal[3s + c]`, minus the emission when `subtract_emission`
  // (the combined signal is the color), divided by max(albedo, eps) when `demodulate`.
  const float* signal[3 * kMaxSignals] = {};
  bool subtract_emission = false, demodulate = false;
  const float* emission[3] = {};   // null: none
  const float* albedo[3] = {};     // null: none (no demodulation)
  const float* invalid = nullptr;  // 1 where an input was not finite (null: none)
  const float* depth = nullptr;
  const float* normal[3] = {};
  const uint32_t* id = nullptr;  // null: no id test
  const float* motion[2] = {};
  const float* gradient[2] = {};
  const float* lambda = nullptr;       // A-SVGF normalised temporal change (null: none)
  const float* relight = nullptr;      // A-SVGF history relighting factor (null: none)
  bool shorten_history = false;        // with lambda: n -> (1 - lambda) n
  float jitter_dx = 0, jitter_dy = 0;  // current minus previous jitter (pixels)
  bool has_history = false;
  const float* prev_depth = nullptr;
  const float* prev_normal[3] = {};
  const uint32_t* prev_id = nullptr;
  const float* prev_length = nullptr;
  const float* prev_color[3 * kMaxSignals] = {};
  const float* prev_mean[kMaxSignals] = {};
  const float* prev_var[kMaxSignals] = {};
  float* acc[3 * kMaxSignals] = {};
  float* mean[kMaxSignals] = {};
  float* var[kMaxSignals] = {};
  float* length = nullptr;
  // This frame's (sanitised) depth and normal and its ids, kept for the next frame: written
  // here with streaming stores from the values the block loads anyway, instead of a separate
  // copy pass (null: not kept). keep_id_from is the id plane to keep (also when ids are not
  // tested).
  float* keep_depth = nullptr;
  float* keep_normal[3] = {};
  const uint32_t* keep_id_from = nullptr;
  uint32_t* keep_id = nullptr;
  // Step 1 folded into the reads (when `check`): the raw planes the sanitising would repair.
  // Color-like ones must be finite and >= 0, depth finite and > 0, normal and depth gradient
  // finite; a block that fails makes accumulate_block return true (core/sanitize.h semantics).
  bool check = false;
  int check_colors = 0, check_finites = 0;
  const float* check_color[15] = {};
  const float* check_depth = nullptr;
  const float* check_finite[5] = {};
  // Fast-history clamp (history_clamp.h), when `fast`: the fast history is reprojected with the
  // same taps and accumulated into fast_acc; acc then receives this frame's signal, long_prev
  // the reprojected long history and alpha_out the color alpha, for the clamp pass.
  bool fast = false;
  float fast_alpha_min = 0.5f;
  const float* prev_fast[3 * kMaxSignals] = {};
  float* fast_acc[3 * kMaxSignals] = {};
  float* long_prev[3 * kMaxSignals] = {};
  float* alpha_out = nullptr;
};

}  // namespace afterimage::svgf
