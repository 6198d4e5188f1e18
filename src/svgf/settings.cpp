#include "svgf/settings.h"

#include <fmt/format.h>

namespace afterimage::svgf {

namespace {

constexpr EnumNames<Split, 4> kSplitNames{{{Split::Auto, "auto"},
                                           {Split::Combined, "combined"},
                                           {Split::DiffuseSpecular, "diffuse_specular"},
                                           {Split::DirectIndirect, "direct_indirect"}}};

constexpr EnumNames<AtrousKernel, 2> kKernelNames{
    {{AtrousKernel::B3_5x5, "5x5"}, {AtrousKernel::Linear3x3, "3x3"}}};

ParamTable<SvgfSettings> make_table() {
  using S = SvgfSettings;
  ParamTable<S> t("svgf");
  t.add_enum("split", &S::split, kSplitNames,
             "signals filtered apart: auto (direct_indirect, else diffuse_specular when the "
             "frame has them, else combined), combined ((color - emission) / albedo), "
             "diffuse_specular, direct_indirect");
  t.add_float("albedo_epsilon", &S::albedo_epsilon, 1e-6f, 1.0f,
              "demodulation floor: radiance / max(albedo, eps)");
  t.add_float("alpha_min", &S::alpha_min, 0.001f, 1.0f,
              "color: alpha = max(alpha_min, 1/(n+1)), n reprojected history length");
  t.add_float("moments_alpha_min", &S::moments_alpha_min, 0.001f, 1.0f,
              "luminance moments: alpha = max(moments_alpha_min, 1/(n+1))");
  t.add_int("history_cap", &S::history_cap, 1, 1024, "largest history length n (frames)");
  t.add_float("depth_tolerance", &S::depth_tolerance, 0.0f, 1.0f,
              "reprojection: relative depth difference a tap may have");
  t.add_float("depth_slope", &S::depth_slope, 0.0f, 64.0f,
              "reprojection: extra depth tolerance per pixel of tap distance, times |grad d|");
  t.add_float("normal_cos", &S::normal_cos, -1.0f, 1.0f,
              "reprojection: minimum dot(n_prev, n) of a tap");
  t.add_bool("id_test", &S::id_test, "reprojection: object ids of a tap must match");
  t.add_int("temporal_variance_frames", &S::temporal_variance_frames, 1, 1024,
            "history length from which the temporal variance mu2 - mu1^2 is used");
  t.add_int("spatial_radius", &S::spatial_radius, 1, 8,
            "spatial variance window radius before that (3: 7x7)");
  t.add_int("iterations", &S::iterations, 1, 10, "à-trous iterations (step 2^i)");
  t.add_enum("atrous_kernel", &S::atrous_kernel, kKernelNames,
             "à-trous kernel: 5x5 (the paper's B3 spline, 25 taps) or 3x3 (linear B-spline "
             "(1/4, 1/2, 1/4)^2, 9 taps; speed)");
  t.add_float("sigma_z", &S::sigma_z, 1e-3f, 1e3f, "depth edge-stopping scale");
  t.add_int("sigma_n", &S::sigma_n, 1, 1024, "normal edge-stopping exponent");
  t.add_bool("normal_exp", &S::normal_exp,
             "normal weight exp(-sigma_n (1 - n.n')) in the one exp of the edge-stopping "
             "weights instead of max(0, n.n')^sigma_n (speed)");
  t.add_float("sigma_l", &S::sigma_l, 1e-3f, 1e3f, "luminance edge-stopping scale (of sigma)");
  t.add_float("depth_epsilon", &S::depth_epsilon, 1e-7f, 1.0f,
              "depth edge-stopping eps, relative to the pixel's depth");
  // History quality options (history_clamp.h).
  t.add_bool("fast_history_clamp", &S::fast_history_clamp,
             "clamp the long color history to a fast history's local mean +- sigma stddev box");
  t.add_float("fast_alpha_min", &S::fast_alpha_min, 0.001f, 1.0f,
              "fast history: alpha = max(fast_alpha_min, 1/(n+1))");
  t.add_float("fast_clamp_sigma", &S::fast_clamp_sigma, 0.0f, 1e3f,
              "fast history box: mean +- sigma * stddev");
  t.add_int("fast_clamp_radius", &S::fast_clamp_radius, 0, 4,
            "fast history box window radius (1: 3x3)");
  t.add_int("firefly_rank", &S::firefly_rank, 0, 8,
            "clamp input luminance to the k-th largest of the 8 neighbours (0 = off)");
  t.add_float("alpha_seconds", &S::alpha_seconds, 0.0f, 1e3f,
              "color time constant tau (s): alpha_min = 1 - exp(-dt/tau); 0 = use alpha_min");
  t.add_float("moments_alpha_seconds", &S::moments_alpha_seconds, 0.0f, 1e3f,
              "moments time constant (s); 0 = use moments_alpha_min");
  t.add_float("history_cap_seconds", &S::history_cap_seconds, 0.0f, 1e3f,
              "history cap in seconds: round(T/dt) frames; 0 = use history_cap");
  t.add_float("fallback_fps", &S::fallback_fps, 1.0f, 1000.0f,
              "frame rate for dt when the frames carry no increasing time");
  t.add_bool("temporal_gradient", &S::temporal_gradient,
             "A-SVGF: raise alpha by the reconstructed temporal gradient lambda where the frame "
             "has the gradient channel (render --gradients)");
  t.add_int("gradient_iterations", &S::gradient_iterations, 0, 8,
            "A-SVGF: à-trous iterations reconstructing the gradient over 3x3 strata");
  t.add_float("gradient_scale", &S::gradient_scale, 0.0f, 100.0f,
              "A-SVGF: lambda = min(1, gradient_scale |delta| / max) (1: the paper)");
  t.add_bool("gradient_shorten_history", &S::gradient_shorten_history,
             "A-SVGF: also shorten the history length n to (1 - lambda) n");
  t.add_bool("gradient_relight", &S::gradient_relight,
             "A-SVGF: scale the reprojected history (color, moments) by the reconstructed "
             "luminance ratio now / prev before the blend (beyond the paper)");
  return t;
}

}  // namespace

const ParamTable<SvgfSettings>& SvgfSettings::params() {
  static const ParamTable<SvgfSettings> kTable = make_table();  // immutable
  return kTable;
}
void SvgfSettings::set_assignment(const std::string& assignment) {
  params().set_assignment(*this, assignment);
}
void SvgfSettings::validate() const {
  params().validate(*this);
}
std::string SvgfSettings::describe() const {
  return params().describe(*this);
}
std::string SvgfSettings::to_json() const {
  return params().to_json(*this);
}
const char* to_string(Split s) {
  return enum_name(kSplitNames, s);
}
const char* to_string(AtrousKernel k) {
  return enum_name(kKernelNames, k);
}

SvgfSettings preset_svgf_paper() {
  // Schied et al. 2017: alpha = 0.2 for color and moments, temporal variance from 4 frames on,
  // 7x7 spatial variance before, 5 à-trous iterations with sigma_z = 1, sigma_n = 128,
  // sigma_l = 4 (Sec. 4.1-4.3 and 5).
  return SvgfSettings{};
}

SvgfSettings preset_afterimage() {
  // Chosen for `afterimage denoise`'s default, SVGF followed by the taa default: TAA then does
  // the long temporal accumulation, so SVGF keeps a shorter history (alpha 0.4 for color and
  // moments), stopped harder on luminance (sigma_l 2; 4 again since the 3x3 kernel, below) and
  // blurs less (3 à-trous iterations).
  // Tuned on path-traced room and room_light, validated on motion, orbit and penumbra
  // rendered with --path-trace (96x54, 20 frames, 256-spp references, eval --warmup 0),
  // display PSNR / FLIP / temporal error, svgf-paper + TAA -> this + TAA:
  //   tuning     room        31.41 / .0917 / .0077 -> 33.46 / .0763 / .0089
  //              room_light  28.56 / .1536 / .0139 -> 30.56 / .1296 / .0147
  //   validation motion      33.19 / .0482 / .0077 -> 33.86 / .0476 / .0091
  //              orbit       33.16 / .0359 / .0066 -> 34.22 / .0329 / .0068
  //              penumbra    38.95 / .0360 / .0027 -> 40.62 / .0269 / .0029
  // Each change alone gains less (room: sigma_l 2 32.27, alpha 0.4 32.21, 3 iterations
  // 32.25 dB); the price is 2-19% more temporal error, still far below spatial-only's.
  //
  // The history quality options (history_clamp.h) stay off: none wins on the tuning scenes.
  // Same renders and metrics, this preset + TAA, off -> on (room, room_light | motion, orbit):
  //   fast_history_clamp (fast alpha 0.5, sigma 2, 3x3): 33.46 -> 33.48, 30.56 -> 30.55 |
  //     33.87 -> 33.87, 34.22 -> 34.24 dB, FLIP .0763/.1296|.0476/.0329 -> .0766/.1300|.0479/
  //     .0330, temporal equal: a tie at alpha 0.4, whose short history leaves little to clamp.
  //     sigma 1 / 0.5, fast alpha 0.3 and radius 2 are ties or lose (sigma 1: 33.42, 30.48).
  //     It helps a long history: at alpha 0.2 it gains +0.1..+1.0 dB (sigma 0.5: room 32.83 ->
  //     33.20, room_light 29.47 -> 30.42), still below alpha 0.4 without it; alpha 0.3 + sigma
  //     0.5 + fast alpha 0.3 ties on tuning (33.48, 30.55) and loses on validation (33.79,
  //     34.09). Over 40 frames of room_light (both switches) it gains (30.25 -> 30.43 dB, sigma
  //     0.5: 30.74) while motion over 40 frames ties (33.77).
  //   firefly_rank 1 / 2 / 3: loses everywhere, room 31.61 / 29.01 / 26.46, room_light 28.02 /
  //     25.35 / 22.80, motion 33.31 / 31.01 / 27.39, orbit 34.22 / 33.80 / 32.69 dB, FLIP worse,
  //     and on path-traced sparkle, the firefly scene, 22.59 -> 19.19 (k 1): at 1 spp every
  //     local maximum of the noise is cut, which darkens the result (room frame 19, mean R:
  //     reference .342, off .332, k 1 .321; sparkle -13%).
  //   alpha_seconds = moments_alpha_seconds = 0.06525 (alpha 0.4 at 30 fps), history_cap_seconds
  //     = 32/30: bit-identical at the renderer's 30 fps (eval PSNR inf against off). At 15 fps
  //     (the even frames of 40-frame renders) it gives alpha 0.64 instead of 0.4: room_light
  //     27.55 -> 28.30 dB, motion 31.53 -> 31.34 dB, so it is not the better default either.
  //
  // A-SVGF temporal gradients on (Schied, Peters, Dachsbacher 2018; gradient.h; used only when
  // the frames carry the gradient channel, render --gradients), gradient_scale 2. Measured on
  // frames rendered with --gradients (whose color is that of a plain render; the same input for
  // both rows, only the setting differs), 96x54, 20 frames, 256-spp references, denoise (+ TAA),
  // eval --warmup 0, display PSNR / SSIM / FLIP / temporal error, without -> with gradients:
  //   tuning     room_light     30.56 / .917 / .1296 / .0147 -> 31.14 / .913 / .1153 / .0139
  //   validation room_light -s7 30.65 / .916 / .1273 / .0147 -> 31.26 / .913 / .1132 / .0138
  //              room           33.46 / .940 / .0763 / .0089 -> 33.41 / .939 / .0764 / .0090
  //              orbit          34.22 / .928 / .0329 / .0068 -> 34.22 / .928 / .0329 / .0068
  // Lag after the lamp switches on (frames until the display MSE is within 1.2x its mean over
  // the last 4 frames): room_light 6 -> 4, -s7 5 -> 3. The paper's scale 1 gains less
  // (room_light 30.93, lag 5); 4 a little more on room_light (31.19) but loses more on room
  // (33.39) with more temporal error; gradient_iterations 1 is within 0.02 dB of 3; without
  // shortening the history room_light gets 30.90 and more temporal error. Rays: +10%. With
  // render --gradient-replace (the paper: the re-traced sample replaces the pixel's) the same
  // filter scores 30.60 / 32.79 dB on room_light / room: the copied samples cost 0.5-0.65 dB.
  // History relighting (gradient.h gradient_relight; beyond the paper), measured after the
  // lag of the gradients above stayed at 3 frames with 256-spp references. Why lambda
  // underestimates the lamp: it does not; the sparse samples' mean change matches the
  // references' within its standard error, and lambda / scale is close to the references'
  // normalised change (right half, where the lamp adds 20-30% and the excess error was: 0.18-
  // 0.22 against 0.21-0.33).
  // The paper's rule can only discard: it keeps (1 - lambda)(1 - alpha) of the stale history,
  // which no later gradient sees, and discarding more costs as much 1-spp noise (lambda forced
  // to 1: display error .0191 two frames after the switch, default .0187; scales 4-16 .0176-
  // .0179). Neither the split (split=combined: .0183) nor the moments are the cause. Same
  // renders and pipeline (96x54, 20 frames, 256-spp references, denoise + TAA, eval --warmup 0,
  // PSNR / SSIM / FLIP / temporal error), off -> on:
  //   tuning    room_light     32.081 .9228 .0930 .01265 -> 32.165 .9231 .0902 .01238
  //   held out  room_light -s7 31.960 .9205 .0924 .01272 -> 32.089 .9211 .0879 .01242
  //             room_light 40f 32.398 .9270 .0883 .01205 -> 32.527 .9274 .0853 .01169 (the
  //               lamp also switches off at frame 22: error 1/2 frames after .0160/.0138 ->
  //               .0151/.0137)
  //             room           34.122 .9504 .0659 .00784 -> 34.114 .9503 .0658 .00785
  //             orbit          34.931 .9402 .0305 .00538 -> 34.936 .9402 .0305 .00539
  //             motion         35.141 .9208 .0402 .00653 -> 35.173 .9209 .0402 .00655
  // Display error (lag.py's MAE) at frames 6 / 7 / 8 after the switch: room_light .0323 / .0213
  // / .0187 -> .0284 / .0193 / .0176, -s7 .0327 / .0215 / .0187 -> .0283 / .0189 / .0171. Lag
  // (metrics/temporal.h lag_frames over 20 | the demo's 14 frames; plain SVGF + TAA: 5 | 4):
  // room_light 3 | 3 -> 3 | 2, -s7 3 | 3 -> 2 | 2. What remains is the precision of the factor,
  // reconstructed from one 1-spp sample per 3x3 stratum: a scratch prototype relighting with
  // the references' own per-pixel luminance ratio reaches .0166 at frame 8 (lag 2; their RGB
  // ratio .0165, so the lamp's color matters little), this estimate .0176; more gradient
  // iterations (4, 5) and bilinear factors between strata do not close it (.0176, .0175).
  // The paper's scale 1 with relighting gains on room_light (32.269 dB, SSIM .9272, FLIP .0916)
  // but loses after the switch off (.0173 / .0151) and ties on lag. Relighting TAA's history
  // too (scratch prototype, the factor handed to the resolver) changes nothing (frame 8 .0177).
  SvgfSettings s;
  s.gradient_relight = true;
  s.alpha_min = 0.4f;
  s.moments_alpha_min = 0.4f;
  s.iterations = 3;
  s.temporal_gradient = true;
  s.gradient_scale = 2.0f;
  // Speed: normal_exp (the normal weight exp(-128 (1 - n.n')) and the kernel weight inside the
  // one exp) halves the à-trous CPU time at 1080p (perf task-clock samples, svgf.filter.afterimage
  // 1 thread: 6630 / 6390 -> 3129 / 3034) and the spatial variance's by ~10%. Denoise demo
  // (96x54, 14 frames), PSNR / FLIP without -> with: room svgf 27.7092 / .08981 -> 27.7097 /
  // .08981, A-SVGF + TAA 33.6369 -> 33.6371; room_light svgf 26.7589 -> 26.7595, A-SVGF + TAA
  // 30.9592 -> 30.9599, FLIP within 2e-6 on every row. svgf-paper keeps the paper's power.
  s.normal_exp = true;
  // Speed (issue 11's 50 ms at 1080p on 2 threads), measured not to lose: the 3x3 linear
  // B-spline à-trous kernel (9 taps per iteration instead of 25) with the paper's sigma_l 4
  // (the 3x3 kernel shrinks the variance less per iteration, so the luminance weight may be
  // looser), and the spatial variance over 5x5 instead of 7x7 (only where the history holds < 4
  // frames). 1080p svgf.filter.afterimage, perf task-clock samples on one core: à-trous
  // ~2540 -> ~1360, spatial variance ~440 -> ~255, the filter ~-33%. Quality, rendered with
  // --path-trace --gradients, 256-spp references, denoise (+ TAA), eval --warmup 0, display
  // PSNR / SSIM / FLIP / temporal error, before (5x5, sigma_l 2, 7x7) -> after:
  //   tuning    room 96x54, 14 frames  33.285 .9347 .0764 .00894 -> 33.406 .9400 .0690 .00867
  //             room_light             30.676 .9004 .1129 .01483 -> 31.312 .9118 .0977 .01386
  //   held out  room 192x108, 24       36.251 .9473 .0652 .00750 -> 36.837 .9509 .0535 .00740
  //             room_light             33.130 .9092 .0999 .01285 -> 34.023 .9162 .0833 .01235
  //             motion 96x54, 20       34.665 .9084 .0438 .00771 -> 34.704 .9116 .0409 .00737
  //             orbit                  34.521 .9335 .0315 .00613 -> 34.519 .9338 .0309 .00610
  //             penumbra               40.677 .9741 .0256 .00257 -> 40.887 .9763 .0244 .00251
  // (A-SVGF + TAA rows; svgf + TAA and svgf alone move the same way; sigma_l also scales the
  // A-SVGF gradient reconstruction's luminance weight, gradient.cpp.) Alone: the 3x3 kernel with
  // sigma_l 2 gains PSNR and FLIP but loses SSIM and temporal error (room 96x54: 33.558 .9290
  // .0702 .00946); sigma_l 4 with the 5x5 kernel gains too but less on PSNR and FLIP (room
  // 32.832 .9394 .0753 .00819, room_light 30.988 .9167 .1038 .01295); 2 iterations of the 3x3
  // lose temporal error (room .00953 at sigma_l 4); sigma_l 5 trades PSNR for temporal error
  // (room 33.188, .00853); the 5x5 spatial variance alone ties or gains (room 33.344).
  // Re-measured after the TAA default took its fresh-history filter, same rows, old -> new:
  // room 32.537 -> 32.591, room_light 30.228 -> 30.783, room 192x108 35.957 -> 36.457,
  // room_light 192x108 32.928 -> 33.754, motion 35.189 -> 35.206, penumbra 40.148 -> 40.279 dB
  // with SSIM, FLIP and temporal error better on all six; orbit 34.946 -> 34.917 dB, SSIM
  // .9406 -> .9403, FLIP .0313 -> .0308, temporal .00520 -> .00519.
  s.atrous_kernel = AtrousKernel::Linear3x3;
  s.sigma_l = 4.0f;
  s.spatial_radius = 2;
  return s;
}

const std::vector<PresetInfo>& svgf_presets() {
  static const std::vector<PresetInfo> kPresets{
      {"afterimage",
       "our default, tuned for SVGF followed by TAA (alpha 0.4, 3 iterations of a 3x3 "
       "kernel, 5x5 spatial variance; A-SVGF temporal gradients with scale 2 and history "
       "relighting where the frames carry them)",
       preset_afterimage},
      {"svgf-paper", "Schied et al., HPG 2017: SVGF with the paper's parameters",
       preset_svgf_paper},
  };
  return kPresets;
}

std::vector<std::string> preset_names() {
  std::vector<std::string> names;
  for (const auto& p : svgf_presets()) names.emplace_back(p.name);
  return names;
}

SvgfSettings make_preset(const std::string& name) {
  for (const auto& p : svgf_presets())
    if (name == p.name) return p.make();
  throw SettingsError(fmt::format("unknown svgf preset '{}'; valid presets: {}", name,
                                  fmt::join(preset_names(), ", ")));
}

}  // namespace afterimage::svgf
