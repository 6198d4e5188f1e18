// G-buffer and reference renderers over Embree (DESIGN.md §1 "afterimage render", §3, §4).
//
//  * render_gbuffer: one primary ray per pixel through the jittered sample position
//    (i + 0.5 + jitter.x, j + 0.5 + jitter.y) — what a rasteriser with jittered_projection
//    produces — with direct lighting, linear depth, normals, albedo, ids and motion vectors.
//  * render_reference: the same frame time and shading model with n x n stratified samples
//    per pixel, box filtered over the pixel (ground truth for anti-aliasing; also SSAA n^2).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "camera/camera.h"
#include "core/parallel.h"
#include "frame/frame.h"
#include "render/path_tracer.h"
#include "render/scene.h"
#include "reproject/shading_cache.h"

namespace afterimage::render {

class Accel;

// Called with the fraction of rows done (0..1] from worker threads, serialised by the
// renderer and at most once per percent. Must not throw.
using ProgressFn = std::function<void(double fraction)>;

// Time profile of the shutter (motion blur references): how exposure is weighted over the
// shutter interval. Box: uniform (a global shutter fully open); triangle: rising linearly to
// the middle and falling back (a slow-opening shutter), peak at the frame time.
enum class ShutterProfile { Box, Triangle };
// "box" | "triangle"; SettingsError otherwise.
ShutterProfile parse_shutter_profile(const std::string& name);

// Camera effects of reference frames (issue 12); G-buffer frames ignore them (their channels
// and the reference's depth / normal / albedo / id / motion stay the pinhole, frame-time
// pixel-center sample). A reference with neither effect is the plain one, bit for bit.
struct CameraEffects {
  // Thin-lens rays through frame_lens(scene.camera) (Scene::camera.lens, focal length from the
  // FOV): the pixel's pinhole ray meets view depth focus_distance at the focus point; the ray
  // starts at an aperture sample (camera/aperture.h) of radius thin_lens_ray_radius on the
  // camera's x/y plane and aims at it (PBRT-v3 6.2.3), so a point's blur is
  // circle_of_confusion_px. Needs a perspective camera and lens.f_number > 0.
  bool depth_of_field = false;
  // Shutter angle in degrees: the pixel's samples spread over angle / 360 of the frame interval
  // 1 / fps, CENTERED on the frame time (half before, half after; motion vectors still refer to
  // frame times), clipped to the frame's camera shot. 0 = instantaneous, 360 = a whole frame.
  double shutter_angle_deg = 0.0;
  ShutterProfile shutter_profile = ShutterProfile::Box;
  // Time strata: the frame is rendered as this many sub-frames, each with the scene, camera and
  // BVH at one time (stratum midpoints of the profile's inverse CDF, equal weights) and
  // spp / shutter_samples of each pixel's samples (the accumulation buffer). Must divide spp;
  // 0 = the largest divisor of spp that is <= 64.
  int shutter_samples = 0;
  bool motion_blur() const { return shutter_angle_deg > 0.0; }
  bool any() const { return depth_of_field || motion_blur(); }
  // Throws SettingsError (angle in [0, 360], shutter_samples >= 0).
  void validate() const;
  bool operator==(const CameraEffects&) const = default;
};

// Offset (seconds) from the frame time of time stratum `i` of `strata`: the midpoint u =
// (i + 0.5) / strata through the profile's inverse CDF over the centered shutter interval.
double shutter_time_offset(const CameraEffects& fx, double fps, int i, int strata);

struct RenderSettings {
  int width = 640, height = 360;
  JitterSequence jitter;  // G-buffer sample offsets per frame (default Halton(2,3) x 16)
  uint64_t seed = 1;      // stratified-sample and light-sample random numbers
  // false: sphere lights shadow from their center (hard shadows, as a real-time G-buffer
  // pass would). true: `light_samples` stratified cone samples per shading point (soft).
  // Both passes use the same model, so a reference differs from a G-buffer frame only in
  // spatial sampling.
  bool soft_shadows = false;
  int light_samples = 16;  // perfect square; only with soft_shadows
  ProgressFn progress;     // optional
  // Also write motion_next (p_next - p_curr, pixels, unjittered; zero before a camera cut):
  // forward reprojection splats a frame into the next one with it (issue 13).
  bool motion_next = false;
  // Light samples of a static scene differ frame to frame (animated scenes' always do): the
  // averaging shading cache (issue 13) accumulates independent estimates.
  bool per_frame_light_samples = false;
  // G-buffer frames shade through the reverse reprojection cache (issue 13): only the pixels
  // it chooses run the direct light; frames must then be rendered in order, one SceneRenderer
  // per sequence. Unset: every pixel shaded every frame.
  std::optional<reproject::ShadingCacheSettings> shading_cache;
  // Depth of field / motion blur of reference frames (issue 12); none by default.
  CameraEffects effects;
  // Path tracing (path_tracer.h, issue 11): G-buffer frames are then the noisy path-traced
  // frames with every channel path_tracer.h lists, references path-traced with any spp >= 1.
  // Excludes shading_cache and camera effects.
  std::optional<PathTraceSettings> path_trace;
  // A-SVGF temporal gradients (Schied, Peters, Dachsbacher, HPG 2018, Sec. 3; needs path_trace):
  // noisy frames carry the `gradient` channel (path_tracer.h "Gradient samples").
  bool gradients = false;
  // With gradients: true = the re-traced sample replaces the landing pixel's sample (the paper),
  // false = it only measures the gradient and every pixel keeps its own sample, so the frame's
  // color is bit for bit that of a render without gradients (the same rays either way: the
  // pixel's own path is traced in both). Measured (svgf/settings.cpp): replacing puts a copy of
  // last frame's sample into 1/9 of the pixels and costs the filtered result 0.5-0.65 dB.
  bool gradient_replace = false;
  // Throws SettingsError (size >= 1, light_samples a perfect square >= 1, effects, path_trace,
  // gradients without path_trace).
  void validate() const;
};

// One G-buffer frame rendered through the shading cache.
struct CacheFrameStats {
  int frame = 0;
  reproject::ShadingCacheCounters counters;
  uint64_t shadow_rays = 0;
  double seconds = 0.0;  // the whole G-buffer frame: primary rays, cache, shading
};

struct RenderStats {
  uint64_t primary_rays = 0;
  uint64_t shadow_rays = 0;
  uint64_t bounce_rays = 0;  // path tracing: closest-hit rays after the primary one
  double seconds = 0.0;
  std::vector<CacheFrameStats> cache_frames;  // per G-buffer frame, with a shading cache
  // A-SVGF gradient samples (path_tracer.h, steps 3-4): previous-frame samples forward-
  // projected into a stratum and re-traced, and those accepted (the same surface was hit).
  uint64_t gradient_retraced = 0, gradient_accepted = 0;
  uint64_t rays() const { return primary_rays + shadow_rays + bounce_rays; }
  double rays_per_second() const { return seconds > 0 ? double(rays()) / seconds : 0.0; }
  RenderStats& operator+=(const RenderStats& o) {
    primary_rays += o.primary_rays;
    shadow_rays += o.shadow_rays;
    bounce_rays += o.bounce_rays;
    seconds += o.seconds;
    gradient_retraced += o.gradient_retraced;
    gradient_accepted += o.gradient_accepted;
    cache_frames.insert(cache_frames.end(), o.cache_frames.begin(), o.cache_frames.end());
    return *this;
  }
};

// Frame `frame_index` as a G-buffer, with the scene evaluated at scene.eval_time(frame_index):
// every channel of Frame filled (background: sky color, depth kBackgroundDepth, normal and
// albedo 0, id 0, motion of the view direction at infinity); view / projection (unjittered)
// / jitter = settings.jitter.at(frame_index) / index / time = frame_index / fps set. Motion
// refers to frame_index - 1 (frame 0 and the first frame after a camera cut: to itself, so
// zero); camera_cut = scene.camera_cut_at(frame_index). `stats` (may be null) accumulates.
Frame render_gbuffer(const Scene& scene, int frame_index, const RenderSettings& settings,
                     const Exec& exec, RenderStats* stats = nullptr);

// Reference / SSAA: `spp` = n * n stratified samples per pixel (n >= 1), averaged. Color is
// the converged estimate; depth, normal, albedo, id and motion come from the unjittered
// pixel-center sample; jitter is (0, 0). Deterministic for a given settings.seed; frames of
// a static scene use the same samples, so their references are identical. With
// settings.effects (depth of field, motion blur) every sample also gets a stratified lens
// position and / or a shutter time (CameraEffects); the result is deterministic for any
// thread count.
Frame render_reference(const Scene& scene, int frame_index, int spp, const RenderSettings& settings,
                       const Exec& exec, RenderStats* stats = nullptr);

// Renders frames of one scene with its acceleration structure kept across frames: the mesh
// BVHs are built once, and each frame only refits the top level to the objects' matrices at
// that frame's time. Results are identical to render_gbuffer / render_reference.
class SceneRenderer {
 public:
  // Validates the settings and builds the mesh BVHs. `scene` must outlive the renderer.
  SceneRenderer(const Scene& scene, const RenderSettings& settings, const Exec& exec);
  ~SceneRenderer();
  SceneRenderer(const SceneRenderer&) = delete;
  SceneRenderer& operator=(const SceneRenderer&) = delete;

