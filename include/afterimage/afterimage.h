/* Afterimage's C API (docs/library.md), for engines and for other languages (C#, Rust,
   Python ctypes): the operations of the C++ API (afterimage/afterimage.hpp) behind opaque
   handles and plain structs. Every call that can fail returns an afterimage_status; the
   message of the failure is afterimage_last_error() on the same thread, and an optional
   callback hears it too. No call lets a C++ exception out.

   Conventions (docs/DESIGN.md §3): linear scene-referred Rec.709 color, HDR; pixel (0, 0) is
   the top-left; motion = p_prev - p_curr in pixels, y down, unjittered, unless a
   motion_convention says otherwise; depth is linear view depth unless a depth_convention says
   otherwise; jitter in pixels in [-0.5, 0.5], y down. Booleans are ints (0 = false).

   Text comes back through a caller's buffer: f(..., char* buf, size_t buf_size,
   size_t* needed) writes as much as fits, always NUL-terminated when buf_size > 0, and sets
   *needed (may be NULL) to the full length + 1; buf may be NULL with buf_size 0 to ask for
   the size. A truncated result (never cut inside a UTF-8 character) is still AFTERIMAGE_OK:
   compare *needed with buf_size.

   A handle is used by one thread at a time; different handles run on different threads
   freely. Structs are passed by pointer and only read during the call: nothing the caller
   gave is kept after it returns. */
#pragma once

#include <stddef.h>

#include "afterimage/export.h"
#include "afterimage/version.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- Errors ---------------------------------------------------------------------------------- */

typedef enum afterimage_status {
  AFTERIMAGE_OK = 0,
  AFTERIMAGE_ERROR_INPUT,            /* unreadable or inconsistent input: a file, a frame */
  AFTERIMAGE_ERROR_SETTINGS,         /* an unknown or impossible method, stage or setting */
  AFTERIMAGE_ERROR_OUTPUT,           /* a result could not be written */
  AFTERIMAGE_ERROR_INVALID_ARGUMENT, /* a NULL handle or pointer, a negative count */
  AFTERIMAGE_ERROR_OUT_OF_MEMORY,
  AFTERIMAGE_ERROR_UNKNOWN /* any other exception: its message says what */
} afterimage_status;

/* The one-line message of the last call that failed on this thread ("" if none has). A
   successful call leaves it as it was, so read it right after the failing call; the pointer
   stays valid until the next failure on this thread. */
AFTERIMAGE_API const char* afterimage_last_error(void);

/* Called with every failure's status and message, on the thread of the failing call, and
   with AFTERIMAGE_OK for a note: a warning that did not stop a files call (a repaired pixel,
   a camera sidecar read), possibly from a worker thread. It must not throw or call back into
   a handle in use. */
typedef void (*afterimage_error_fn)(void* user, afterimage_status status, const char* message);
/* The library's one piece of global state (the C ABI has no context object to keep it in):
   set it once at start-up; NULL removes it. Safe to call from any thread. */
AFTERIMAGE_API void afterimage_set_error_callback(afterimage_error_fn fn, void* user);

/* ---- Version and registries ------------------------------------------------------------------ */

/* The library's version ("0.1.0"), and MAJOR * 10000 + MINOR * 100 + PATCH: compare with
   AFTERIMAGE_VERSION_STRING / AFTERIMAGE_VERSION_NUMBER, the headers'. */
AFTERIMAGE_API const char* afterimage_version(void);
AFTERIMAGE_API int afterimage_version_number(void);
/* The SIMD target the library was compiled for ("AVX3_ZEN4, 16 float lanes"). */
AFTERIMAGE_API afterimage_status afterimage_simd_target(char* buf, size_t buf_size, size_t* needed);

/* Every registered method variant ("taa:afterimage", ...), every post stage, and every
   channel name a frame may carry, one per line ('\n' between names, none after the last). */
AFTERIMAGE_API afterimage_status afterimage_method_names(char* buf, size_t buf_size,
                                                         size_t* needed);
AFTERIMAGE_API afterimage_status afterimage_post_stage_names(char* buf, size_t buf_size,
                                                             size_t* needed);
AFTERIMAGE_API afterimage_status afterimage_channel_names(char* buf, size_t buf_size,
                                                          size_t* needed);
/* The settings of a spec as lines "key = value  default, range -- doc". */
AFTERIMAGE_API afterimage_status afterimage_describe_settings(const char* spec, char* buf,
                                                              size_t buf_size, size_t* needed);

