// `afterimage demo`, the main job: render the built-in scenes with their references (cached
// between runs), run no-AA, SSAA and every TAA preset, score all against the references and
// write a report (+ an MP4 of no-AA | TAA | reference when ffmpeg is present).
#pragma once

#include <string>
#include <vector>

#include "core/parallel.h"
#include "eval/evaluate.h"
#include "frame/frame.h"
#include "metrics/metrics.h"

namespace afterimage {

struct DemoSettings {
  std::string out_dir = "out/demo";
  int width = 320, height = 180;  // default size keeps the whole demo within minutes on 2 cores
  int frames = 48;
  // Built-in scene names; empty = the registry's default demo scenes (in_default_demo).
  std::vector<std::string> scenes;
  std::vector<std::string> scene_list() const;  // scenes, or the registry's defaults
  int reference_spp = 64;                       // ground truth: 8x8 stratified samples per pixel
  // The reference of the warm-up frames (t < warmup), which only the per-frame plots read
  // (every mean starts at frame warmup; the temporal error's first pair is warmup, warmup + 1):
  // fewer samples there leave every table value as it was; a cold demo traces ~19% fewer
  // samples (16 of 48 frames at 16 instead of 64, of 86 per frame with the SSAA passes).
  int warmup_reference_spp = 16;
  std::vector<int> ssaa = {4, 16};  // SSAA baselines (samples per pixel)
  int warmup = 16;                  // frames excluded from the means
  // Methods to run (run/methods.h specs, e.g. "taa:hdrp"); empty = the registry's
  // demo list (every published TAA preset). A spec may override settings:
  // "taa:variance+variance_gamma=1.25+history=catmull_rom_9".
  std::vector<std::string> methods;
  // TAAU section (issue 10): the scenes rendered at 1 / taau_scale per axis, upsampled by
  // these methods (empty: the registry's default TAAU variant) and by bicubic / Lanczos-3
  // upscaling of low-resolution no-AA and TAA, beside native TAA. taau_scale 0: no section.
  float taau_scale = 2.0f;
  std::vector<std::string> taau_methods;
  // Reprojection section (issue 13): the shading cache on these scenes (rendered with soft
  // shadows; empty: no cache rows), cache_frames frames each.
  std::vector<std::string> cache_scenes = {"penumbra"};
  int cache_frames = 32;
  // ... and forward reprojection (extrapolate / interpolate every other frame) on these.
  std::vector<std::string> extrapolate_scenes = {"motion", "orbit"};
  // Camera-effect sections (issue 12): "STAGE:SCENE", the post pass against the ray-traced
  // effect, effect_frames frames at effect_spp samples per pixel.
  std::vector<std::string> effect_sections = {"dof:focus", "dof:bokeh", "motion_blur:motion"};
  int effect_frames = 4, effect_spp = 16;
  // Light-effects section (issue 12): bloom (scored against its FFT reference), lens flare and
  // glare (images and ms/frame) on these scenes' references, light_frames frames at effect_spp.
  std::vector<std::string> light_scenes = {"sparkle"};
  int light_frames = 2;
  // Denoising section (issue 11): these path-traced scenes at denoise_width x denoise_height,
  // denoise_frames frames, references at denoise_spp samples per pixel (14: room_light's lamp
  // switches on at frame 6, and the lag line needs 8 frames after it).
  std::vector<std::string> denoise_scenes = {"room", "room_light"};
  int denoise_width = 96, denoise_height = 54, denoise_frames = 14, denoise_spp = 256;
  bool video = true;  // MP4 if ffmpeg is on PATH
  // "" (none), exr, png or jpg: also write the frames of every row of each scene's main table,
  // and its reference, to out_dir/frames/SCENE/ROW/frame.NNNN.EXT (PNG / JPEG: the metrics'
  // display transform, so `eval` scores them as the table does).
  std::string frames_format;
  std::string command_line;
  void validate() const;                              // throws SettingsError
  std::vector<std::string> method_list() const;       // methods, or the default list
  std::vector<std::string> taau_method_list() const;  // taau_methods, or the default
};

// A rendered scene sequence: jittered G-buffer frames and color-only companions.
struct SceneSequence {
  std::vector<Frame> gbuffer;     // jittered G-buffer (TAA input)
  std::vector<ImageF> reference;  // reference_spp
  // spp -> frames (spp 1 = no-AA); SSAA rows (spp > 1) are empty before ssaa_first_frame.
  std::vector<std::pair<int, std::vector<ImageF>>> ssaa;
};

// The first frame the demo renders at SSAA n: no-AA every frame (the video shows it), more
// samples from the end of the warm-up, since no mean reads the warm-up frames (by default 16
// frames x 20 samples, ~10% of a scene's ~3 300 sample-frames).
int ssaa_first_frame(int n, const DemoSettings& s);

// Loads the cached sequence for (scene, settings) or renders and caches it.
SceneSequence load_or_render_scene(const std::string& scene, const DemoSettings& s, const Exec& ex);

// The low-resolution renders TAAU reads: G-buffer at round(size / scale) with Halton
// ceil(8 scale^2) jitter, and no-AA (one sample at each pixel center) at the same size.
struct LowResSequence {
  float scale = 2.0f;
  std::vector<Frame> gbuffer;
  std::vector<ImageF> noaa;
};
LowResSequence render_low_res(const std::string& scene, int width, int height, int frames,
                              float scale, const Exec& ex);
// Cached beside the scene's native renders (s.taau_scale).
LowResSequence load_or_render_low_res(const std::string& scene, const DemoSettings& s,
                                      const Exec& ex);

// The TAAU table of one scene, each row scored against the native `reference`: bicubic
// (Catmull-Rom) and Lanczos-3 upscaling of low-resolution no-AA and of low-resolution TAA
// (`taa_spec`), native TAA (`taa_spec` on `native_gbuffer`, skipped if that is empty), then
// every TAAU spec. `native_gbuffer` also gives the ghosting masks (none if empty).
std::vector<MethodEvaluation> evaluate_upscaling(
    const LowResSequence& low, const std::vector<Frame>& native_gbuffer,
    const std::vector<ImageF>& reference, const std::vector<std::string>& taau_specs,
    const std::string& taa_spec, const metrics::MetricsSettings& ms, const Exec& ex);

// "taau:performance+scale=S" for the section's scale S... : the default TAAU rows.
std::vector<std::string> default_taau_demo_methods(float scale = 2.0f);

// Runs everything; prints the tables; returns the report path.
std::string run_demo(const DemoSettings& s, const Exec& ex);

}  // namespace afterimage