  // With settings().shading_cache, through the cache (gbuffer_masked + ShadingCache), the
  // frame's color composed from the cache's output; stats then gets a CacheFrameStats.
  Frame gbuffer(int frame_index, RenderStats* stats = nullptr);
  Frame reference(int frame_index, int spp, RenderStats* stats = nullptr);

  // The renderer's shading as a per-pixel function on a subset of pixels (the reverse
  // reprojection shading cache, issue 13). Traces every pixel's primary ray (the G-buffer
  // channels of gbuffer()), calls choose(frame, mask) with a width * height mask of zeros to
  // mark the pixels to shade (nonzero), then computes the direct light — the shadow rays, the
  // expensive term — at those pixels only. In the returned frame `color` holds the cheap part
  // (emission + albedo * ambient, or the sky) and `diffuse` / `specular` the demodulated direct
  // light where shaded (0 elsewhere): compose_shading(color, albedo, diffuse, specular) of a
  // shaded pixel is its gbuffer() color up to float rounding (same random numbers).
  using ShadeMaskFn = std::function<void(const Frame& gbuffer, std::vector<uint8_t>& mask)>;
  Frame gbuffer_masked(int frame_index, const ShadeMaskFn& choose, RenderStats* stats = nullptr);

  // Ground truth of visibility (tests of the shading cache): the object id (0 = sky) and
  // linear view depth of the first surface hit at each pixel-space position (x right, y down,
  // no jitter added) in frame `frame_index`.
  struct SurfaceAt {
    uint32_t id = 0;
    float depth = 0.0f;
  };
  std::vector<SurfaceAt> surfaces_at(int frame_index, const std::vector<Vec2d>& positions);
  // Path tracing only (settings().path_trace): traces each request in frame `frame_index`
  // (its scene, camera and jitter) with the random numbers of another noisy frame's pixel
  // (RetraceRequest, A-SVGF). A request with the traced frame's own key and jittered pixel
  // position returns exactly that pixel of gbuffer(frame_index). Any thread count, same result.
  std::vector<PathPixel> retrace(int frame_index, const std::vector<RetraceRequest>& requests,
                                 RenderStats* stats = nullptr);
  const RenderSettings& settings() const { return settings_; }
  // Size of the next frames rendered (the BVHs do not depend on it): render_sequence renders
  // a low-resolution G-buffer beside full-resolution references (render --render-scale).
  void set_size(int width, int height);
  // Camera effects of the next reference frames (render_sequence: per pass).
  void set_effects(const CameraEffects& effects);
  // Seed of the next frames' random numbers (render_sequence: a pass with its own seed).
  void set_seed(uint64_t seed) { settings_.seed = seed; }
  // Progress of the next frames rendered (see ProgressFn).
  void set_progress(ProgressFn fn) { settings_.progress = std::move(fn); }

