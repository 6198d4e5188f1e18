// Settings of the temporal resolver (DESIGN.md §2: a plain struct registered in the
// parameter table of core/params.h — every field has a default, a range and a one-line doc —
// validate(), and a key/value interface that rejects unknown keys: Halide's GeneratorParam /
// pbrt's ReportUnused habit).
//
// Defaults are the plain exponential accumulator of seed 000 Eq.2 (alpha 0.1, bilinear
// history, no rectification); named presets (taa/presets.h) switch techniques on.
#pragma once

#include <string>
#include <vector>

#include "core/params.h"

namespace afterimage::taa {

// How the history buffer is resampled at p + motion (seed 000 "模糊处理", seed 003
// "History Filter").
enum class HistorySampler {
  Bilinear,     // 4 taps; blurs a little every frame, and the blur accumulates
  CatmullRom5,  // Activision (Filmic SMAA, 2016): 5 bilinear taps, corners dropped
  CatmullRom9,  // MJP's 9 bilinear taps: exact Catmull-Rom away from borders
  Bicubic16,    // full 16-tap Catmull-Rom: the reference the cheaper ones approximate
};

// Which motion vector a pixel uses (seed 002 "Motion Vector的膨胀", seed 003 "Depth
// Dilation" / "Magnitude Dilation").
enum class VelocityDilation {
  None,                // the pixel's own motion
  ClosestDepthCross5,  // motion of the closest-depth pixel of the 5-pixel cross (UE4)
  ClosestDepthBox9,    // motion of the closest-depth pixel of the 3x3 box (INSIDE)
  LargestMotion,       // motion of largest magnitude in the 3x3 box
};

// How a history color outside the neighbourhood's color volume is brought back
// (seed 000 "重影", seed 003 "Color Rejection/Rectification").
enum class Rectify {
  None,          // keep history as sampled (ghosts persist; for tests and reference)
  Clamp,         // per-channel clamp to the AABB
  ClipCenter,    // Playdead clip_aabb: along the line to the AABB center
  ClipFiltered,  // UE4 ClipToFiltered: along the line to the filtered current color
  ConvexHull,    // clip along the line to the filtered color onto the convex hull of the
                 // neighbourhood colors (seed 000 Fig.8(b), seed 003 Fig.14)
};

// How the AABB is built from the neighbourhood samples.
enum class BoxShape {
  MinMax,    // per-channel min / max of the samples
  Variance,  // Salvi 2016 variance clipping: mu +- gamma * sigma (seed 000 Eq.16)
};

// Which current-frame pixels form the neighbourhood.
enum class Neighborhood {
  Cross5,   // center + 4 edge neighbours
  Box9,     // 3x3
  Rounded,  // INSIDE: average of the cross5 and box9 min/max boxes ("rounded" 3x3)
};

enum class ColorSpace { Rgb, YCoCg };

// Spatial filter of the current frame's 3x3 neighbourhood, weighted by each sample's actual
// (jittered) distance to the pixel center (seed 003 "Filter Current Color").
enum class CurrentFilter {
  None,               // the center sample
  Gaussian,           // exp(-r^2 / (2 sigma^2))
  BlackmanHarris,     // exp(-2.29 r^2): UE4 / HDRP Gaussian fit of a 3.3-wide Blackman-Harris
  MitchellNetravali,  // separable Mitchell-Netravali cubic, B = C = 1/3 (negative lobes)
};

// What a failed geometry test does to the history weight (seed 003 "Geometry Rejection").
enum class Rejection {
  Off,     // test not performed
  Reset,   // history weight 0 (sample count restarts at 1)
  Reduce,  // history weight multiplied by reject_keep
};

// Every member is registered in TaaSettings::params() (settings.cpp), the one place its key,
// range and one-line doc are spelled; its default is the initializer below. `afterimage
// resolve --list-settings` prints them all, and the README table is generated from them.
struct TaaSettings {
  // --- Accumulation (seed 000 Eq.1-3) ---
  // Blend factor of the current frame in s_t = alpha x_t + (1 - alpha) s_{t-1} (Eq.2) when
  // sample_count is off.
  float alpha = 0.1f;
  // With sample_count: the floor of alpha = max(alpha_min, 1/N), i.e. the steady state the
  // box average (Eq.1) turns into the exponential filter (Eq.3).
  float alpha_min = 0.05f;
  // Per-pixel sample count N: a fresh pixel averages its first frames with equal weights
  // (Eq.1 box filter) instead of converging exponentially.
  bool sample_count = false;
  // Point-sampled history (HLSL Load, seed 000 static scene): no resampling blur at all;
  // exact for static scenes, nearest-pixel reprojection otherwise.
  bool static_mode = false;

