// Upscaler: temporal upsampling (TAAU, issue 10). Input frames rendered at a lower
// resolution with jitter (Halton 2,3 of length ceil(8 scale^2), as FSR2 recommends) are
// accumulated into a history at the output resolution. Per output pixel, in this order:
//   1. the 3x3 input samples around the one nearest to the pixel center are splatted into it
//      with weights of their true distance (upscale_kernels.h: Lanczos-2 or Gaussian), giving
//      this frame's color and its weight (sum of the sample weights);
//   2. the color is clamped to the 3x3 min/max (deringing);
//   3. velocity dilation over the input 3x3, motion scaled to output pixels, history read at
//      the output pixel center + motion (DESIGN.md §3) with a bicubic filter;
//   4. rectification of history against the input 3x3 (taa/taa_kernels.h rectify_history);
//   5. weighted running mean: alpha = w / (n + w) with n the weight history carries, capped;
//      with history confidence the box of 4. is widened and the cap raised where the nearest
//      input pixel's luma moments trust the history (TAA's rules on the low-resolution stream,
//      computed per input pixel in the pre-pass; taa/taa_kernels.h "History confidence").
// History is reset on the first frame, on a change of input or output size and on
// Frame::camera_cut. Bit-identical for any thread count and for Exec::simd off.
#pragma once

#include <string>
#include <utility>

#include "core/image.h"
#include "core/parallel.h"
#include "frame/frame.h"
#include "taau/settings.h"

namespace afterimage::taau {

class Upscaler {
 public:
  // Throws SettingsError if `settings` do not validate.
  explicit Upscaler(const TaauSettings& settings = {}, Exec exec = {});

  // Upscales one frame: returns the RGB image at settings().output_size(frame size), which is
  // also the next frame's history. Needs color; depth and motion are used when present.
  // Throws InputError on inconsistent channel shapes or an impossible output size.
  ImageF process(const Frame& frame);

  void reset();

  // core/state_file.h file of kind "taau": continuing from a saved state is bit-identical.
  void save_state(const std::string& path) const;
  void load_state(const std::string& path);

  const TaauSettings& settings() const { return settings_; }
  const Exec& exec() const { return exec_; }
  void set_exec(Exec e) { exec_ = e; }
  bool has_history() const { return valid_; }
  const ImageF& history() const { return history_; }
  const ImageF& weight() const { return weight_; }  // accumulated sample weight per pixel

 private:
  std::string loaded_from_;
  TaauSettings settings_;
  taa::TaaSettings rect_;  // the rectification fields as TAA settings
  Exec exec_;

  // --- State ---
  int in_w_ = 0, in_h_ = 0, out_w_ = 0, out_h_ = 0;
  bool valid_ = false;
  long frames_ = 0;
  ImageF history_;               // 3 planes RGB, output size
  ImageF weight_;                // 1 plane, output size
  ImageF moments_;               // taa::kLumaMomentPlanes planes, input size (confidence)
  ImageF spreads_;               // taa::kSpreadPlanes planes derived from moments_, input size
  long frames_since_reset_ = 0;  // frames the history has run (the moments' young weight)

  // --- Scratch ---
  ImageF next_history_, next_weight_, next_moments_, next_spreads_, sanitized_, invalid_,
      zero_motion_, background_depth_;
  ImageF pre_;  // per input pixel: dilated motion and the rectification box (upscaler.cpp)
};

}  // namespace afterimage::taau
