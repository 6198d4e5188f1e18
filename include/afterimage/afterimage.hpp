// Afterimage's C++ API (docs/library.md): temporal methods (TAA, TAAU, SVGF) and post stages
// run on frames built from the caller's own buffers, frame extrapolation, image metrics, and
// files to files over rendered sequences. Errors are exceptions (afterimage/errors.hpp) with
// one-line messages. The C API (afterimage/afterimage.h) offers the same operations.
//
// Conventions (docs/DESIGN.md §3): linear scene-referred Rec.709 color, HDR; pixel (0, 0) is
// the top-left; motion = p_prev - p_curr in pixels, y down, unjittered, unless a
// motion_convention says otherwise; depth is linear view depth unless a depth_convention says
// otherwise; jitter in pixels in [-0.5, 0.5], y down.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "afterimage/errors.hpp"
#include "afterimage/export.h"
#include "afterimage/version.h"

namespace afterimage {
inline namespace v0 {

// The library's version ("0.1.0"); AFTERIMAGE_VERSION_STRING is the headers'.
AFTERIMAGE_API const char* version();
// The SIMD target the library was compiled for: "AVX3_ZEN4, 16 float lanes". Outputs of
// another lane width may differ in the last bits; any thread count and `simd = false` do not.
AFTERIMAGE_API std::string simd_target();

// How the library runs: worker threads (0 = all cores) and the SIMD path (false: the 1-lane
// reference path, the same bits).
struct ExecOptions {
  int threads = 0;
  bool simd = true;
};

enum class DataType { f32, f16, u32 };

// The caller's pixels, read or written in place: element (x, y, c) is at
// data + y * row_stride + x * pixel_stride + c * channel_stride bytes. Strides of 0 take the
// packed interleaved layout (pixel_stride = channels * element size, row_stride = width *
// pixel_stride, channel_stride = element size). interleaved() and planar() make the two
// usual layouts; any other is a matter of strides (a row padded to 256 bytes, a plane of a
// larger image).
struct AFTERIMAGE_API BufferView {
  void* data = nullptr;
  DataType type = DataType::f32;
  int width = 0, height = 0, channels = 0;
  std::ptrdiff_t pixel_stride = 0, row_stride = 0, channel_stride = 0;

  bool empty() const { return data == nullptr; }
  static BufferView interleaved(void* data, int width, int height, int channels,
                                DataType type = DataType::f32);
  static BufferView interleaved(const void* data, int width, int height, int channels,
                                DataType type = DataType::f32) {
    return interleaved(const_cast<void*>(data), width, height, channels, type);
  }
  // Channel c is a whole width x height plane at data + c * width * height elements.
  static BufferView planar(void* data, int width, int height, int channels,
                           DataType type = DataType::f32);
  static BufferView planar(const void* data, int width, int height, int channels,
                           DataType type = DataType::f32) {
    return planar(const_cast<void*>(data), width, height, channels, type);
  }
};

// A thin lens (depth of field): f_number 0 is a pinhole.
struct Lens {
  double focal_length_mm = 50.0;
  double f_number = 0.0;
  double focus_distance = 5.0;  // scene units along the view axis
  double sensor_width_mm = 36.0;
  int blades = 0;  // 0 = disc, 3..16 = polygon
  double blade_rotation_deg = 0.0;
};

// The camera and timing of one frame.
struct FrameCamera {
  // World to view and the *unjittered* projection, row-major (m[row * 4 + col]), right-handed
  // view space looking down -Z (docs/DESIGN.md §3). Leave `known` false when the renderer
  // cannot give them: what needs the camera's own motion (motion blur's camera / object split)
  // then refuses the frame.
  float view[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  float projection[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  bool known = false;
  float jitter_x = 0, jitter_y = 0;  // this frame's sample offset, pixels, y down
  int index = 0;                     // frame number
  double time = 0;                   // seconds
  bool cut = false;                  // a camera cut: no history is used across it
  Lens lens;                         // for depth of field
  bool lens_known = false;           // false: the DoF stage takes the lens from its settings
};

// One frame of a renderer's G-buffer, in the caller's buffers (nothing is kept after the call
// that reads it). Only color is required; what a method needs besides (depth and motion for
// TAA, normals and albedo for SVGF, ...) Method::required_channels() says.
struct FrameInput {
  BufferView
      color;  // 3 channels (RGB) or 4 (RGBA: the 4th is coverage alpha unless `alpha` is given)
  BufferView depth;           // 1 channel
  BufferView normal, albedo;  // 3 channels
  BufferView motion;          // 2 channels
  BufferView id;              // 1 channel, u32 (or f32 holding integers)
  BufferView alpha;           // 1 channel, coverage of the premultiplied color
  // Any other channel of the library's table by name ("emission", "variance",
  // "motion_next", "gradient", ...; see channel_names()).
  std::vector<std::pair<std::string, BufferView>> extra;
  // The renderer's conventions, as the CLI's --map takes them: motion "afterimage", "blender",
  // "unity", "unreal", "fsr2[:sx:sy]"; depth "linear", "ray", "hardware[:near:far]",
  // "hardware-reversed[:near:far]" (docs/DESIGN.md §3).
  std::string motion_convention = "afterimage";
  std::string depth_convention = "linear";
  FrameCamera camera;
};

// A temporal method, a post stage or a chain of them, with its own history: hand it the frames
// of one sequence in order.
class AFTERIMAGE_API Method {
 public:
  // `spec`: a method "taa:afterimage", "taa:hdrp", "taau:quality", "svgf:afterimage" (see
  // method_names(); "+key=value" may follow, as in "taa:hdrp+alpha=0.1"), a post stage
  // ("dof", "motion_blur", "bloom", "flare", "tonemap", "sharpen"; see post_stage_names()),
  // or a chain of them, "svgf,taa,bloom,tonemap", run in the order of docs/DESIGN.md §1
  // whatever order it lists them in (`afterimage run --pipeline`). `settings`: "key=value" for
  // a single method, "stage.key=value" for a chain or a post stage. SettingsError names an
  // unknown name or key and an out-of-range value.
  explicit Method(const std::string& spec, const std::vector<std::string>& settings = {},
                  const ExecOptions& exec = {});
  ~Method();
  Method(Method&&) noexcept;
  Method& operator=(Method&&) noexcept;

  std::string name() const;
  // The channels a frame must carry ("color", "depth", "motion", ...): process() refuses a
  // frame without one.
  std::vector<std::string> required_channels() const;
  // The output size for inputs of width x height (larger for TAAU).
  std::pair<int, int> output_size(int width, int height) const;

  // Processes the next frame and writes the output color into `out`: output_size() pixels, 3
  // channels (RGB) or 4 (RGBA: the coverage alpha, 1 where the input had none). InputError for
  // a frame the method cannot use (a missing channel, another size than the frames before, a
  // camera it needs and was not given).
  void process(const FrameInput& frame, const BufferView& out);
  // Forgets the history: the next frame starts a new sequence.
  void reset();
  // Continuation across runs: the state after frame k, loaded into a method of the same spec
  // and settings, continues bit for bit. load_state changes nothing unless the file is valid.
  void save_state(const std::string& path) const;
  void load_state(const std::string& path);
  // Every setting of this instance as JSON, and as lines "key = value  default, range -- doc".
  std::string settings_json() const;
  std::string describe_settings() const;
  void set_exec(const ExecOptions& exec);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Every registered method variant ("taa:afterimage", "taa:hdrp", ..., "taau:quality",
// "svgf:afterimage", ...), every post stage, and every channel name a FrameInput may carry.
AFTERIMAGE_API std::vector<std::string> method_names();
AFTERIMAGE_API std::vector<std::string> post_stage_names();
AFTERIMAGE_API std::vector<std::string> channel_names();
// The settings of a spec (as Method::describe_settings), without keeping a method.
AFTERIMAGE_API std::string describe_settings(const std::string& spec);

// ---- Frame extrapolation (forward reprojection, docs/DESIGN.md §2 reproject/) ----------
// The frame that missed its deadline synthesised from the last rendered frame and the new
// frame's camera (VR's asynchronous reprojection).
class AFTERIMAGE_API Extrapolator {
 public:
  // settings: "fill=background" (default; naive, pushpull, pushpull-background).
  explicit Extrapolator(const std::vector<std::string>& settings = {},
                        const ExecOptions& exec = {});
  ~Extrapolator();
  Extrapolator(Extrapolator&&) noexcept;
  Extrapolator& operator=(Extrapolator&&) noexcept;
  // A rendered frame: color and depth, with a known camera; its motion_next (in `extra`), when
  // given, moves its pixels exactly to the next frame. Copied: the buffers may be reused.
  void set_source(const FrameInput& rendered);
  // The color of a frame `frames_after` frames after the source, seen from `target` (its
  // view, projection and jitter), into `out` (the source's size, 3 channels). Returns the
  // fraction of pixels no source sample reached (filled by the fill).
  double synthesize(const FrameCamera& target, const BufferView& out, int frames_after = 1);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// ---- Metrics on two images (linear HDR color, 3 channels) ------------------------------
// PSNR and SSIM are computed on display values: HDR inputs through the Reinhard tonemap and
// sRGB, LDR inputs (decoded display values in [0, 1]) on their sRGB re-encoding, as
// `afterimage compare` does.
enum class Range { ldr, hdr };
struct PairScores {
  double psnr = 0;             // dB, display RGB, peak 1 (+inf when identical)
  double psnr_linear = 0;      // dB, linear values, peak = the reference's maximum
  double ssim = 0;             // display RGB
  double flip = 0;             // LDR-FLIP for Range::ldr, HDR-FLIP for Range::hdr
  const char* flip_kind = "";  // "LDR-FLIP" or "HDR-FLIP"
};
AFTERIMAGE_API PairScores compare(const BufferView& reference, const BufferView& test,
                                  Range range = Range::hdr, const ExecOptions& exec = {});
AFTERIMAGE_API double psnr(const BufferView& reference, const BufferView& test,
                           Range range = Range::hdr, const ExecOptions& exec = {});
AFTERIMAGE_API double ssim(const BufferView& reference, const BufferView& test,
                           Range range = Range::hdr, const ExecOptions& exec = {});
// LDR-FLIP of display images in [0, 1] (Andersson et al. 2020) at `ppd` pixels per degree
// (<= 0: FLIP's default, 67); HDR-FLIP of linear images over FLIP's automatic exposures.
AFTERIMAGE_API double ldr_flip(const BufferView& reference, const BufferView& test, double ppd = 0,
                               const ExecOptions& exec = {});
AFTERIMAGE_API double hdr_flip(const BufferView& reference, const BufferView& test,
                               const ExecOptions& exec = {});
// Temporal error of one frame pair: mean over pixels and channels of
// |(O_t - O_t-1) - (R_t - R_t-1)| on linear images (flicker and lag both raise it).
AFTERIMAGE_API double temporal_error(const BufferView& output_prev, const BufferView& output,
                                     const BufferView& reference_prev, const BufferView& reference,
                                     const ExecOptions& exec = {});

// ---- Files ----------------------------------------------------------------------------
// How a sequence on disk is read: the CLI's --name, --layout, --map, --jitter, --jitter-file
// (README "Renders from other tools").
struct SequenceOptions {
  std::string name;               // file stem; "" = the only one in the folder
  std::string layout = "auto";    // auto, afterimage, blender[:VIEWLAYER], or a layout .json
  std::vector<std::string> maps;  // "motion=vel.X,vel.Y:unity", "depth=Z:hardware-reversed"
  std::string jitter;             // "" (from the files), "none", "haltonN[:start]"
  std::string jitter_file;        // camera sidecar
};

// An owned frame as read from a file: planar float channels (ids as floats), and its camera.
class AFTERIMAGE_API FrameData {
 public:
  FrameData();
  ~FrameData();
  FrameData(FrameData&&) noexcept;
  FrameData& operator=(FrameData&&) noexcept;
  int width() const;
  int height() const;
  // The channels present ("color", "depth", ...), in the library's table order.
  std::vector<std::string> channels() const;
  bool has(const std::string& channel) const;
  // A planar view of a channel's values (empty if absent); ids are u32.
  BufferView channel(const std::string& channel) const;
  const FrameCamera& camera() const;
  // The frame as a method's input (views into this frame, which must outlive the call).
  FrameInput input() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  friend class FrameReader;
};

using NoteFn = std::function<void(const std::string& note)>;

// Reads a sequence through layouts and conventions, checking each frame's file as it goes.
class AFTERIMAGE_API FrameReader {
 public:
  explicit FrameReader(const std::string& dir, const SequenceOptions& options = {},
                       const NoteFn& note = {});
  ~FrameReader();
  FrameReader(FrameReader&&) noexcept;
  FrameReader& operator=(FrameReader&&) noexcept;
  size_t size() const;
  std::string path(size_t i) const;
  // The layout that reads the files and how it was chosen: "afterimage (recognised)".
  std::string layout() const;
  // Frame i with every channel its file has (or only `channels`, color always).
  FrameData read(size_t i, const std::vector<std::string>& channels = {}) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Writes linear color (3 channels, or 4 with alpha) as an EXR frame with `camera` in its
// header (written to a temporary name and renamed: never half a file).
AFTERIMAGE_API void write_exr(const std::string& path, const BufferView& color,
                              const FrameCamera& camera = {});

// Called after each frame: (frames done, total, output path).
using ProgressFn = std::function<void(size_t done, size_t total, const std::string& path)>;

struct RunOptions {
  SequenceOptions input;
  std::string out_name;              // "" = each output keeps its input's file name
  std::string format = "exr";        // exr, png, jpg
  bool keep_gbuffer = false;         // EXR: also every input channel the method did not produce
  std::string compression = "none";  // EXR compression (zip, piz, dwaa, ...)
  bool half = false;                 // EXR color as 16-bit half
  float exposure = 1.0f;             // png / jpg
  std::string tonemap = "reinhard";  // png / jpg without a tonemap stage: reinhard | clamp
  std::string load_state, save_state;
  ExecOptions exec;
};
struct RunSummary {
  size_t frames = 0;
  double seconds = 0;          // the whole run: read, process, write
  double process_seconds = 0;  // inside the method
  std::string layout;          // how the input was read
};
// Files to files (`afterimage resolve`, `denoise` and `run`): every frame of `in_dir` through
// `spec` (as Method's) into `out_dir`. Every input's header is checked before anything is
// written; an error on frame k leaves frames < k written and complete, nothing of frame k.
AFTERIMAGE_API RunSummary run_files(const std::string& spec,
                                    const std::vector<std::string>& settings,
                                    const std::string& in_dir, const std::string& out_dir,
                                    const RunOptions& options = {}, const ProgressFn& progress = {},
                                    const NoteFn& note = {});

// `afterimage extrapolate`: input frame k (from 0) is kept when k % (skip + 1) == 0 and
// synthesised from the frame kept before it otherwise (with `interpolate`, from the kept
// frames on both sides).
struct ExtrapolateOptions {
  SequenceOptions input;
  int skip = 1;
  bool interpolate = false;
  std::string fill = "background";  // naive, pushpull, pushpull-background
  std::string out_name;
  std::string compression = "none";
  ExecOptions exec;
};
struct ExtrapolateSummary {
  size_t frames = 0, synthesized = 0;
  double mean_hole_fraction = 0, max_hole_fraction = 0, seconds = 0;
};
AFTERIMAGE_API ExtrapolateSummary extrapolate_files(const std::string& in_dir,
                                                    const std::string& out_dir,
                                                    const ExtrapolateOptions& options = {},
                                                    const ProgressFn& progress = {},
                                                    const NoteFn& note = {});

// `afterimage eval`: output sequences scored against a reference sequence.
struct EvaluateOptions {
  std::vector<std::string> labels;     // default: the folder names
  SequenceOptions reference_input;     // how the reference (and G-buffer) frames are read
  std::string gbuffer;                 // frames with depth, ids and motion for the ghosting masks
  int warmup = 16;                     // frames left out of the means
  int every = 1, every_offset = 0;     // score frames t with t % every == every_offset
  std::string json_path, report_path;  // also write metrics JSON / an HTML report
  ExecOptions exec;
};
struct SequenceScores {
  std::string label;
  int frames = 0, frames_measured = 0;
  double psnr = 0, psnr_linear = 0, ssim = 0;
  double flip = 0;  // LDR-FLIP of the tonemapped frames
  double temporal_error = 0;
};
AFTERIMAGE_API std::vector<SequenceScores> evaluate(const std::vector<std::string>& output_dirs,
                                                    const std::string& reference_dir,
                                                    const EvaluateOptions& options = {},
                                                    const NoteFn& note = {});

}  // namespace v0
}  // namespace afterimage