/* ---- Buffers and frames ---------------------------------------------------------------------- */

typedef enum afterimage_data_type {
  AFTERIMAGE_F32 = 0,
  AFTERIMAGE_F16 = 1, /* IEEE half; outputs are rounded to nearest even */
  AFTERIMAGE_U32 = 2  /* ids */
} afterimage_data_type;

/* The caller's pixels, read or written in place: element (x, y, c) is at
   data + y * row_stride + x * pixel_stride + c * channel_stride bytes. Strides of 0 take the
   packed interleaved layout (pixel_stride = channels * element size, row_stride = width *
   pixel_stride, channel_stride = element size). data NULL means "no such channel". */
typedef struct afterimage_buffer {
  void* data;
  afterimage_data_type type;
  int width, height, channels;
  ptrdiff_t pixel_stride, row_stride, channel_stride;
} afterimage_buffer;

/* The two usual layouts: packed interleaved, and planar (channel c is a whole width x height
   plane at data + c * width * height elements). data is const only so that an input's pointer
   needs no cast: the library writes into output buffers alone. */
AFTERIMAGE_API afterimage_buffer afterimage_buffer_interleaved(const void* data, int width,
                                                               int height, int channels,
                                                               afterimage_data_type type);
AFTERIMAGE_API afterimage_buffer afterimage_buffer_planar(const void* data, int width, int height,
                                                          int channels, afterimage_data_type type);

/* A thin lens (depth of field): f_number 0 is a pinhole; blades 0 is a disc, 3..16 a
   polygon. focus_distance is in scene units along the view axis. */
typedef struct afterimage_lens {
  double focal_length_mm, f_number, focus_distance, sensor_width_mm;
  int blades;
  double blade_rotation_deg;
} afterimage_lens;

/* The camera and timing of one frame. view (world to view) and the *unjittered* projection
   are row-major (m[row * 4 + col]), right-handed, looking down -Z. Leave `known` 0 when the
   renderer cannot give them: what needs the camera's motion then refuses the frame. */
typedef struct afterimage_camera {
  float view[16], projection[16];
  int known;
  float jitter_x, jitter_y; /* this frame's sample offset, pixels, y down */
  int index;                /* frame number */
  double time;              /* seconds */
  int cut;                  /* a camera cut: no history is used across it */
  afterimage_lens lens;
  int lens_known; /* 0: the DoF stage takes the lens from its settings */
} afterimage_camera;

/* Identity matrices and the C++ FrameCamera's defaults (a 50 mm pinhole focused at 5). */
AFTERIMAGE_API void afterimage_camera_init(afterimage_camera* camera);

/* A channel of the library's table by name ("emission", "motion_next", ...). */
typedef struct afterimage_named_buffer {
  const char* name;
  afterimage_buffer buffer;
} afterimage_named_buffer;

/* One frame of a renderer's G-buffer in the caller's buffers (copied during the call). Only
   color is required (3 channels, or 4 with coverage alpha); what a method needs besides,
   afterimage_method_required_channels says. */
typedef struct afterimage_frame {
  afterimage_buffer color;
  afterimage_buffer depth;          /* 1 channel */
  afterimage_buffer normal, albedo; /* 3 channels */
  afterimage_buffer motion;         /* 2 channels */
  afterimage_buffer id;             /* 1 channel, u32 (or f32 holding integers) */
  afterimage_buffer alpha;          /* 1 channel, coverage of the premultiplied color */
  const afterimage_named_buffer* extra;
  int extra_count;
  /* As the CLI's --map takes them; NULL is "afterimage" / "linear". Motion: "afterimage",
     "blender", "unity", "unreal", "fsr2[:sx:sy]"; depth: "linear", "ray",
     "hardware[:near:far]", "hardware-reversed[:near:far]". */
  const char* motion_convention;
  const char* depth_convention;
  afterimage_camera camera;
} afterimage_frame;

/* No buffers, default conventions, afterimage_camera_init's camera. */
AFTERIMAGE_API void afterimage_frame_init(afterimage_frame* frame);

/* ---- Methods --------------------------------------------------------------------------------- */

/* A temporal method, a post stage or a chain of them, with its own history: hand it the
   frames of one sequence in order. */
typedef struct afterimage_method_t* afterimage_method;

