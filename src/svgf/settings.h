// Settings of SVGF (Schied, Kaplanyan, Wyman, Patney, Chaitanya, Burgess, Liu, Dachsbacher,
// Lefohn, Salvi, "Spatiotemporal Variance-Guided Filtering: Real-Time Reconstruction for
// Path-Traced Global Illumination", HPG 2017): a plain struct registered in the parameter table
// (core/params.h; DESIGN.md §2) and the preset registry {name, citation, make}.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/params.h"

namespace afterimage::svgf {

// Which illumination signals are filtered (each with its own history, moments, variance and
// à-trous): the paper filters direct and indirect illumination separately, NRD diffuse and
// specular; which one wins is to be measured (issue 11).
enum class Split : uint8_t {
  Auto,             // the first of direct_indirect, diffuse_specular the frame has, else combined
  Combined,         // one signal: (color - emission) / max(albedo, eps)
  DiffuseSpecular,  // diffuse (demodulated by the renderer) and specular (radiance)
  DirectIndirect,   // direct / max(albedo, eps) and indirect / max(albedo, eps) (the paper)
};

// The à-trous kernel h: the paper's 5x5 B3 spline, or the 3x3 linear B-spline (9 taps per
// iteration instead of 25; speed, beyond the paper; svgf_kernels.h atrous_weight).
enum class AtrousKernel : uint8_t { B3_5x5, Linear3x3 };

// Every member is registered in SvgfSettings::params() (settings.cpp); its default is the
// paper's value where the paper gives one.
struct SvgfSettings {
  Split split = Split::Auto;
  // Demodulation floor: illumination = radiance / max(albedo, eps) per channel, remodulated by
  // the same factor, so black texels round-trip exactly.
  float albedo_epsilon = 1e-3f;

  // Temporal accumulation (Sec. 4.1): alpha = max(alpha_min, 1 / (n + 1)) with n the history
  // length reprojected from the previous frame (seed 001, section 2.3, explains why not this
  // pixel's own).
  float alpha_min = 0.2f;          // color (paper: alpha = 0.2)
  float moments_alpha_min = 0.2f;  // luminance moments (paper: the same alpha)
  int history_cap = 32;            // frames counted in the history length n

  // Consistency of each 2x2 reprojection tap (Sec. 4.1: depth, normal, object id); the paper
  // states no thresholds.
  float depth_tolerance = 0.01f;  // relative: |d_prev - d| <= tol * d + slope term
  float depth_slope = 2.0f;       // times |grad d| (depth per pixel) times the tap distance
  float normal_cos = 0.9f;        // minimum dot(n_prev, n) of a tap (about 26 degrees)
  bool id_test = true;            // object ids must match (when the frames carry ids)

  // Variance estimation (Sec. 4.2): temporal mu2 - mu1^2 once the history holds this many
  // frames, before that a spatial estimate over a (2r + 1)^2 depth/normal-weighted window.
  int temporal_variance_frames = 4;
  int spatial_radius = 3;  // 7x7

  // Edge-avoiding à-trous wavelet (Sec. 4.3, seed 001 Eq.二.1-二.4).
  int iterations = 5;
  AtrousKernel atrous_kernel = AtrousKernel::B3_5x5;
  float sigma_z = 1.0f;  // depth: exp(-|z_p - z_q| / (sigma_z |grad z . (p - q)| + eps))
  int sigma_n = 128;     // normal: max(0, n_p . n_q)^sigma_n
  // Speed, beyond the paper: the normal weight as exp(-sigma_n (1 - n_p . n_q)), folded with
  // the kernel weight into the one exp of the depth and luminance terms (svgf_kernels.h
  // normal_exponent; à-trous and spatial variance). settings.cpp gives its measurements.
  bool normal_exp = false;
  float sigma_l = 4.0f;  // luminance: exp(-|l_p - l_q| / (sigma_l sqrt(g3x3(Var)) + eps))
  // The paper's eps of the depth term, relative to the pixel's depth (it gives no value): a
  // fronto-parallel surface has no depth gradient, so its rounding noise alone must not stop.
  float depth_epsilon = 1e-4f;

  // History quality options beyond the paper (issue 11; history_clamp.h; all off in svgf-paper,
  // settings.cpp gives the measurements behind the afterimage preset's choice).
  // Fast-history clamp (ReLAX): the long history clamped to mean +- sigma * stddev of a short
  // history (alpha = max(fast_alpha_min, 1/(n+1))) over a (2r + 1)^2 window before blending.
  bool fast_history_clamp = false;
  float fast_alpha_min = 0.5f;
  float fast_clamp_sigma = 2.0f;
  int fast_clamp_radius = 1;
  // Firefly clamp: the demodulated input's luminance to the k-th largest of its 8 neighbours'
  // (chroma kept); 0 = off.
  int firefly_rank = 0;
  // Accumulation in seconds (0 = use the frame-based alpha_min, moments_alpha_min,
  // history_cap): alpha = 1 - exp(-dt / tau), cap = round(T / dt) frames, dt the frames' time
  // step, else 1 / fallback_fps.
  float alpha_seconds = 0.0f;
  float moments_alpha_seconds = 0.0f;
  float history_cap_seconds = 0.0f;
  float fallback_fps = 30.0f;
  // A-SVGF temporal gradients (Schied, Peters, Dachsbacher, HPG 2018; gradient.h): where the
  // frame carries the `gradient` channel (render --gradients), alpha' = (1 - lambda) alpha +
  // lambda for color and moments, lambda the reconstructed normalised change. Without that
  // channel nothing changes (plain SVGF).
  bool temporal_gradient = false;
  int gradient_iterations = 3;  // à-trous passes over the 3x3 strata
  // lambda = min(1, gradient_scale |delta| / max): 1 is the paper's normalisation; larger
  // values react fully to smaller relative changes (a sensitivity, as Q2RTX's anti-lag scale).
  float gradient_scale = 1.0f;
  bool gradient_shorten_history = true;  // history length n -> (1 - lambda) n as well
  // Beyond the paper: before the blend, scale the reprojected history (color and moments) by
  // the reconstructed luminance ratio now / prev (gradient.h gradient_relight).
  bool gradient_relight = false;

  static const ParamTable<SvgfSettings>& params();
  void set_assignment(const std::string& assignment);  // "key=value"
  void validate() const;                               // SettingsError naming the field
  std::string describe() const;
  std::string to_json() const;
  bool operator==(const SvgfSettings&) const = default;
};

const char* to_string(Split s);
const char* to_string(AtrousKernel k);

// The paper's defaults (the struct's defaults).
SvgfSettings preset_svgf_paper();
// Our default, measured with TAA after it (`afterimage denoise`'s default): settings.cpp gives
// the tuning and validation figures.
SvgfSettings preset_afterimage();

struct PresetInfo {
  const char* name;      // as accepted by --preset / make_preset
  const char* citation;  // one line
  SvgfSettings (*make)();
};
// Every preset, default (afterimage) first.
const std::vector<PresetInfo>& svgf_presets();
std::vector<std::string> preset_names();
SvgfSettings make_preset(const std::string& name);  // SettingsError for unknown names

}  // namespace afterimage::svgf
