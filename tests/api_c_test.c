/* The C API (include/afterimage/afterimage.h) end to end, from C: errors and the callback,
   registries and the size-query idiom, TAA over a synthetic jittered sequence into
   interleaved, planar and half outputs, state continuation, metrics, extrapolation, and
   files to files. Prints one line per check and then "N passed, M failed"; exits non-zero
   when any check failed. Plain C99, no test framework, so that it also checks the header
   compiles and links as C. */
#define _POSIX_C_SOURCE 200809L

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <direct.h>
#define make_dir(path) _mkdir(path)
#define remove_dir(path) _rmdir(path)
#else
#include <sys/stat.h>
#include <unistd.h>
#define make_dir(path) mkdir(path, 0755)
#define remove_dir(path) rmdir(path)
#endif

#include "afterimage/afterimage.h"

enum { W = 64, H = 36, FRAMES = 12, STATE_AFTER = 6, SUPERSAMPLE = 16 };

static int passed, failed;

static void check(int ok, const char* format, ...) {
  va_list args;
  printf("%s ", ok ? "PASS" : "FAIL");
  va_start(args, format);
  vprintf(format, args);
  va_end(args);
  printf("\n");
  if (ok)
    ++passed;
  else
    ++failed;
}

/* ---- The error callback's record ------------------------------------------------------------- */

static afterimage_status callback_status;
static char callback_message[512];

static void on_error(void* user, afterimage_status status, const char* message) {
  ++*(int*)user;
  callback_status = status;
  snprintf(callback_message, sizeof callback_message, "%s", message);
}

/* ---- The scene: a smooth gradient cut by a hard diagonal edge -------------------------------- */

/* The radiance at continuous pixel position (x, y), y down. */
static void scene(double x, double y, float rgb[3]) {
  if (x - 0.6 * y - 20.0 > 0.0) {
    rgb[0] = 0.9f;
    rgb[1] = 0.85f;
    rgb[2] = 0.2f;
  } else {
    rgb[0] = (float)(0.05 + 0.5 * x / W);
    rgb[1] = (float)(0.1 + 0.4 * y / H);
    rgb[2] = 0.3f;
  }
}

static double halton(unsigned index, unsigned base) {
  double f = 1.0, r = 0.0;
  while (index > 0) {
    f /= base;
    r += f * (index % base);
    index /= base;
  }
  return r;
}

/* The library's default jitter: Halton(2, 3) from index 1, in [-0.5, 0.5]. */
static void jitter_of(int frame, float* jx, float* jy) {
  *jx = (float)(halton((unsigned)frame + 1u, 2) - 0.5);
  *jy = (float)(halton((unsigned)frame + 1u, 3) - 0.5);
}

/* One sample per pixel, at (i + 0.5 + jx, j + 0.5 + jy). */
static void render_at(float jx, float jy, float* rgb) {
  int i, j;
  for (j = 0; j < H; ++j)
    for (i = 0; i < W; ++i) scene(i + 0.5 + jx, j + 0.5 + jy, rgb + 3 * (j * W + i));
}

/* Frame k's color. */
static void render(int frame, float* rgb) {
  float jx, jy;
  jitter_of(frame, &jx, &jy);
  render_at(jx, jy, rgb);
}

/* The pixel's box average over SUPERSAMPLE x SUPERSAMPLE samples: what TAA converges to. */
static void reference(float* rgb) {
  int i, j, a, b, c;
  for (j = 0; j < H; ++j)
    for (i = 0; i < W; ++i) {
      double sum[3] = {0, 0, 0};
      float s[3];
      for (b = 0; b < SUPERSAMPLE; ++b)
        for (a = 0; a < SUPERSAMPLE; ++a) {
          scene(i + (a + 0.5) / SUPERSAMPLE, j + (b + 0.5) / SUPERSAMPLE, s);
          for (c = 0; c < 3; ++c) sum[c] += s[c];
        }
      for (c = 0; c < 3; ++c)
        rgb[3 * (j * W + i) + c] = (float)(sum[c] / (SUPERSAMPLE * SUPERSAMPLE));
    }
}