/* `spec`: "taa:afterimage", "taau:quality", "svgf:afterimage" ("+key=value" may follow), a
   post stage ("bloom", "tonemap", ...) or a chain "svgf,taa,bloom,tonemap". `settings`:
   "key=value" for a method, "stage.key=value" for a chain (may be NULL when count is 0).
   threads 0 uses every core; simd 0 takes the 1-lane path (the same bits). */
AFTERIMAGE_API afterimage_status afterimage_method_new(const char* spec,
                                                       const char* const* settings,
                                                       int settings_count, int threads, int simd,
                                                       afterimage_method* out);
/* NULL is ignored. */
AFTERIMAGE_API void afterimage_method_free(afterimage_method method);

/* Processes the next frame and writes the output color into `out`: output_size pixels, 3
   channels or 4 (alpha: 1 where the input had none), f32 or f16. AFTERIMAGE_ERROR_INPUT for
   a frame the method cannot use (a missing channel, another size than the frames before). */
AFTERIMAGE_API afterimage_status afterimage_method_process(afterimage_method method,
                                                           const afterimage_frame* frame,
                                                           const afterimage_buffer* out);
/* Forgets the history: the next frame starts a new sequence. */
AFTERIMAGE_API afterimage_status afterimage_method_reset(afterimage_method method);
/* The state after frame k, loaded into a method of the same spec and settings, continues bit
   for bit. load_state changes nothing unless the file is valid. */
AFTERIMAGE_API afterimage_status afterimage_method_save_state(afterimage_method method,
                                                              const char* path);
AFTERIMAGE_API afterimage_status afterimage_method_load_state(afterimage_method method,
                                                              const char* path);
/* The output size for inputs of width x height (larger for TAAU). */
AFTERIMAGE_API afterimage_status afterimage_method_output_size(afterimage_method method, int width,
                                                               int height, int* out_width,
                                                               int* out_height);
AFTERIMAGE_API afterimage_status afterimage_method_set_exec(afterimage_method method, int threads,
                                                            int simd);
/* The name with its overrides, every setting as JSON and as lines, and the channels a frame
   must carry ("color\ndepth\nmotion"). */
AFTERIMAGE_API afterimage_status afterimage_method_name(afterimage_method method, char* buf,
                                                        size_t buf_size, size_t* needed);
AFTERIMAGE_API afterimage_status afterimage_method_settings_json(afterimage_method method,
                                                                 char* buf, size_t buf_size,
                                                                 size_t* needed);
AFTERIMAGE_API afterimage_status afterimage_method_describe_settings(afterimage_method method,
                                                                     char* buf, size_t buf_size,
                                                                     size_t* needed);
AFTERIMAGE_API afterimage_status afterimage_method_required_channels(afterimage_method method,
                                                                     char* buf, size_t buf_size,
                                                                     size_t* needed);

/* ---- Frame extrapolation --------------------------------------------------------------------- */

/* The frame that missed its deadline, synthesised from the last rendered frame and the new
   frame's camera (VR's asynchronous reprojection). */
typedef struct afterimage_extrapolator_t* afterimage_extrapolator;

/* settings: "fill=background" (default; naive, pushpull, pushpull-background). */
AFTERIMAGE_API afterimage_status afterimage_extrapolator_new(const char* const* settings,
                                                             int settings_count, int threads,
                                                             int simd,
                                                             afterimage_extrapolator* out);
AFTERIMAGE_API void afterimage_extrapolator_free(afterimage_extrapolator extrapolator);
/* A rendered frame: color and depth with a known camera; its "motion_next" (in extra), when
   given, moves its pixels exactly to the next frame. Copied: the buffers may be reused. */
AFTERIMAGE_API afterimage_status afterimage_extrapolator_set_source(
    afterimage_extrapolator extrapolator, const afterimage_frame* rendered);
/* The color `frames_after` (>= 1) frames after the source, seen from `target`, into `out`
   (the source's size, 3 or 4 channels); *hole_fraction (may be NULL) gets the fraction of
   pixels no source sample reached. */
AFTERIMAGE_API afterimage_status afterimage_extrapolator_synthesize(
    afterimage_extrapolator extrapolator, const afterimage_camera* target,
    const afterimage_buffer* out, int frames_after, double* hole_fraction);

/* ---- Metrics on two images (linear HDR color, 3 or 4 channels; alpha is left out) ------------ */
/* PSNR and SSIM are computed on display values: with hdr != 0 through the Reinhard tonemap
   and sRGB, with hdr == 0 (display values in [0, 1]) on their sRGB re-encoding, as
   `afterimage compare` does. */