  // --- History sampling ---
  HistorySampler history = HistorySampler::Bilinear;
  // Clamp a bicubic history fetch to the min/max of its 2x2 bilinear footprint, removing
  // the ringing (overshoot) of the negative lobes (HDRP ANTI_RINGING).
  bool anti_ringing = false;

  // --- Reprojection ---
  VelocityDilation dilation = VelocityDilation::None;

  // --- Rectification ---
  Rectify rectify = Rectify::None;
  BoxShape box = BoxShape::MinMax;
  // gamma of mu +- gamma sigma; NVIDIA suggests [0.75, 1.25].
  float variance_gamma = 1.0f;
  // Intersect the variance box with the min/max box (Salvi 2016).
  bool variance_intersect_minmax = false;
  // Grow the variance box to contain the filtered color (UE4).
  bool variance_include_filtered = false;
  // Smallest half-extent of the box in the chroma channels, relative to the luma of the
  // filtered color (taa_kernels.h box_with_floor); 0 in the published presets, which have none. A
  // box that is flat in a channel (grey content has Co = Cg = 0 in all nine samples) turns a
  // rounding-sized deviation of the history in that channel into a full clip toward the
  // filtered color: one pixel changed by 0.001 changed its neighbours by 0.07 the next frame.
  float box_floor = 0.0f;
  Neighborhood neighborhood = Neighborhood::Box9;
  ColorSpace color_space = ColorSpace::Rgb;

  // --- Geometry rejection (seed 003), tested against the 2x2 footprint at p + motion: the
  // test passes if any of the four previous pixels matches (edges are not falsely rejected).
  Rejection depth_reject = Rejection::Off;  // previous vs current linear depth
  // Relative depth tolerance |d_prev - d| <= tol * d.
  float depth_tolerance = 0.05f;
  Rejection id_reject = Rejection::Off;        // object id mismatch (U4 stencil rejection)
  Rejection velocity_reject = Rejection::Off;  // previous motion there vs current motion
  // Motion difference in pixels above which the velocity test fails.
  float velocity_tolerance = 2.0f;
  // History weight kept by a Reduce rejection.
  float reject_keep = 0.25f;

  // --- Flicker control ---
  // Karis luma weighting 1/(1+L) of current and history in the blend (seed 003 "Luma
  // Weighted Exponential Blending").
  bool luma_weight = false;
  CurrentFilter current_filter = CurrentFilter::None;
  // Gaussian sigma in pixels (seed 003 uses ~0.5-0.6).
  float filter_sigma = 0.5f;
  // Multiply each filter weight by 1/(1+L) of its sample (seed 003 GaussianFilterMiddleColor).
  bool filter_luma_weight = false;
  // Fresh history (with sample_count): where the history holds few frames the color shown
  // (not the history stored) blends a wider Gaussian (sigma px; 0 = off), handing over to the
  // current filter linearly as the frames kept reach fresh_filter_frames (taa_kernels.h
  // fresh_filter_handover).
  float fresh_filter_sigma = 0.0f;
  float fresh_filter_frames = 4.0f;
  // Blend the filtered current color (UE4) rather than the raw center sample; the filtered
  // color is always the clip target.
  bool blend_filtered = true;
  // Velocity-weighted alpha (seed 003 ①; UE4): alpha = lerp(alpha, velocity_alpha_max,
  // saturate(|v| / velocity_alpha_px)); UE4 reaches the maximum at 40 px/frame.
  bool adaptive_velocity = false;
  float velocity_alpha_max = 0.2f;
  float velocity_alpha_px = 40.0f;
  // Depth-weighted alpha (seed 003 ②): farther -> smaller alpha, alpha = lerp(depth_alpha_far,
  // alpha, sqrt(saturate(depth_alpha_distance / d))) with d in scene units; sky keeps alpha.
  bool adaptive_depth = false;
  float depth_alpha_far = 0.025f;  // the seed's value
  float depth_alpha_distance = 10.0f;
  // Karis 2014: reduce alpha when history is near the clamp box surface, alpha scaled by
  // lerp(clamp_alpha_scale, 1, saturate(distance / half extent)) along luma.
  bool adaptive_clamp_distance = false;
  float clamp_alpha_scale = 0.5f;
  // INSIDE (Playdead 2016): history feedback = lerp(luma_feedback_min, luma_feedback_max,
  // (1 - |L_c - L_h| / max(L_c, L_h, 0.2))^2), alpha = 1 - feedback; validate() requires
  // luma_feedback_min <= luma_feedback_max.
  bool adaptive_luma_difference = false;
  float luma_feedback_min = 0.88f;
  float luma_feedback_max = 0.97f;