/* Right-handed, looking down -Z, row-major (m[row * 4 + col]). */
static void perspective(float m[16], double fov_y_deg, double aspect, double znear, double zfar) {
  const double f = 1.0 / tan(fov_y_deg * 3.14159265358979323846 / 360.0);
  memset(m, 0, 16 * sizeof m[0]);
  m[0] = (float)(f / aspect);
  m[5] = (float)f;
  m[10] = (float)((zfar + znear) / (znear - zfar));
  m[11] = (float)(2.0 * zfar * znear / (znear - zfar));
  m[14] = -1.0f;
}

/* An IEEE half's value (exact: every half is a float). */
static float half_to_float(uint16_t h) {
  const int sign = h >> 15, exponent = (h >> 10) & 31, mantissa = h & 1023;
  float v;
  if (exponent == 0)
    v = ldexpf((float)mantissa, -24);
  else if (exponent == 31)
    v = mantissa ? NAN : INFINITY;
  else
    v = ldexpf((float)(mantissa | 1024), exponent - 25);
  return sign ? -v : v;
}

static double mean_abs_error(const float* a, int a_channels, const float* b, int b_channels) {
  double sum = 0;
  int p, c;
  for (p = 0; p < W * H; ++p)
    for (c = 0; c < 3; ++c) sum += fabs((double)a[p * a_channels + c] - b[p * b_channels + c]);
  return sum / (3.0 * W * H);
}

/* Whether `list` (names separated by '\n') holds `name` as a whole line. */
static int has_line(const char* list, const char* name) {
  const size_t n = strlen(name);
  const char* p = list;
  while ((p = strstr(p, name)) != NULL) {
    if ((p == list || p[-1] == '\n') && (p[n] == '\n' || p[n] == '\0')) return 1;
    p += n;
  }
  return 0;
}

/* The text of a size-query call, in a malloc'd buffer (NULL on failure). */
static char* method_text(afterimage_status (*f)(afterimage_method, char*, size_t, size_t*),
                         afterimage_method m) {
  size_t needed = 0;
  char* buf;
  if (f(m, NULL, 0, &needed) != AFTERIMAGE_OK) return NULL;
  buf = (char*)malloc(needed);
  if (buf && f(m, buf, needed, NULL) != AFTERIMAGE_OK) {
    free(buf);
    return NULL;
  }
  return buf;
}

/* ---- The checks ------------------------------------------------------------------------------ */

static void test_version(void) {
  check(strcmp(afterimage_version(), AFTERIMAGE_VERSION_STRING) == 0,
        "afterimage_version() \"%s\" equals AFTERIMAGE_VERSION_STRING \"%s\"", afterimage_version(),
        AFTERIMAGE_VERSION_STRING);
  check(afterimage_version_number() == AFTERIMAGE_VERSION_NUMBER,
        "afterimage_version_number() %d equals AFTERIMAGE_VERSION_NUMBER %d",
        afterimage_version_number(), AFTERIMAGE_VERSION_NUMBER);
}

static void test_registries(void) {
  size_t needed = 0, needed_small = 0;
  char* names;
  char small[8];
  afterimage_status st = afterimage_method_names(NULL, 0, &needed);
  check(st == AFTERIMAGE_OK && needed > 1, "method_names size query: status %d, needed %zu",
        (int)st, needed);
  names = (char*)malloc(needed);
  if (!names) return;
  st = afterimage_method_names(names, needed, NULL);
  check(st == AFTERIMAGE_OK && strlen(names) + 1 == needed,
        "method_names fills a buffer of the needed size exactly (%zu chars)", strlen(names));
  check(has_line(names, "taa:afterimage"), "method_names lists taa:afterimage");
  {
    static char large[1 << 16];
    size_t needed_large = 0;
    st = afterimage_method_names(large, sizeof large, &needed_large);
    check(st == AFTERIMAGE_OK && needed_large == strlen(large) + 1 && needed_large == needed &&
              strcmp(large, names) == 0,
          "needed is the text's length + 1 (%zu), whatever the buffer", needed_large);
  }

  memset(small, 'x', sizeof small);
  st = afterimage_method_names(small, sizeof small, &needed_small);
  check(st == AFTERIMAGE_OK && needed_small == needed && small[sizeof small - 1] == '\0' &&
            strncmp(small, names, sizeof small - 1) == 0,
        "a too-small buffer gets the needed size (%zu) and a NUL-terminated truncation \"%s\"",
        needed_small, small);
  free(names);

  st = afterimage_channel_names(NULL, 0, &needed);
  names = st == AFTERIMAGE_OK ? (char*)malloc(needed) : NULL;
  if (names) {
    st = afterimage_channel_names(names, needed, NULL);
    check(st == AFTERIMAGE_OK && has_line(names, "depth") && has_line(names, "motion") &&
              has_line(names, "motion_next"),
          "channel_names lists depth, motion and motion_next");
    free(names);
  }
  st = afterimage_post_stage_names(NULL, 0, &needed);
  names = st == AFTERIMAGE_OK ? (char*)malloc(needed) : NULL;
  if (names) {
    st = afterimage_post_stage_names(names, needed, NULL);
    check(st == AFTERIMAGE_OK && has_line(names, "tonemap"), "post_stage_names lists tonemap");
    free(names);
  }
  st = afterimage_method_names(NULL, 4, &needed);
  check(st == AFTERIMAGE_ERROR_INVALID_ARGUMENT, "a NULL buffer with a size > 0 is refused");
}