typedef struct afterimage_pair_scores {
  double psnr;        /* dB, display RGB, peak 1 (+inf when identical) */
  double psnr_linear; /* dB, linear values, peak = the reference's maximum */
  double ssim;        /* display RGB */
  double flip;        /* HDR-FLIP when flip_is_hdr, else LDR-FLIP */
  int flip_is_hdr;
} afterimage_pair_scores;

AFTERIMAGE_API afterimage_status afterimage_compare(const afterimage_buffer* reference,
                                                    const afterimage_buffer* test, int hdr,
                                                    afterimage_pair_scores* out);
AFTERIMAGE_API afterimage_status afterimage_psnr(const afterimage_buffer* reference,
                                                 const afterimage_buffer* test, int hdr,
                                                 double* out);
AFTERIMAGE_API afterimage_status afterimage_ssim(const afterimage_buffer* reference,
                                                 const afterimage_buffer* test, int hdr,
                                                 double* out);
/* LDR-FLIP of display images in [0, 1] at `ppd` pixels per degree (<= 0: FLIP's 67). */
AFTERIMAGE_API afterimage_status afterimage_ldr_flip(const afterimage_buffer* reference,
                                                     const afterimage_buffer* test, double ppd,
                                                     double* out);
/* HDR-FLIP of linear images over FLIP's automatic exposures. */
AFTERIMAGE_API afterimage_status afterimage_hdr_flip(const afterimage_buffer* reference,
                                                     const afterimage_buffer* test, double* out);
/* Mean over pixels and channels of |(O_t - O_t-1) - (R_t - R_t-1)| on linear images: flicker
   and lag both raise it. */
AFTERIMAGE_API afterimage_status afterimage_temporal_error(const afterimage_buffer* output_prev,
                                                           const afterimage_buffer* output,
                                                           const afterimage_buffer* reference_prev,
                                                           const afterimage_buffer* reference,
                                                           double* out);

/* ---- Files ----------------------------------------------------------------------------------- */

/* Writes linear color (3 channels, or 4 with alpha) as an EXR frame with `camera` (NULL:
   afterimage_camera_init's) in its header; written to a temporary name and renamed, so never
   half a file. Frames named <name>.NNNN.exr in a folder are a sequence for the calls below. */
AFTERIMAGE_API afterimage_status afterimage_write_exr(const char* path,
                                                      const afterimage_buffer* color,
                                                      const afterimage_camera* camera);

/* Called after each frame written, in order and one call at a time, possibly from a worker
   thread: (frames done, total, output path). */
typedef void (*afterimage_progress_fn)(void* user, size_t done, size_t total, const char* path);

typedef struct afterimage_run_summary {
  size_t frames;
  double seconds;         /* the whole run: read, process, write */
  double process_seconds; /* inside the method */
  char layout[256];       /* how the input was read (truncated to fit) */
} afterimage_run_summary;

/* Files to files (`afterimage run`): every frame of in_dir through `spec` (as
   afterimage_method_new's) into out_dir, as "exr" (format NULL), "png" or "jpg". Every
   input's header is checked before anything is written; an error on frame k leaves frames
   < k written and complete. progress and out may be NULL. */
AFTERIMAGE_API afterimage_status afterimage_run_files(const char* spec, const char* const* settings,
                                                      int settings_count, const char* in_dir,
                                                      const char* out_dir, const char* format,
                                                      afterimage_progress_fn progress, void* user,
                                                      afterimage_run_summary* out);

typedef struct afterimage_sequence_scores {
  char label[256]; /* the output folder's name (truncated to fit) */
  int frames, frames_measured;
  double psnr, psnr_linear, ssim;
  double flip; /* LDR-FLIP of the tonemapped frames */
  double temporal_error;
} afterimage_sequence_scores;

/* `afterimage eval`: each of `count` output sequences scored against reference_dir, leaving
   the first `warmup` frames out of the means; json_path (may be NULL) also gets the metrics
   JSON. scores (may be NULL) is an array of `count`, in the order of output_dirs. */
AFTERIMAGE_API afterimage_status afterimage_evaluate(const char* const* output_dirs, int count,
                                                     const char* reference_dir, int warmup,
                                                     const char* json_path,
                                                     afterimage_sequence_scores* scores);

#ifdef __cplusplus
}
#endif
