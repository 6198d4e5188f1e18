#include "taa/presets.h"

#include <fmt/format.h>

#include "core/error.h"

namespace afterimage::taa {

TaaSettings preset_none() {
  // Seed 000 Eq.2 with the usual alpha = 0.1 (seed 002 footnote: 10-20% current frame).
  return TaaSettings{};
}

TaaSettings preset_uncharted4() {
  // Xu, "Temporal Antialiasing in Uncharted 4", SIGGRAPH 2016 (seed 000): blend factor 0.05
  // on HDR color, 3x3 min/max AABB, bilinear history; seed 003 ② credits U4 with stencil
  // rejection, which object ids play here. U4's Laplacian post sharpen (seed 000 Eq.5) is
  // the post/sharpen pass (`+sharpen=S` in a method spec), left off so this preset shows the
  // resolve alone.
  TaaSettings s;
  s.alpha = 0.05f;
  s.history = HistorySampler::Bilinear;
  s.rectify = Rectify::Clamp;
  s.box = BoxShape::MinMax;
  s.neighborhood = Neighborhood::Box9;
  s.color_space = ColorSpace::Rgb;
  s.id_reject = Rejection::Reset;
  return s;
}

TaaSettings preset_ue4() {
  // Karis, "High Quality Temporal Supersampling", SIGGRAPH 2014 (seeds 002/003): YCoCg box,
  // clip toward the filtered center color (ClipToFiltered), Blackman-Harris-fit filter of
  // the jittered 3x3, 1/(1+L) weighting, bicubic (Catmull-Rom) history, closest depth of
  // the cross for velocity, alpha 0.04 rising with velocity, lower alpha near clamping.
  TaaSettings s;
  s.alpha = 0.04f;
  s.history = HistorySampler::CatmullRom5;
  s.dilation = VelocityDilation::ClosestDepthCross5;
  s.rectify = Rectify::ClipFiltered;
  s.box = BoxShape::MinMax;
  s.neighborhood = Neighborhood::Box9;
  s.color_space = ColorSpace::YCoCg;
  s.luma_weight = true;
  s.current_filter = CurrentFilter::BlackmanHarris;
  s.blend_filtered = true;
  s.adaptive_velocity = true;
  s.velocity_alpha_max = 0.2f;
  s.velocity_alpha_px = 40.0f;
  s.adaptive_clamp_distance = true;
  s.clamp_alpha_scale = 0.5f;
  return s;
}

TaaSettings preset_inside() {
  // Pedersen, "Temporal Reprojection Anti-Aliasing in INSIDE", GDC 2016, and Playdead's
  // public shader (seed 003): YCoCg, 3x3 "rounded" min/max (average of cross and box),
  // clip_aabb toward the box center, closest-fragment 3x3 velocity, bilinear history,
  // feedback lerp(0.88, 0.97, unbiased luma weight^2). The talk uses Halton(2,3) x 16 jitter.
  TaaSettings s;
  s.history = HistorySampler::Bilinear;
  s.dilation = VelocityDilation::ClosestDepthBox9;
  s.rectify = Rectify::ClipCenter;
  s.box = BoxShape::MinMax;
  s.neighborhood = Neighborhood::Rounded;
  s.color_space = ColorSpace::YCoCg;
  s.adaptive_luma_difference = true;
  s.luma_feedback_min = 0.88f;
  s.luma_feedback_max = 0.97f;
  return s;
}

TaaSettings preset_hdrp() {
  // Unity HDRP TemporalAntialiasing.hlsl (high quality tier; seed 003 links it): variance
  // neighbourhood with gamma 1.5, Blackman-Harris (Gaussian fit) central filtering, clip
  // toward the filtered color, Catmull-Rom history with anti-ringing, closest-depth 3x3
  // velocity, blend factor raised with motion.
  TaaSettings s;
  s.alpha = 0.1f;
  s.history = HistorySampler::CatmullRom5;
  s.anti_ringing = true;
  s.dilation = VelocityDilation::ClosestDepthBox9;
  s.rectify = Rectify::ClipFiltered;
  s.box = BoxShape::Variance;
  s.variance_gamma = 1.5f;
  s.variance_include_filtered = true;
  s.neighborhood = Neighborhood::Box9;
  s.color_space = ColorSpace::YCoCg;
  s.current_filter = CurrentFilter::BlackmanHarris;
  s.blend_filtered = true;
  s.adaptive_velocity = true;
  s.velocity_alpha_max = 0.3f;
  s.velocity_alpha_px = 20.0f;
  return s;
}

TaaSettings preset_variance() {
  // Salvi, "An Excursion in Temporal Supersampling", GDC 2016 (seeds 000/003): box
  // mu +- gamma sigma with gamma = 1, intersected with the min/max box, clipped toward its
  // center (the mean), in YCoCg.
  TaaSettings s;
  s.alpha = 0.1f;
  s.history = HistorySampler::Bilinear;
  s.rectify = Rectify::ClipCenter;
  s.box = BoxShape::Variance;
  s.variance_gamma = 1.0f;
  s.variance_intersect_minmax = true;
  s.neighborhood = Neighborhood::Box9;
  s.color_space = ColorSpace::YCoCg;
  return s;
}

TaaSettings preset_afterimage() {
  // Our default, chosen by measurement: `afterimage demo` (320x180, 48 frames, 64-spp
  // references, means after frame 16) on thin / motion / orbit, ranking by the mean LDR-FLIP
  // over the three scenes, with PSNR, temporal error and ghosting as checks. Coordinate
  // search from the combination below (runs of `afterimage demo --presets
  // "afterimage+key=value..."` on 2026-11-22):
  //   start (luma_weight on, alpha_min 0.08, sigma 0.5): FLIP .0620/.0237/.0193 mean .0350
  //   luma_weight off: thin FLIP .0620 -> .0393 (1/(1+L) darkens the small bright specular,
  //     which the box-filtered reference keeps), motion/orbit +.0007;
  //   alpha_min 0.08 -> 0.125: motion/orbit FLIP -.0015 each, thin +.0006, thin temporal
  //     error .0098 -> .0117 (0.15 trades more flicker for little);
  //   filter_sigma 0.5 -> 0.3 (clip target closer to the center sample): thin -.0007;
  //   final: FLIP .0394/.0215/.0179 mean .0263, PSNR 30.2/36.8/37.6 dB; best published
  //     preset (hdrp) .0389/.0253/.0200 mean .0281, PSNR 29.3/35.0/36.1 dB.
  //   Rejected: sharpen 0.25 (FLIP +.0003..+.0030), variance_gamma 0.75 / 1.25 (thin worse /
  //     motion ghosting .0189 -> .0200), blend_filtered (blur: sharpness 0.38 on thin),
  //     rounded neighbourhood, 16-tap history, adaptive velocity (no change > .0002).
  // Re-measured 2026-11-29, same protocol: blend_filtered at this sigma (0.3) lowers FLIP on all
  //   three tuning scenes (.0394/.0215/.0179 -> .0381/.0211/.0177) and on the held-out ones,
  //   but alone a blended filter sets a blur floor on what still content converges to (static
  //   light, 64 frames: 43.2 -> 41.5 dB; room 38.2 -> 37.8 dB; sharpness on thin 0.82 ->
  //   0.69), the opposite of issue 10's static convergence. With history confidence, which
  //   blends the raw sample where the history is trusted, it is a win without that floor.
  //   current_filter = mitchell_netravali: FLIP .0400/.0223/.0178 here (hdrp with it:
  //   .0389/.0253/.0200 -> .0377/.0242/.0198).
  // History confidence (settings.h, taa_kernels.h), on since 2026-11-29: per-pixel luma
  //   moments tell aliasing from change, and where the history is trusted the box widens, the
  //   alpha floor falls to 1/64 and the raw sample is blended (only where fully trusted, see
  //   below); elsewhere the filtered color (blend_filtered: without confidence it set a blur
  //   floor on still content, above).
  //   Same demo protocol, all twelve scenes, FLIP before (no confidence, no blend_filtered, no
  //   box floor) -> now:
  //     tuning      thin .0394 -> .0351, motion .0215 -> .0209, orbit .0179 -> .0177, light
  //                 .0240 -> .0257, blades .0276 -> .0266, room .0085 -> .0074, room_light
  //                 .0130 -> .0140;
  //     validation  sparkle .1007 -> .0847, moire .0579 -> .0558, cut .0174 -> .0144, penumbra
  //                 .0115 -> .0110, focus .0222 -> .0204 (best anchor on each, hdrp: .0910 /
  //                 .0583 / .0163 / .0127 / .0219; mean .0373 vs .0400, -6.9%: issue 10 asks
  //                 -10%); temporal error lower on every scene (validation mean .00837 against
  //                 ue4's .00741, the lowest anchor: sparkle .0182 vs .0129).
  //   light and room_light lose because the box floor (below) removed an accident that helped
  //   them: see box_floor. Still scenes now converge past 16x SSAA (128x72, 64 frames: thin
  //   34.75 vs 32.45 dB; without confidence 29.82). Cost: about twice the time (`afterimage
  //   bench`, the row afterimage+confidence=false+blend_filtered=false).
  // confidence_motion_px 0.1 -> 0.5 (settings.h, 2026-11-29): trust now fades out over half a
  //   pixel of motion per frame instead of a tenth, so a slow pan keeps its trusted history.
  //   Tuning FLIP sum .1474 -> .1438 (thin .0351 -> .0307; room .0074 -> .0078, blades .0266 ->
  //   .0269). Validation, FLIP (temporal error): sparkle .0847 -> .0631 (.0182 -> .0158), moire
  //   .0558 -> .0505, cut .0144 -> .0140, penumbra .0110 -> .0110, focus .0204 -> .0184; mean
  //   .0314 against hdrp's .0400 (-21%); temporal mean .00748 against ue4's .00741 (1.01x).
  // The raw sample only where the history is fully trusted (2026-11-29; it was blended in
  //   proportion to the confidence): tuning FLIP sum .1438 -> .1424 (room .0078 -> .0072, thin
  //   .0307 -> .0302), temporal error lower on six of seven; see confident_blend_source.
  //   Validation after both changes (cold demo): FLIP sparkle .0631, moire .0503, cut .0138,
  //   penumbra .0110, focus .0181, mean .0313 against hdrp's .0400 (-21.8%); temporal mean
  //   .00744 against ue4's .00741 (1.004x: sparkle .0157 vs .0129).
  // fresh_filter_sigma 0.6 over 4 frames (2026-11-29; taa_kernels.h fresh_filter_handover):
  //   after a reset the 1/N average moved with each jittered sample; the color shown blends a
  //   Gaussian of sigma 0.6 while the history holds fewer than 4 frames. Chosen on the tuning
  //   scenes (FLIP mean / temporal mean over thin, motion, orbit, light, blades, room,
  //   room_light), blended into the history as well at first: off .02035 / .00350; sigma 0.5,
  //   0.6, 0.7 over 4 frames .02023-.02024 / .00345-.00347 (flat; 0.6 the middle), over 2
  //   frames .02028, over 8 .02023-.02031, over 16 .02149; sigma 1 / 1.5 over 8 .02046 /
  //   .02057. Blended into the history, the wide color lingered where trust lowers alpha to
  //   1/64: a cold-started SVGF + TAA (demo denoise, 14 frames) lost 0.7 dB on room (A-SVGF +
  //   TAA 33.29 -> 32.59 dB). Only in the color shown: tuning .02029 / .00347, and that
  //   denoise row 33.47 dB (FLIP .0699 -> .0687; room_light 30.78 -> 31.40 dB). Validation,
  //   FLIP (temporal error), before -> now: sparkle .0631 -> .0630 (.01573 -> .01571), moire
  //   .0503 -> .0503 (.01437 -> .01419), cut .0138 -> .0138 (.00258 -> .00249), penumbra .0110
  //   -> .0110 (.00159 -> .00158), focus .0181 -> .0180 (.00290 -> .00287); FLIP mean .0312
  //   against hdrp's .0400 (-22.0%), temporal mean .00736 against ue4's .00741 (0.993x, the
  //   first time below the best anchor).
  // box_floor 0.001 (settings.h): without a floor the box of grey content is flat in Co and Cg,
  //   and the clip toward the filtered color jumped all the way to it for a history whose chroma
  //   was off by rounding: one input pixel changed by 0.001 changed its neighbours by 0.07 the
  //   next frame (tests/taa_resolver_test.cpp OnePixelChangedSlightlyChangesTheOutputSlightly).
  //   On `light` (a grey floor under a moving white light) that jump happened to follow the
  //   lighting: the floor costs .0240 -> .0258 there without confidence and .0240 -> .0257 with
  //   it (room_light .0132 -> .0140); nothing else moves by more than .0001, and the static
  //   scenes converge to the same dB with or without it (taa_confidence_test, all twelve).
  // Sample-count alpha gives fresh pixels an Eq.1 box average (fast, unbiased convergence)
  // and decays to alpha_min; the filtered color is the clip target, and the blended color is
  // the raw sample only where the history is fully trusted (taa_kernels.h
  // confident_blend_source).
  TaaSettings s;
  s.sample_count = true;
  s.alpha_min = 0.125f;
  s.history = HistorySampler::CatmullRom5;
  s.anti_ringing = true;
  s.dilation = VelocityDilation::ClosestDepthBox9;
  s.rectify = Rectify::ClipFiltered;
  s.box = BoxShape::Variance;
  s.variance_gamma = 1.0f;
  s.variance_intersect_minmax = true;
  s.variance_include_filtered = true;
  s.neighborhood = Neighborhood::Box9;
  s.color_space = ColorSpace::YCoCg;
  s.current_filter = CurrentFilter::Gaussian;
  s.filter_sigma = 0.3f;
  s.fresh_filter_sigma = 0.6f;
  s.fresh_filter_frames = 4.0f;
  s.blend_filtered = true;
  s.confidence = true;
  s.box_floor = 0.001f;
  s.luma_weight = false;
  // Geometry rejection halves the history weight instead of resetting it: sub-pixel
  // geometry (thin poles and wires) fails depth / id tests every few frames, and a reset
  // there leaves a single aliased sample. Measured at 320x180, 32 frames, display PSNR after
  // 8 frames: reset thin 26.0 / motion 36.0 / orbit 36.3 dB; reduce 0.5 28.2 / 36.1 / 37.0;
  // off 28.3 / 35.9 / 36.9 (off ghosts more at age 3-5 on motion).
  s.depth_reject = Rejection::Reduce;
  s.depth_tolerance = 0.05f;
  s.id_reject = Rejection::Reduce;
  s.reject_keep = 0.5f;
  return s;
}

const std::vector<PresetInfo>& taa_presets() {
  // Immutable, so one shared copy is not state.
  static const std::vector<PresetInfo> kPresets{
      {"afterimage", "ours: tuned by measurement on the built-in scenes", preset_afterimage},
      {"none", "plain exponential accumulation (seed 000 Eq.2), no rectification", preset_none},
      {"uncharted4", "Xu, Temporal Antialiasing in Uncharted 4, SIGGRAPH 2016", preset_uncharted4},
      {"ue4", "Karis, High Quality Temporal Supersampling (UE4), SIGGRAPH 2014", preset_ue4},
      {"inside", "Pedersen, Temporal Reprojection Anti-Aliasing in INSIDE, GDC 2016",
       preset_inside},
      {"hdrp", "Unity HDRP TemporalAntialiasing.hlsl (high quality)", preset_hdrp},
      {"variance", "Salvi, An Excursion in Temporal Supersampling, GDC 2016", preset_variance},
  };
  return kPresets;
}

std::vector<std::string> preset_names() {
  std::vector<std::string> names;
  for (const auto& p : taa_presets()) names.emplace_back(p.name);
  return names;
}

TaaSettings make_preset(const std::string& name) {
  for (const auto& p : taa_presets())
    if (name == p.name) return p.make();
  std::string valid;
  for (const auto& n : preset_names()) {
    if (!valid.empty()) valid += ", ";
    valid += n;
  }
  throw SettingsError(fmt::format("unknown taa preset '{}'; valid presets: {}", name, valid));
}

}  // namespace afterimage::taa