static void test_errors(void) {
  afterimage_method m = (afterimage_method)1; /* must be reset to NULL on failure */
  afterimage_status st;
  int calls = 0;
  afterimage_set_error_callback(on_error, &calls);
  st = afterimage_method_new("taa:nonexistent", NULL, 0, 0, 1, &m);
  check(st == AFTERIMAGE_ERROR_SETTINGS && m == NULL,
        "method_new(\"taa:nonexistent\") fails with AFTERIMAGE_ERROR_SETTINGS (status %d)",
        (int)st);
  check(afterimage_last_error()[0] != '\0' && strstr(afterimage_last_error(), "nonexistent"),
        "last_error names the method: \"%s\"", afterimage_last_error());
  check(calls == 1 && callback_status == AFTERIMAGE_ERROR_SETTINGS &&
            strcmp(callback_message, afterimage_last_error()) == 0,
        "the callback heard it once with the same status and message (%d calls)", calls);

  st = afterimage_method_new(NULL, NULL, 0, 0, 1, &m);
  check(st == AFTERIMAGE_ERROR_INVALID_ARGUMENT, "method_new with a NULL spec: status %d", (int)st);
  {
    const char* settings[] = {"alpha=0.1", NULL};
    st = afterimage_method_new("taa:afterimage", settings, 2, 0, 1, &m);
    check(st == AFTERIMAGE_ERROR_INVALID_ARGUMENT && m == NULL,
          "method_new with a NULL setting: status %d, \"%s\"", (int)st, afterimage_last_error());
  }
  st = afterimage_method_reset(NULL);
  check(st == AFTERIMAGE_ERROR_INVALID_ARGUMENT && calls == 4,
        "a NULL handle gives AFTERIMAGE_ERROR_INVALID_ARGUMENT: \"%s\"", afterimage_last_error());
  afterimage_set_error_callback(NULL, NULL);
  st = afterimage_method_reset(NULL);
  check(st == AFTERIMAGE_ERROR_INVALID_ARGUMENT && calls == 4,
        "without a callback nothing is called");
}

static void test_defaults(void) {
  afterimage_camera c;
  afterimage_frame f;
  int k, identity = 1;
  memset(&c, 0x7f, sizeof c);
  afterimage_camera_init(&c);
  for (k = 0; k < 16; ++k)
    identity = identity && c.view[k] == (k % 5 == 0 ? 1.0f : 0.0f) &&
               c.projection[k] == (k % 5 == 0 ? 1.0f : 0.0f);
  check(identity && !c.known && c.jitter_x == 0 && c.index == 0 && c.time == 0 && !c.cut &&
            c.lens.focal_length_mm == 50.0 && c.lens.f_number == 0.0 &&
            c.lens.focus_distance == 5.0 && c.lens.sensor_width_mm == 36.0 && !c.lens_known,
        "camera_init: identity matrices, unknown camera, a 50 mm pinhole focused at 5");
  memset(&f, 0x7f, sizeof f);
  afterimage_frame_init(&f);
  check(f.color.data == NULL && f.depth.data == NULL && f.extra == NULL && f.extra_count == 0 &&
            f.motion_convention == NULL && f.camera.lens.focal_length_mm == 50.0,
        "frame_init: no buffers, default conventions, camera_init's camera");
}