  // --- History confidence (issue 10; taa_kernels.h "History confidence") ---
  // Per pixel c in [0, 1] from the sample's distance to the pixel's temporal luma
  // distribution (z score) and from motion. c widens the rectification box by
  // c * confidence_box_sigma temporal sigmas, lowers the alpha floor from alpha_min (or alpha)
  // toward confident_alpha_min, and, at rest, overrides failed depth / id tests (seed 003 ①: depth
  // that changes at zero velocity is aliasing), fading out by confidence_geometry_px.
  // On in the afterimage preset (with blend_filtered and box_floor; presets.cpp gives the
  // measurements), off in the published ones. The rules that withdraw trust (motion at rest,
  // motion memory, whiteness, neighbours, drift) and the nearest-pixel read of the moments were
  // designed on thin, motion, orbit, light, blades, room and room_light, reading their failing
  // pixels one by one; sparkle, moire, cut, penumbra and focus were only scored (the demo's
  // validation set). Static scenes converge past 16x SSAA with it and not without
  // (tests/taa_confidence_test.cpp).
  bool confidence = false;
  float confident_alpha_min = 1.0f / 64.0f;
  float confidence_z_lo = 2.5f;  // z below which the history is fully trusted
  float confidence_z_hi = 4.0f;  // z above which it is not trusted at all
  // Motion (px/frame, the 3x3 neighbours' largest, remembered) at which trust reaches 0,
  // linearly. 0.1 until 2026-11-29 kept the history of a slow pan untrusted, so its sub-pixel
  // detail was clipped every frame. Chosen on the tuning scenes (demo 320x180, 48 frames, FLIP
  // thin / motion / orbit / light / blades / room / room_light, sum): 0.1 .0351 .0209 .0177
  // .0257 .0266 .0074 .0140 (.1474); 0.25 .1438; 0.5 .0307 .0206 .0178 .0257 .0269 .0078 .0143
  // (.1438, temporal error lower on thin / motion / room); 1 .1450 (blades .0279). The lever
  // was found on a validation scene (sparkle's temporal error map: its slow camera, ~0.2
  // px/frame, left the glints untrusted), so the held-out figures (presets.cpp) are less
  // independent than before. TAAU reads this value in output pixels.
  float confidence_motion_px = 0.5f;
  float moments_alpha_min = 1.0f / 16.0f;  // floor of the moments' weight (their memory)
  float confidence_spatial = 1.0f;         // weight of this frame's 3x3 luma sigma in the spread
  float confidence_box_sigma = 2.0f;       // box widened by this many temporal sigmas x c
  float confidence_rel_floor = 0.02f;      // spread floor relative to the mean luma
  float confidence_abs_floor = 1e-3f;      // absolute spread floor (linear luma)
  // Motion (px/frame) below which confidence overrides failed depth / id tests, fading
  // linearly to 0 at this speed (seed 003 ①: "at zero velocity"), in this frame and at the
  // history's position in the previous one (what a moving blade uncovers is still, but its
  // history held the blade).
  float confidence_geometry_px = 0.5f;
  // Von Neumann ratio (successive-difference over about-the-mean luma variance) below which the
  // pixel's variation is a coherent change, not aliasing (no confidence), and above which it
  // counts fully as aliasing (taa_kernels.h temporal_whiteness).
  float confidence_white_lo = 0.5f;
  float confidence_white_hi = 0.9f;
  // The motion that withdraws trust is the largest speed among the 3x3 neighbours, remembered
  // with this per-frame decay: the still background beside a swaying blade stays distrusted for
  // a few frames after the blade has passed (its history holds the blade).
  float confidence_motion_memory = 0.8f;
  // A change seen by a neighbour in its own statistics (at rest) withdraws the trust too: the
  // flat interior of a blinking panel sees the switch at once, its edge pixels cannot. The
  // largest of the 8 neighbours' z scores (without the spatial term) is mapped to 1 below
  // this value and 0 above twice it; 0 turns the rule off.
  float confidence_neighbor_z = 6.0f;
  // A neighbourhood whose samples trend away from their means is not trusted: the sum of the
  // 3x3 pixels' drifts (running means of x - mean, weight at least confidence_drift_alpha;
  // taa_kernels.h update_luma_moments) over the sum of their spreads (drift_spread); full trust
  // below this z, none above twice it; 0 turns the rule off. A light ramping over a still floor
  // moves every pixel's mean the same way, while aliasing's drifts cancel. One pixel's own drift
  // is too noisy under Halton jitter: at 0.5 it cost static moire 0.9 dB. Measured on the
  // tuning scenes (demo, FLIP thin / motion / orbit / light / blades / room / room_light, box
  // floor 0.001): off .0346/.0211/.0177/.0289/.0267/.0078/.0143 (sum .1511); 0.1 .1481; 0.2
  // .0351/.0209/.0177/.0257/.0266/.0074/.0140 (.1474); 0.3 .1480. Static convergence is unchanged
  // down to 0.2 (render --static 128x72, 64 frames, PSNR of x / (1 + x) at frame 63 against the
  // 64-spp reference, rule off -> 0.2: moire 34.43 -> 34.42 dB, thin 33.87 -> 33.84).
  float confidence_drift_z = 0.2f;
  float confidence_drift_alpha = 0.125f;

