// Settings of temporal upsampling (TAAU, issue 10; DESIGN.md §2: a plain struct registered in
// the parameter table of core/params.h). The input frames are rendered at a lower resolution;
// the output is `scale` times larger per axis (or an explicit size). Rectification reuses the
// TAA choices (taa/settings.h enums, spelled once there).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/params.h"
#include "taa/settings.h"

namespace afterimage::taau {

// Weight of a current-frame sample by its true distance to the output pixel center (in
// output pixels): the "splat" of the sample into the output grid.
enum class SplatKernel {
  Lanczos2,  // sinc(r) sinc(r / 2), r < 2 (FSR2's upsampling kernel)
  Gaussian,  // exp(-r^2 / (2 sigma^2))
};

// Every member is registered in TaauSettings::params() (settings.cpp); its default is the
// initializer below.
struct TaauSettings {
  // --- Output size ---
  // Output size per axis = round(input * scale) (FSR2 quality 1.5, balanced 1.7,
  // performance 2.0).
  float scale = 2.0f;
  // Explicit output size (both or neither; 0 = from scale).
  int output_width = 0;
  int output_height = 0;

  // --- Splat of the current samples ---
  // Chosen by measurement (`afterimage demo --scenes thin,motion,orbit --methods
  // taa:afterimage --taau-methods ...`, 320x180 output, 48 frames, means after 16; FLIP
  // thin / motion / orbit, mean): Gaussian sigma 0.5 .0857/.0325/.0268 mean .0483 (PSNR 30.60
  // dB mean); sigma 0.4 .0485, 0.6 .0494; Lanczos-2 width 1.25 .0484 (30.45 dB), width 1
  // (max_weight 3) .0502, width 0.8 .0497. Lanczos-2 is as good at best, not better, and costs
  // a sine and a cosine per sample: Gaussian is the default.
  SplatKernel kernel = SplatKernel::Gaussian;
  // Lanczos-2 distance unit in output pixels (1: zero crossing at 1 output pixel, support 2).
  float lanczos_width = 1.0f;
  // Gaussian sigma in output pixels.
  float gaussian_sigma = 0.5f;
  // Clamp the splatted current color to the min/max of its 3x3 low-resolution samples
  // (removes the ringing of Lanczos' negative lobes; FSR2 does the same).
  bool deringing = true;

  // --- Accumulation ---
  // Cap of the accumulated sample weight per output pixel: alpha >= w / (max_weight + w),
  // the exponential floor of a sample-count accumulation (seed 000 Eq.1 -> Eq.3). A pixel
  // gets w ~ 0.4 per frame at 2x (sigma 0.5), so 2 keeps alpha near TAA's 0.125-0.16; more
  // history blurs moving scenes through repeated resampling (same runs, mean FLIP: cap 1.5
  // .0485, 2 .0483, 3 .0489, 4 .0496 with thin improving and motion / orbit worsening).
  float max_weight = 2.0f;
  // History confidence (taa/settings.h "History confidence"; the other confidence_* settings
  // at TAA's defaults): TAA's rules run per input pixel in the pre-pass on the low-resolution
  // stream (the raw sample's z against its luma moments, motion, whiteness, the neighbours'
  // change and the 3x3 drift), and every output pixel takes its nearest sample's trust. Where
  // the history is trusted the box widens by up to confidence_box_sigma temporal sigmas of the
  // input samples and the weight cap rises from max_weight toward confident_max_weight.
  // Until 2026-11-29 the confidence was per output pixel, from moments of the splatted color,
  // without the neighbour and drift rules (at output resolution the neighbours' samples are not
  // at hand): it lagged after lighting changes at rest and lost to bicubic upscaling of the
  // low-resolution TAA on `light`. Chosen on the demo's tuning scenes (320x180 from 160x90, 48
  // frames, FLIP thin / motion / orbit / light / blades), with TAA's confidence_motion_px 0.5:
  //   per output pixel (old)                    .0496 .0311 .0293 .0450 .0384 (sum .1934)
  //   per input pixel, box sigma 2 (TAA's)       .0535 .0307 .0270 .0344 .0386 (.1842)
  //   per input pixel, box sigma 4               .0520 .0306 .0270 .0344 .0384 (.1824)
  //   per input pixel, box sigma 8               .0512 .0305 .0270 .0344 .0383 (.1814)
  // (TAA 1/2 + bicubic: .0646 .0415 .0351 .0422 .0419). The input samples of one pixel vary
  // more under jitter than the output's blend, so the box needs more of their sigmas. Held-out
  // figures: presets.cpp / the closing note of issue 10. TaauScene (128x72 from 64x36) with
  // box sigma 2 failed on sparkle (.1311 against TAA 1/2 + bicubic's .1308); with 8 it passes.
  // The cap 24 (alpha ~ 1/60 at 2x) tied with 8 and 64 (TaauScene thin .0620 / .0616).
  bool confidence = true;
  float confident_max_weight = 24.0f;
  float confidence_box_sigma = 8.0f;
  // Motion (output px/frame) at which trust reaches 0: TAA's confidence_motion_px in output
  // pixels, converted to input pixels for the pre-pass.
  float confidence_motion_px = 0.5f;

  // --- History at output resolution ---
  taa::HistorySampler history = taa::HistorySampler::CatmullRom5;
  bool anti_ringing = true;
  taa::VelocityDilation dilation = taa::VelocityDilation::ClosestDepthBox9;

  // --- Rectification against the low-resolution 3x3 neighbourhood (taa/taa_kernels.h) ---
  taa::Rectify rectify = taa::Rectify::ClipFiltered;
  taa::BoxShape box = taa::BoxShape::Variance;
  float variance_gamma = 1.0f;
  bool variance_intersect_minmax = true;
  bool variance_include_filtered = true;
  taa::ColorSpace color_space = taa::ColorSpace::YCoCg;

  static const ParamTable<TaauSettings>& params();

  void set(const std::string& key, const std::string& value);
  void set_assignment(const std::string& assignment);
  std::string get(const std::string& key) const;
  void validate() const;  // SettingsError naming the first bad field
  std::string to_json() const;
  std::string describe() const;

  // The TAA settings whose rectification fields are these (for taa::rectify_history).
  taa::TaaSettings rectification() const;

  // Output size for an input of in_w x in_h: the explicit size, else round(in * scale).
  // Throws InputError when the output is smaller than the input or more than 4x larger on an
  // axis (the range TAAU is made for).
  std::pair<int, int> output_size(int in_w, int in_h) const;

  bool operator==(const TaauSettings&) const = default;
};

const char* to_string(SplatKernel k);

// Presets: FSR2's quality modes by their per-axis scale.
struct PresetInfo {
  const char* name;
  const char* citation;
  TaauSettings (*make)();
};
const std::vector<PresetInfo>& taau_presets();  // performance (the default, 2x) first
std::vector<std::string> preset_names();
TaauSettings make_preset(const std::string& name);  // SettingsError for unknown names

// `--upscale` argument: a preset name, a scale ("1.8") or an output size ("1920x1080"), as a
// method spec "taau:<preset>[+scale=S | +output_width=W+output_height=H]". Throws
// SettingsError for anything else (non-finite, scale outside [1, 4], malformed size).
std::string upscale_spec(const std::string& arg);

}  // namespace afterimage::taau