/* The buffers of one frame of the static scene. */
typedef struct Frame {
  float color[W * H * 3], depth[W * H], motion[W * H * 2];
  afterimage_frame frame;
} Frame;

static void make_frame(Frame* f, int k) {
  int p;
  render(k, f->color);
  for (p = 0; p < W * H; ++p) f->depth[p] = 5.0f;
  memset(f->motion, 0, sizeof f->motion);
  afterimage_frame_init(&f->frame);
  f->frame.color = afterimage_buffer_interleaved(f->color, W, H, 3, AFTERIMAGE_F32);
  f->frame.depth = afterimage_buffer_interleaved(f->depth, W, H, 1, AFTERIMAGE_F32);
  f->frame.motion = afterimage_buffer_interleaved(f->motion, W, H, 2, AFTERIMAGE_F32);
  f->frame.camera.known = 1;
  perspective(f->frame.camera.projection, 60.0, (double)W / H, 0.1, 100.0);
  jitter_of(k, &f->frame.camera.jitter_x, &f->frame.camera.jitter_y);
  f->frame.camera.index = k;
  f->frame.camera.time = k / 60.0;
}

static void test_taa(void) {
  static Frame frames[FRAMES];
  static float rgba[W * H * 4], planar[3 * W * H], continued[W * H * 4];
  static uint16_t half[W * H * 3];
  static float ref[W * H * 3];
  afterimage_method interleaved = NULL, planar_m = NULL, half_m = NULL, resumed = NULL;
  afterimage_buffer out_rgba = afterimage_buffer_interleaved(rgba, W, H, 4, AFTERIMAGE_F32);
  afterimage_buffer out_planar = afterimage_buffer_planar(planar, W, H, 3, AFTERIMAGE_F32);
  afterimage_buffer out_half = afterimage_buffer_interleaved(half, W, H, 3, AFTERIMAGE_F16);
  afterimage_buffer out_continued =
      afterimage_buffer_interleaved(continued, W, H, 4, AFTERIMAGE_F32);
  const char* state_path = "afterimage_api_c_test.state";
  int k, p, c, ow = 0, oh = 0;
  int status_ok = 1, alpha_one = 1, planar_same = 1, half_close = 1, continued_same = 1;
  float worst_half = 0;
  afterimage_status st;
  char* text;

  for (k = 0; k < FRAMES; ++k) make_frame(&frames[k], k);
  st = afterimage_method_new("taa:afterimage", NULL, 0, 0, 1, &interleaved);
  check(st == AFTERIMAGE_OK && interleaved, "method_new(\"taa:afterimage\"): status %d", (int)st);
  if (st != AFTERIMAGE_OK) return;
  afterimage_method_new("taa:afterimage", NULL, 0, 0, 1, &planar_m);
  afterimage_method_new("taa:afterimage", NULL, 0, 1, 0, &half_m); /* 1 thread, 1 lane */

  text = method_text(afterimage_method_required_channels, interleaved);
  check(text && has_line(text, "depth") && has_line(text, "motion"),
        "TAA requires depth and motion");
  free(text);
  text = method_text(afterimage_method_name, interleaved);
  check(text && strstr(text, "taa"), "method_name: \"%s\"", text ? text : "(failed)");
  free(text);
  text = method_text(afterimage_method_settings_json, interleaved);
  check(text && text[0] == '{', "settings_json is a JSON object");
  free(text);
  st = afterimage_method_output_size(interleaved, W, H, &ow, &oh);
  check(st == AFTERIMAGE_OK && ow == W && oh == H, "output_size %dx%d -> %dx%d", W, H, ow, oh);

  {
    /* A frame without depth, first, so that the sequence has not started. */
    afterimage_frame no_depth = frames[0].frame;
    no_depth.depth.data = NULL;
    st = afterimage_method_process(interleaved, &no_depth, &out_rgba);
    check(st == AFTERIMAGE_ERROR_INPUT && strstr(afterimage_last_error(), "depth"),
          "a frame without depth gives AFTERIMAGE_ERROR_INPUT: \"%s\"", afterimage_last_error());
    st = afterimage_method_process(NULL, &frames[0].frame, &out_rgba);
    check(st == AFTERIMAGE_ERROR_INVALID_ARGUMENT, "process on a NULL handle: status %d", (int)st);
    st = afterimage_method_process(interleaved, &frames[0].frame, NULL);
    check(st == AFTERIMAGE_ERROR_INVALID_ARGUMENT, "process into a NULL buffer: status %d",
          (int)st);
  }

  for (k = 0; k < FRAMES; ++k) {
    status_ok &=
        afterimage_method_process(interleaved, &frames[k].frame, &out_rgba) == AFTERIMAGE_OK;
    status_ok &=
        afterimage_method_process(planar_m, &frames[k].frame, &out_planar) == AFTERIMAGE_OK;
    status_ok &= afterimage_method_process(half_m, &frames[k].frame, &out_half) == AFTERIMAGE_OK;
    if (k == STATE_AFTER - 1) {
      status_ok &= afterimage_method_save_state(interleaved, state_path) == AFTERIMAGE_OK;
      status_ok &=
          afterimage_method_new("taa:afterimage", NULL, 0, 0, 1, &resumed) == AFTERIMAGE_OK;
      status_ok &= afterimage_method_load_state(resumed, state_path) == AFTERIMAGE_OK;
    }
    if (k >= STATE_AFTER && resumed) {
      status_ok &=
          afterimage_method_process(resumed, &frames[k].frame, &out_continued) == AFTERIMAGE_OK;
      continued_same &= memcmp(continued, rgba, sizeof rgba) == 0;
    }
    for (p = 0; p < W * H; ++p) {
      alpha_one &= rgba[4 * p + 3] == 1.0f;
      for (c = 0; c < 3; ++c) {
        const float f = rgba[4 * p + c], h = half_to_float(half[3 * p + c]);
        planar_same &= memcmp(&planar[c * W * H + p], &f, sizeof f) == 0;
        if (fabsf(h - f) > worst_half) worst_half = fabsf(h - f);
        half_close &= fabsf(h - f) <= 1e-3f * fabsf(f) + 1e-3f;
      }
    }
  }
  check(status_ok, "%d frames through four methods, with save_state / load_state: all OK%s%s",
        FRAMES, status_ok ? "" : ", last error: ", status_ok ? "" : afterimage_last_error());
  check(alpha_one, "interleaved RGBA output: alpha 1 in channel 3");
  check(planar_same, "planar output has the interleaved output's RGB bits, every frame");
  check(half_close,
        "f16 output (1 thread, 1 lane) is the f32 output rounded (largest difference %g)",
        (double)worst_half);
  check(resumed && continued_same,
        "state saved after frame %d, loaded into a new method: frames %d..%d bit-identical",
        STATE_AFTER - 1, STATE_AFTER, FRAMES - 1);

  {
    /* The output after the whole sequence against the supersampled image. */
    afterimage_buffer ref_b = afterimage_buffer_interleaved(ref, W, H, 3, AFTERIMAGE_F32);
    afterimage_buffer last = frames[FRAMES - 1].frame.color;
    double psnr_taa = 0, psnr_single = 0, mae_taa, mae_single;
    afterimage_status st_single;
    reference(ref);
    mae_taa = mean_abs_error(rgba, 4, ref, 3);
    mae_single = mean_abs_error(frames[FRAMES - 1].color, 3, ref, 3);
    st = afterimage_psnr(&ref_b, &out_rgba, 1, &psnr_taa);
    st_single = afterimage_psnr(&ref_b, &last, 1, &psnr_single);
    check(st == AFTERIMAGE_OK && st_single == AFTERIMAGE_OK && psnr_taa > psnr_single + 1.0,
          "TAA is closer to the %dx%d supersampled image than one jittered frame: PSNR %.2f dB "
          "against %.2f dB",
          SUPERSAMPLE, SUPERSAMPLE, psnr_taa, psnr_single);
    check(mae_taa < mae_single, "mean absolute error %.5f against %.5f", mae_taa, mae_single);
  }

  st = afterimage_method_reset(interleaved);
  check(st == AFTERIMAGE_OK, "reset");
  st = afterimage_method_load_state(interleaved, "afterimage_api_c_test.missing");
  check(st == AFTERIMAGE_ERROR_INPUT || st == AFTERIMAGE_ERROR_SETTINGS,
        "load_state of a missing file fails: status %d \"%s\"", (int)st, afterimage_last_error());

  remove(state_path);
  afterimage_method_free(interleaved);
  afterimage_method_free(planar_m);
  afterimage_method_free(half_m);
  afterimage_method_free(resumed);
  afterimage_method_free(NULL);
}

