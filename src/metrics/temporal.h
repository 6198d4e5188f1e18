// Metrics over time (DESIGN.md §4): temporal error (flicker and lag), ghosting (error on
// recently disoccluded pixels, by age) and sharpness (gradient-energy ratio).
//
// Unless stated otherwise the images here are *display* images (display.h: the same
// tonemap + sRGB encoding on output and reference), 3 planes, values in [0, 1].
#pragma once

#include <cstdint>
#include <vector>

#include "core/image.h"
#include "core/parallel.h"
#include "metrics/display.h"

namespace afterimage::metrics {

using Mask = Image<uint8_t>;  // 1 plane, 1 = set

// ---- Temporal error --------------------------------------------------------------------
// e(t) = mean over pixels and channels of |(O_t - O_{t-1}) - (R_t - R_{t-1})|.
// Zero when the output changes exactly as the reference does; flicker (change the reference
// does not have) and lag (change arriving late) both raise it.
double temporal_error_frame(const ImageF& output_prev, const ImageF& output,
                            const ImageF& reference_prev, const ImageF& reference,
                            const Exec& ex = {});

// Mean of e(t) over frames t > warmup (frames 0..warmup-1 are warm-up; e(t) needs both t-1
// and t to be measured frames), on *linear* sequences put through `display`.
// NaN if no frame qualifies. Throws InputError on mismatched lengths or shapes.
double temporal_error(const std::vector<ImageF>& output, const std::vector<ImageF>& reference,
                      int warmup, const DisplaySettings& display = {}, const Exec& ex = {});

// ---- Lag after a step change ----------------------------------------------------------
// Display error of one frame: mean over pixels and channels of |display(O) - display(R)| on
// *linear* images (the per-frame error lag_frames follows).
double display_error_frame(const ImageF& output, const ImageF& reference,
                           const DisplaySettings& display = {}, const Exec& ex = {});
// display_error_frame of every frame (equal lengths and shapes; InputError otherwise).
std::vector<double> display_error_per_frame(const std::vector<ImageF>& output,
                                            const std::vector<ImageF>& reference,
                                            const DisplaySettings& display = {},
                                            const Exec& ex = {});

// Frames a method needs to follow a step change of the reference at frame `step` (issue 11:
// "frames until error <= 1.2x steady state"). With e the per-frame error (display_error_frame)
// of frames 0..N-1:
//   steady = mean of e over the last `steady_frames` frames (the state the method settles
//            in after the step; they must all lie after `step`),
//   lag    = the smallest L >= 0 with e[step + L] <= tolerance * steady,
// i.e. 0 when the step frame itself is already within tolerance; N - step when no frame is.
// InputError unless 0 <= step and step + steady_frames <= N, steady_frames >= 1, tolerance >= 1.
int lag_frames(const std::vector<double>& error, int step, int steady_frames = 4,
               double tolerance = 1.2);

// ---- Disocclusion ----------------------------------------------------------------------
struct DisocclusionSettings {
  // Relative depth change beyond which the surface seen at the reprojected point is taken
  // as a different one: |d_prev - d| > depth_tolerance * d.
  float depth_tolerance = 0.1f;
  void validate() const;  // throws SettingsError
};

// Pixels of frame t that show a surface not visible at frame t-1, from G-buffer data
// (DESIGN.md §3 conventions): the history position of pixel (i, j) is
// q = (i + 0.5, j + 0.5) + motion (motion = p_prev - p_curr). The pixel is disoccluded if q is
// off-screen, or motion is not finite, or at the previous-frame pixel containing q (nearest,
// floor(q)) the object id differs or the depth differs by more than the tolerance.
// depth, prev_depth: 1 plane; id, prev_id: 1 plane; motion: 2 planes.
Mask disocclusion_mask(const ImageF& depth, const ImageU32& id, const ImageF& motion,
                       const ImageF& prev_depth, const ImageU32& prev_id,
                       const DisocclusionSettings& s = {}, const Exec& ex = {});

// Per-pixel age of the last disocclusion, followed along the motion vectors:
//   age_t(p) = 1                          if p is disoccluded at frame t,
//            = age_{t-1}(q) + 1            if 1 <= age_{t-1}(q) < max_age (q = history
//                                          position of p, nearest pixel, on screen),
//            = 0                           otherwise (never, or more than max_age frames ago).
// So age_t(p) = k  <=>  the surface at p was disoccluded at frame t-k+1 and has stayed
// visible (not disoccluded again) since. Without motion (nullptr) q = p.
class DisocclusionAge {
 public:
  explicit DisocclusionAge(int max_age = 8);
  void update(const Mask& disoccluded, const ImageF* motion = nullptr, const Exec& ex = {});
  void reset() { age_ = {}; }
  const Image<uint8_t>& age() const { return age_; }
  int max_age() const { return max_age_; }

 private:
  int max_age_;
  Image<uint8_t> age_;
};

// ---- Ghosting --------------------------------------------------------------------------
// err(k), k = 1..max_age: mean over (frame, pixel) samples with age k of the display error
// mean_c |O - R|. error[k-1] = err(k); NaN where no sample had age k.
struct GhostingCurve {
  std::vector<double> error;
  std::vector<uint64_t> samples;  // pixel-frames that contributed to err(k)
};

class GhostingAccumulator {
 public:
  explicit GhostingAccumulator(int max_age = 8);
  // Adds one frame: display images of output and reference, ages of this frame.
  void add(const ImageF& output, const ImageF& reference, const Image<uint8_t>& age,
           const Exec& ex = {});
  GhostingCurve curve() const;

 private:
  std::vector<double> sum_;
  std::vector<uint64_t> count_;
};

// Whole-sequence convenience on *linear* sequences: masks[t] = disocclusion at frame t
// (masks[0] usually empty of set pixels), motions[t] = motion of frame t (may be empty: static
// screen-space ages). Frames t >= warmup are accumulated; ages are tracked from frame 0.
GhostingCurve ghosting_curve(const std::vector<ImageF>& output,
                             const std::vector<ImageF>& reference, const std::vector<Mask>& masks,
                             const std::vector<ImageF>& motions, int warmup,
                             const DisplaySettings& display = {}, int max_age = 8,
                             const Exec& ex = {});

// ---- Sharpness -------------------------------------------------------------------------
// Sum of squared forward differences (x and y) of one plane: the gradient energy.
double gradient_energy(PlaneView plane, const Exec& ex = {});
// gradient_energy(luma(output)) / gradient_energy(luma(reference)) of display images:
// < 1 blurrier than the reference, > 1 sharper or noisier. 1 if both are flat; +inf if only
// the reference is flat.
double sharpness_ratio(const ImageF& output, const ImageF& reference, const Exec& ex = {});
// gradient_energy(luma(display)): the reference's side of sharpness_ratio, computed once.
double luma_gradient_energy(const ImageF& display, const Exec& ex = {});
// The same ratio against a reference's luma_gradient_energy.
double sharpness_ratio(const ImageF& output, double reference_energy, const Exec& ex = {});

}  // namespace afterimage::metrics