  // --- Temporal change (issue 11; A-SVGF, Schied et al. 2018 Sec. 5) ---
  // Where the input frame carries the temporal_change channel (lambda in [0, 1], written by
  // SVGF with temporal gradients), the blend factor becomes alpha' = (1 - l) alpha + l with
  // l = min(1, temporal_change * lambda): the denoiser's measured change of the shading resets
  // TAA's history too, which motion and rectification cannot see at zero motion. 0 ignores
  // the channel; without the channel the resolve is unchanged (bit for bit).
  // Measured with `afterimage denoise` after `render --path-trace --gradients --size 96x54
  // --frames 20 --reference 256`, eval --warmup 0, 0 -> 1 (lag: frames after the lamp switch
  // until the display error is within 1.2x steady state; plain SVGF + TAA: 5 on both):
  //   room_light: lag 4 -> 3, FLIP .1153 -> .1115, PSNR 31.14 -> 30.99 dB, SSIM .913 -> .904,
  //     temporal error .0139 -> .0147 (the switch frame passes SVGF's freshly reset output);
  //   room_light --seed 7 (held out): lag 3 -> 3, FLIP .1132 -> .1093, PSNR 31.26 -> 31.12;
  //   room 33.41 -> 33.38 dB, orbit 34.22 -> 34.20 dB (FLIP equal).
  //   Rejected: scale 0.5 (lag stays 4), 2 and 4 (lag 3, PSNR -0.1 / -0.2 dB more), also
  //   shortening the stored sample count by lambda (lag 4), a dead zone on lambda (+0.05 dB),
  //   shrinking the rectification box toward the filtered color by lambda (lag 3, -0.01..-0.05
  //   dB).
  float temporal_change = 1.0f;

  // The parameter table (core/params.h) every function below reads.
  static const ParamTable<TaaSettings>& params();

  // Throws SettingsError for unknown `key` (listing valid keys) or a value out of range.
  void set(const std::string& key, const std::string& value);
  // "key=value"
  void set_assignment(const std::string& assignment);
  // Current value of `key` as text (SettingsError for unknown keys).
  std::string get(const std::string& key) const;
  // Throws SettingsError naming the first field out of range.
  void validate() const;
  // {"alpha": 0.1, "history": "bilinear", ...}
  std::string to_json() const;
  // One line per key: "key = value   default D, range R -- doc" (for --list-settings).
  std::string describe() const;

  bool operator==(const TaaSettings&) const = default;
};

// Every settable key, in declaration order.
std::vector<std::string> setting_keys();

const char* to_string(HistorySampler v);
const char* to_string(VelocityDilation v);
const char* to_string(Rectify v);
const char* to_string(BoxShape v);
const char* to_string(Neighborhood v);
const char* to_string(ColorSpace v);
const char* to_string(CurrentFilter v);
const char* to_string(Rejection v);

}  // namespace afterimage::taa