static void test_metrics(void) {
  static float a[W * H * 3], b[W * H * 3];
  afterimage_buffer ra = afterimage_buffer_interleaved(a, W, H, 3, AFTERIMAGE_F32);
  afterimage_buffer rb = afterimage_buffer_interleaved(b, W, H, 3, AFTERIMAGE_F32);
  afterimage_pair_scores s;
  double v = -1, ssim = 0, te = -1;
  afterimage_status st;
  render(0, a);
  memcpy(b, a, sizeof a);
  st = afterimage_compare(&ra, &rb, 1, &s);
  check(st == AFTERIMAGE_OK && isinf(s.psnr) && s.psnr > 0 && s.flip == 0.0 && s.flip_is_hdr,
        "compare of identical images: psnr %g (+inf), HDR-FLIP %g (0)", s.psnr, s.flip);
  st = afterimage_compare(&ra, &rb, 0, &s);
  check(st == AFTERIMAGE_OK && !s.flip_is_hdr && s.ssim > 0.999,
        "compare with hdr 0 gives LDR-FLIP, ssim %g", s.ssim);
  render(3, b);
  st = afterimage_ldr_flip(&ra, &rb, 0, &v);
  check(st == AFTERIMAGE_OK && v > 0 && v < 1, "ldr_flip of two jitters: %g", v);
  st = afterimage_hdr_flip(&ra, &rb, &v);
  check(st == AFTERIMAGE_OK && v > 0 && v < 1, "hdr_flip of two jitters: %g", v);
  st = afterimage_ssim(&ra, &rb, 1, &ssim);
  check(st == AFTERIMAGE_OK && ssim > 0 && ssim < 1, "ssim of two jitters: %g", ssim);
  st = afterimage_temporal_error(&ra, &rb, &ra, &rb, &te);
  check(st == AFTERIMAGE_OK && te == 0.0, "temporal_error of an output equal to its reference: %g",
        te);
  {
    afterimage_buffer small = afterimage_buffer_interleaved(b, W / 2, H, 3, AFTERIMAGE_F32);
    st = afterimage_psnr(&ra, &small, 1, &v);
    check(st == AFTERIMAGE_ERROR_INPUT, "psnr of images of different sizes: \"%s\"",
          afterimage_last_error());
  }
  st = afterimage_psnr(&ra, NULL, 1, &v);
  check(st == AFTERIMAGE_ERROR_INVALID_ARGUMENT, "psnr with a NULL buffer: status %d", (int)st);
}