 private:
  const Scene& scene_;
  RenderSettings settings_;
  Exec exec_;
  std::unique_ptr<Accel> accel_;
  std::unique_ptr<reproject::ShadingCache> cache_;                      // settings_.shading_cache
  Frame reference_effects(int frame_index, int n, RenderStats* stats);  // settings_.effects
  Frame path_traced(int frame_index, RenderStats* stats);               // settings_.path_trace
  Frame path_reference(int frame_index, int spp, RenderStats* stats);   // settings_.path_trace
  // settings_.gradients: the previous noisy frame (with motion_next) and which of its pixels
  // hold a re-traced sample (those are not picked again).
  Frame path_traced_gradients(int frame_index, RenderStats* stats);
  std::unique_ptr<Frame> prev_noisy_;
  std::vector<uint8_t> prev_replaced_;
  uint64_t prev_seed_ = 0;
};

// color = compose_shading(color, albedo, diffuse, specular) at every pixel (float), then drops
// the diffuse and specular channels: a gbuffer_masked frame made whole.
void compose_frame_shading(Frame& f, const Exec& exec);

// What render_sequence renders per frame: the jittered G-buffer (spp 0) or a reference /
// SSAA frame with spp stratified samples per pixel (a perfect square; with path tracing any
// spp >= 1).
struct RenderPass {
  std::string label;  // for progress lines, e.g. "reference 64 spp"
  int spp = 0;
  int width = 0, height = 0;       // 0: the settings' size
  CameraEffects effects{};         // reference passes: their camera effects (replace the settings')
  std::optional<uint64_t> seed{};  // this pass's random-number seed (unset: the settings')
  // Frames t < early_frames render at early_spp samples per pixel instead, with early_seed
  // when set (the demo's warm-up references, which no mean reads: their own seed keeps them
  // from being the very images of an SSAA pass at the same spp).
  int early_frames = 0, early_spp = 0;
  std::optional<uint64_t> early_seed{};
  int spp_at(int frame) const { return frame < early_frames ? early_spp : spp; }
  // Frames t < first_frame are not rendered in this pass (the demo's SSAA rows, which no mean
  // reads before the warm-up ends).
  int first_frame = 0;
};

// Renders frames [0, frames) of `scene`, every pass per frame (frame-major, one
// SceneRenderer), and hands each frame to sink(frame index, pass index, frame) in that order
// (a pass's frames from its first_frame).
// progress(frame index, pass index, fraction of rows), if given, as ProgressFn.
using SequenceRenderProgress = std::function<void(int, size_t, double)>;
void render_sequence(const Scene& scene, int frames, const std::vector<RenderPass>& passes,
                     const RenderSettings& settings, const Exec& exec,
                     const std::function<void(int, size_t, Frame&&)>& sink,
                     RenderStats* stats = nullptr, const SequenceRenderProgress& progress = {});

// Camera matrices of a frame: unjittered projection and view at the scene's frame time.
struct FrameCamera {
  Mat4 view, projection;
};
FrameCamera frame_camera(const Scene& scene, int frame_index, int width, int height);

// sqrt(spp) if spp is a perfect square >= 1, else throws SettingsError naming `what`.
int samples_per_axis(int spp, const std::string& what);

// Low-resolution size of a render scale S in [1, 4] (render --render-scale, TAAU input):
// round(size / S) per axis, at least 1; and the Halton length FSR2 recommends for it,
// ceil(8 S^2) (more phases cover the finer output grid). SettingsError for S outside [1, 4] or
// not finite.
std::pair<int, int> scaled_render_size(int width, int height, double scale);
int jitter_length_for_scale(double scale);

}  // namespace afterimage::render