static void test_extrapolator(void) {
  static Frame source;
  static float out[W * H * 3];
  afterimage_buffer out_b = afterimage_buffer_interleaved(out, W, H, 3, AFTERIMAGE_F32);
  afterimage_extrapolator e = NULL;
  afterimage_camera target;
  double holes = -1;
  afterimage_status st;
  const char* bad[] = {"fill=sideways"};
  make_frame(&source, 0);
  source.frame.camera.jitter_x = source.frame.camera.jitter_y = 0;
  render_at(0, 0, source.color);

  st = afterimage_extrapolator_new(bad, 1, 0, 1, &e);
  check(st == AFTERIMAGE_ERROR_SETTINGS && e == NULL, "extrapolator with fill=sideways: \"%s\"",
        afterimage_last_error());
  st = afterimage_extrapolator_new(NULL, 0, 0, 1, &e);
  check(st == AFTERIMAGE_OK && e, "extrapolator_new: status %d", (int)st);
  if (!e) return;
  st = afterimage_extrapolator_synthesize(e, &source.frame.camera, &out_b, 1, &holes);
  check(st == AFTERIMAGE_ERROR_INPUT, "synthesize before set_source: \"%s\"",
        afterimage_last_error());
  st = afterimage_extrapolator_set_source(e, &source.frame);
  check(st == AFTERIMAGE_OK, "set_source: status %d", (int)st);
  target = source.frame.camera;
  target.index = 1;
  st = afterimage_extrapolator_synthesize(e, &target, &out_b, 1, &holes);
  check(st == AFTERIMAGE_OK && holes >= 0 && holes < 0.01 &&
            mean_abs_error(out, 3, source.color, 3) < 1e-3,
        "synthesize from an unmoved camera: holes %g, mean difference %g", holes,
        mean_abs_error(out, 3, source.color, 3));
  afterimage_extrapolator_free(e);
}

static size_t progress_calls, progress_last_done;

static void on_progress(void* user, size_t done, size_t total, const char* path) {
  (void)path;
  ++progress_calls;
  progress_last_done = done;
  *(size_t*)user = total;
}

static void test_files(void) {
  const char* root = "afterimage_api_c_test_files";
  const char* in_dir = "afterimage_api_c_test_files/in";
  const char* out_dir = "afterimage_api_c_test_files/out";
  const char* json = "afterimage_api_c_test_files/eval.json";
  char path[256];
  static float color[W * H * 3];
  afterimage_run_summary summary;
  afterimage_sequence_scores scores;
  size_t total = 0;
  int k, written = 1;
  afterimage_status st;

  make_dir(root);
  make_dir(in_dir);
  for (k = 0; k < FRAMES; ++k) {
    afterimage_buffer b = afterimage_buffer_interleaved(color, W, H, 3, AFTERIMAGE_F32);
    afterimage_camera cam;
    afterimage_camera_init(&cam);
    jitter_of(k, &cam.jitter_x, &cam.jitter_y);
    cam.index = k;
    render(k, color);
    snprintf(path, sizeof path, "%s/frame.%04d.exr", in_dir, k);
    written &= afterimage_write_exr(path, &b, &cam) == AFTERIMAGE_OK;
  }
  check(written, "write_exr of %d frames%s%s", FRAMES, written ? "" : ": ",
        written ? "" : afterimage_last_error());

  memset(&summary, 0, sizeof summary);
  st = afterimage_run_files("tonemap", NULL, 0, in_dir, out_dir, NULL, on_progress, &total,
                            &summary);
  check(st == AFTERIMAGE_OK && summary.frames == FRAMES && progress_calls == FRAMES &&
            progress_last_done == FRAMES && total == FRAMES && summary.layout[0] != '\0',
        "run_files(\"tonemap\"): status %d, %zu frames, %zu progress calls, layout \"%s\" %s",
        (int)st, summary.frames, progress_calls, summary.layout, st ? afterimage_last_error() : "");
  st = afterimage_run_files("tonemap", NULL, 0, "afterimage_api_c_test_files/none", out_dir, NULL,
                            NULL, NULL, NULL);
  check(st == AFTERIMAGE_ERROR_INPUT, "run_files from a missing folder: \"%s\"",
        afterimage_last_error());

  memset(&scores, 0, sizeof scores);
  st = afterimage_evaluate(&out_dir, 1, in_dir, 2, json, &scores);
  check(st == AFTERIMAGE_OK && scores.frames == FRAMES && scores.frames_measured == FRAMES - 2 &&
            strcmp(scores.label, "out") == 0 && isfinite(scores.psnr),
        "evaluate: status %d, label \"%s\", %d frames, %d measured, psnr %g %s", (int)st,
        scores.label, scores.frames, scores.frames_measured, scores.psnr,
        st ? afterimage_last_error() : "");

  for (k = 0; k < FRAMES; ++k) {
    snprintf(path, sizeof path, "%s/frame.%04d.exr", in_dir, k);
    remove(path);
    snprintf(path, sizeof path, "%s/frame.%04d.exr", out_dir, k);
    remove(path);
  }
  remove(json);
  remove_dir(in_dir);
  remove_dir(out_dir);
  remove_dir(root);
}

int main(void) {
  test_version();
  test_registries();
  test_errors();
  test_defaults();
  test_taa();
  test_metrics();
  test_extrapolator();
  test_files();
  printf("%d passed, %d failed\n", passed, failed);
  return failed ? 1 : 0;
}
