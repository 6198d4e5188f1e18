// The C API (include/afterimage/afterimage.h) over the C++ API: a handle owns a Method or an
// Extrapolator, the C structs are converted to the C++ ones on each call, and every entry point
// runs its body through guarded(), which turns any exception into a status and a message.
#include "afterimage/afterimage.h"

#include <algorithm>
#include <cstring>
#include <exception>
#include <memory>
#include <mutex>
#include <new>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "afterimage/afterimage.hpp"

struct afterimage_method_t {
  afterimage::Method method;
};

struct afterimage_extrapolator_t {
  afterimage::Extrapolator extrapolator;
};

namespace {

using afterimage::BufferView;
using afterimage::DataType;
using afterimage::ExecOptions;
using afterimage::FrameCamera;
using afterimage::FrameInput;
using afterimage::Range;

// ---- Errors -------------------------------------------------------------------------------------

// The error callback is process-wide because the C ABI has no context object to keep it in
// (OIDN keeps its callback per device). The mutex keeps the function and its user pointer a
// consistent pair; it is taken only to set the callback and to read it on a failure or note.
struct Callback {
  afterimage_error_fn fn = nullptr;
  void* user = nullptr;
};
std::mutex callback_mutex;
Callback callback;

thread_local std::string last_error;

// Tells the callback, if any; nothing it does may escape into the caller's C code.
void notify(afterimage_status status, const char* message) noexcept {
  try {
    Callback cb;
    {
      std::lock_guard<std::mutex> lock(callback_mutex);
      cb = callback;
    }
    // Called outside the lock, so that the callback may set another callback.
    if (cb.fn) cb.fn(cb.user, status, message);
  } catch (...) {
  }
}

afterimage_status fail(afterimage_status status, const char* message) noexcept {
  try {
    last_error = message;
  } catch (...) {
    last_error.clear();  // no memory for the message: at least not a stale one
  }
  notify(status, message);
  return status;
}

// A NULL handle or pointer, or a negative count: thrown by require() so that each entry
// point's checks read as one line each, and caught by guarded() like the library's errors.
class InvalidArgument : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

void require(bool ok, const char* function, const char* problem) {
  if (!ok) throw InvalidArgument(std::string(function) + ": " + problem);
}

// Runs `body`, mapping what it throws to a status (most derived types first).
template <class F>
afterimage_status guarded(F&& body) noexcept {
  try {
    body();
    return AFTERIMAGE_OK;
  } catch (const InvalidArgument& e) {
    return fail(AFTERIMAGE_ERROR_INVALID_ARGUMENT, e.what());
  } catch (const afterimage::InputError& e) {
    return fail(AFTERIMAGE_ERROR_INPUT, e.what());
  } catch (const afterimage::SettingsError& e) {
    return fail(AFTERIMAGE_ERROR_SETTINGS, e.what());
  } catch (const afterimage::OutputError& e) {
    return fail(AFTERIMAGE_ERROR_OUTPUT, e.what());
  } catch (const std::bad_alloc&) {
    return fail(AFTERIMAGE_ERROR_OUT_OF_MEMORY, "out of memory");
  } catch (const std::exception& e) {
    return fail(AFTERIMAGE_ERROR_UNKNOWN, e.what());
  } catch (...) {
    return fail(AFTERIMAGE_ERROR_UNKNOWN,
                "unknown error (an exception that is not std::exception)");
  }
}

// ---- Conversions --------------------------------------------------------------------------------

BufferView view_of(const afterimage_buffer& b) {
  BufferView v;
  v.data = b.data;
  // Out-of-range values stay out of range: the C++ API refuses them with a message.
  v.type = static_cast<DataType>(b.type);
  v.width = b.width;
  v.height = b.height;
  v.channels = b.channels;
  v.pixel_stride = b.pixel_stride;
  v.row_stride = b.row_stride;
  v.channel_stride = b.channel_stride;
  return v;
}

afterimage_buffer buffer_of(const BufferView& v) {
  afterimage_buffer b;
  b.data = v.data;
  b.type = static_cast<afterimage_data_type>(v.type);
  b.width = v.width;
  b.height = v.height;
  b.channels = v.channels;
  b.pixel_stride = v.pixel_stride;
  b.row_stride = v.row_stride;
  b.channel_stride = v.channel_stride;
  return b;
}

FrameCamera camera_of(const afterimage_camera& c) {
  FrameCamera r;
  std::copy(c.view, c.view + 16, r.view);
  std::copy(c.projection, c.projection + 16, r.projection);
  r.known = c.known != 0;
  r.jitter_x = c.jitter_x;
  r.jitter_y = c.jitter_y;
  r.index = c.index;
  r.time = c.time;
  r.cut = c.cut != 0;
  r.lens.focal_length_mm = c.lens.focal_length_mm;
  r.lens.f_number = c.lens.f_number;
  r.lens.focus_distance = c.lens.focus_distance;
  r.lens.sensor_width_mm = c.lens.sensor_width_mm;
  r.lens.blades = c.lens.blades;
  r.lens.blade_rotation_deg = c.lens.blade_rotation_deg;
  r.lens_known = c.lens_known != 0;
  return r;
}

afterimage_camera c_camera_of(const FrameCamera& c) {
  afterimage_camera r;
  std::copy(c.view, c.view + 16, r.view);
  std::copy(c.projection, c.projection + 16, r.projection);
  r.known = c.known;
  r.jitter_x = c.jitter_x;
  r.jitter_y = c.jitter_y;
  r.index = c.index;
  r.time = c.time;
  r.cut = c.cut;
  r.lens.focal_length_mm = c.lens.focal_length_mm;
  r.lens.f_number = c.lens.f_number;
  r.lens.focus_distance = c.lens.focus_distance;
  r.lens.sensor_width_mm = c.lens.sensor_width_mm;
  r.lens.blades = c.lens.blades;
  r.lens.blade_rotation_deg = c.lens.blade_rotation_deg;
  r.lens_known = c.lens_known;
  return r;
}

FrameInput frame_of(const afterimage_frame& f, const char* function) {
  FrameInput in;
  in.color = view_of(f.color);
  in.depth = view_of(f.depth);
  in.normal = view_of(f.normal);
  in.albedo = view_of(f.albedo);
  in.motion = view_of(f.motion);
  in.id = view_of(f.id);
  in.alpha = view_of(f.alpha);
  require(f.extra_count >= 0, function, "frame->extra_count is negative");
  require(f.extra_count == 0 || f.extra, function, "frame->extra is NULL with extra_count > 0");
  for (int i = 0; i < f.extra_count; ++i) {
    require(f.extra[i].name != nullptr, function, "frame->extra[i].name is NULL");
    in.extra.emplace_back(f.extra[i].name, view_of(f.extra[i].buffer));
  }
  if (f.motion_convention) in.motion_convention = f.motion_convention;
  if (f.depth_convention) in.depth_convention = f.depth_convention;
  in.camera = camera_of(f.camera);
  return in;
}

std::vector<std::string> strings_of(const char* const* s, int count, const char* function,
                                    const char* what) {
  const std::string w(what);
  require(count >= 0, function, (w + " count is negative").c_str());
  require(count == 0 || s, function, (w + " is NULL with a count > 0").c_str());
  std::vector<std::string> r;
  for (int i = 0; i < count; ++i) {
    require(s[i] != nullptr, function, (w + "[" + std::to_string(i) + "] is NULL").c_str());
    r.emplace_back(s[i]);
  }
  return r;
}

ExecOptions exec_of(int threads, int simd, const char* function) {
  if (threads < 0)
    throw afterimage::SettingsError(std::string(function) + ": threads " + std::to_string(threads) +
                                    " is negative (0 = every core)");
  ExecOptions e;
  e.threads = threads;
  e.simd = simd != 0;
  return e;
}

// The size-query idiom of afterimage.h: as much of `s` as fits, NUL-terminated, never cutting
// a UTF-8 sequence in two, and the full size in *needed.
void copy_text(const std::string& s, char* buf, size_t buf_size, size_t* needed,
               const char* function) {
  require(buf || buf_size == 0, function, "buf is NULL with buf_size > 0");
  if (needed) *needed = s.size() + 1;
  if (buf_size == 0) return;
  size_t n = std::min(s.size(), buf_size - 1);
  if (n < s.size())
    while (n > 0 && (static_cast<unsigned char>(s[n]) & 0xC0) == 0x80) --n;
  std::memcpy(buf, s.data(), n);
  buf[n] = '\0';
}

// A fixed-size char array of a C struct: truncated, always NUL-terminated.
template <size_t N>
void copy_fixed(char (&dst)[N], const std::string& s) {
  copy_text(s, dst, N, nullptr, "");
}

std::string lines(const std::vector<std::string>& names) {
  std::string r;
  for (const std::string& n : names) {
    if (!r.empty()) r += '\n';
    r += n;
  }
  return r;
}

template <class F>
afterimage_status text_result(const char* function, char* buf, size_t buf_size, size_t* needed,
                              F&& make) {
  return guarded([&] { copy_text(make(), buf, buf_size, needed, function); });
}

Range range_of(int hdr) {
  return hdr ? Range::hdr : Range::ldr;
}

}  // namespace

extern "C" {

// ---- Errors, version, registries ----------------------------------------------------------------

const char* afterimage_last_error(void) {
  return last_error.c_str();
}

void afterimage_set_error_callback(afterimage_error_fn fn, void* user) {
  try {
    std::lock_guard<std::mutex> lock(callback_mutex);
    callback.fn = fn;
    callback.user = user;
  } catch (...) {
  }
}

const char* afterimage_version(void) {
  return afterimage::version();
}

int afterimage_version_number(void) {
  return AFTERIMAGE_VERSION_NUMBER;
}

afterimage_status afterimage_simd_target(char* buf, size_t buf_size, size_t* needed) {
  return text_result("afterimage_simd_target", buf, buf_size, needed,
                     [] { return afterimage::simd_target(); });
}

afterimage_status afterimage_method_names(char* buf, size_t buf_size, size_t* needed) {
  return text_result("afterimage_method_names", buf, buf_size, needed,
                     [] { return lines(afterimage::method_names()); });
}

afterimage_status afterimage_post_stage_names(char* buf, size_t buf_size, size_t* needed) {
  return text_result("afterimage_post_stage_names", buf, buf_size, needed,
                     [] { return lines(afterimage::post_stage_names()); });
}

afterimage_status afterimage_channel_names(char* buf, size_t buf_size, size_t* needed) {
  return text_result("afterimage_channel_names", buf, buf_size, needed,
                     [] { return lines(afterimage::channel_names()); });
}

afterimage_status afterimage_describe_settings(const char* spec, char* buf, size_t buf_size,
                                               size_t* needed) {
  const char* fn = "afterimage_describe_settings";
  return text_result(fn, buf, buf_size, needed, [&] {
    require(spec != nullptr, fn, "spec is NULL");
    return afterimage::describe_settings(spec);
  });
}

// ---- Buffers and frames -------------------------------------------------------------------------

afterimage_buffer afterimage_buffer_interleaved(const void* data, int width, int height,
                                                int channels, afterimage_data_type type) {
  return buffer_of(
      BufferView::interleaved(data, width, height, channels, static_cast<DataType>(type)));
}

afterimage_buffer afterimage_buffer_planar(const void* data, int width, int height, int channels,
                                           afterimage_data_type type) {
  return buffer_of(BufferView::planar(data, width, height, channels, static_cast<DataType>(type)));
}

void afterimage_camera_init(afterimage_camera* camera) {
  // From a default FrameCamera, so that the two APIs' defaults cannot drift apart.
  guarded([&] {
    require(camera != nullptr, "afterimage_camera_init", "camera is NULL");
    *camera = c_camera_of(FrameCamera{});
  });
}

void afterimage_frame_init(afterimage_frame* frame) {
  guarded([&] {
    require(frame != nullptr, "afterimage_frame_init", "frame is NULL");
    std::memset(frame, 0, sizeof *frame);  // no buffers, F32, NULL conventions
    frame->camera = c_camera_of(FrameCamera{});
  });
}

// ---- Methods ------------------------------------------------------------------------------------

afterimage_status afterimage_method_new(const char* spec, const char* const* settings,
                                        int settings_count, int threads, int simd,
                                        afterimage_method* out) {
  const char* fn = "afterimage_method_new";
  return guarded([&] {
    require(out != nullptr, fn, "out is NULL");
    *out = nullptr;
    require(spec != nullptr, fn, "spec is NULL");
    const std::vector<std::string> s = strings_of(settings, settings_count, fn, "settings");
    *out = new afterimage_method_t{afterimage::Method(spec, s, exec_of(threads, simd, fn))};
  });
}

void afterimage_method_free(afterimage_method method) {
  delete method;
}

afterimage_status afterimage_method_process(afterimage_method method, const afterimage_frame* frame,
                                            const afterimage_buffer* out) {
  const char* fn = "afterimage_method_process";
  return guarded([&] {
    require(method != nullptr, fn, "method is NULL");
    require(frame != nullptr, fn, "frame is NULL");
    require(out != nullptr, fn, "out is NULL");
    method->method.process(frame_of(*frame, fn), view_of(*out));
  });
}

afterimage_status afterimage_method_reset(afterimage_method method) {
  return guarded([&] {
    require(method != nullptr, "afterimage_method_reset", "method is NULL");
    method->method.reset();
  });
}

afterimage_status afterimage_method_save_state(afterimage_method method, const char* path) {
  const char* fn = "afterimage_method_save_state";
  return guarded([&] {
    require(method != nullptr, fn, "method is NULL");
    require(path != nullptr, fn, "path is NULL");
    method->method.save_state(path);
  });
}

afterimage_status afterimage_method_load_state(afterimage_method method, const char* path) {
  const char* fn = "afterimage_method_load_state";
  return guarded([&] {
    require(method != nullptr, fn, "method is NULL");
    require(path != nullptr, fn, "path is NULL");
    method->method.load_state(path);
  });
}

afterimage_status afterimage_method_output_size(afterimage_method method, int width, int height,
                                                int* out_width, int* out_height) {
  const char* fn = "afterimage_method_output_size";
  return guarded([&] {
    require(method != nullptr, fn, "method is NULL");
    require(out_width != nullptr && out_height != nullptr, fn, "out_width or out_height is NULL");
    const std::pair<int, int> size = method->method.output_size(width, height);
    *out_width = size.first;
    *out_height = size.second;
  });
}

afterimage_status afterimage_method_set_exec(afterimage_method method, int threads, int simd) {
  const char* fn = "afterimage_method_set_exec";
  return guarded([&] {
    require(method != nullptr, fn, "method is NULL");
    method->method.set_exec(exec_of(threads, simd, fn));
  });
}

afterimage_status afterimage_method_name(afterimage_method method, char* buf, size_t buf_size,
                                         size_t* needed) {
  const char* fn = "afterimage_method_name";
  return text_result(fn, buf, buf_size, needed, [&] {
    require(method != nullptr, fn, "method is NULL");
    return method->method.name();
  });
}

afterimage_status afterimage_method_settings_json(afterimage_method method, char* buf,
                                                  size_t buf_size, size_t* needed) {
  const char* fn = "afterimage_method_settings_json";
  return text_result(fn, buf, buf_size, needed, [&] {
    require(method != nullptr, fn, "method is NULL");
    return method->method.settings_json();
  });
}

afterimage_status afterimage_method_describe_settings(afterimage_method method, char* buf,
                                                      size_t buf_size, size_t* needed) {
  const char* fn = "afterimage_method_describe_settings";
  return text_result(fn, buf, buf_size, needed, [&] {
    require(method != nullptr, fn, "method is NULL");
    return method->method.describe_settings();
  });
}

afterimage_status afterimage_method_required_channels(afterimage_method method, char* buf,
                                                      size_t buf_size, size_t* needed) {
  const char* fn = "afterimage_method_required_channels";
  return text_result(fn, buf, buf_size, needed, [&] {
    require(method != nullptr, fn, "method is NULL");
    return lines(method->method.required_channels());
  });
}

// ---- Frame extrapolation ------------------------------------------------------------------------

afterimage_status afterimage_extrapolator_new(const char* const* settings, int settings_count,
                                              int threads, int simd, afterimage_extrapolator* out) {
  const char* fn = "afterimage_extrapolator_new";
  return guarded([&] {
    require(out != nullptr, fn, "out is NULL");
    *out = nullptr;
    const std::vector<std::string> s = strings_of(settings, settings_count, fn, "settings");
    *out = new afterimage_extrapolator_t{afterimage::Extrapolator(s, exec_of(threads, simd, fn))};
  });
}

void afterimage_extrapolator_free(afterimage_extrapolator extrapolator) {
  delete extrapolator;
}

afterimage_status afterimage_extrapolator_set_source(afterimage_extrapolator extrapolator,
                                                     const afterimage_frame* rendered) {
  const char* fn = "afterimage_extrapolator_set_source";
  return guarded([&] {
    require(extrapolator != nullptr, fn, "extrapolator is NULL");
    require(rendered != nullptr, fn, "rendered is NULL");
    extrapolator->extrapolator.set_source(frame_of(*rendered, fn));
  });
}

afterimage_status afterimage_extrapolator_synthesize(afterimage_extrapolator extrapolator,
                                                     const afterimage_camera* target,
                                                     const afterimage_buffer* out, int frames_after,
                                                     double* hole_fraction) {
  const char* fn = "afterimage_extrapolator_synthesize";
  return guarded([&] {
    require(extrapolator != nullptr, fn, "extrapolator is NULL");
    require(target != nullptr, fn, "target is NULL");
    require(out != nullptr, fn, "out is NULL");
    const double holes =
        extrapolator->extrapolator.synthesize(camera_of(*target), view_of(*out), frames_after);
    if (hole_fraction) *hole_fraction = holes;
  });
}

// ---- Metrics ------------------------------------------------------------------------------------

afterimage_status afterimage_compare(const afterimage_buffer* reference,
                                     const afterimage_buffer* test, int hdr,
                                     afterimage_pair_scores* out) {
  const char* fn = "afterimage_compare";
  return guarded([&] {
    require(reference != nullptr && test != nullptr, fn, "reference or test is NULL");
    require(out != nullptr, fn, "out is NULL");
    const afterimage::PairScores s =
        afterimage::compare(view_of(*reference), view_of(*test), range_of(hdr));
    out->psnr = s.psnr;
    out->psnr_linear = s.psnr_linear;
    out->ssim = s.ssim;
    out->flip = s.flip;
    out->flip_is_hdr = std::strcmp(s.flip_kind, "HDR-FLIP") == 0;
  });
}

afterimage_status afterimage_psnr(const afterimage_buffer* reference, const afterimage_buffer* test,
                                  int hdr, double* out) {
  const char* fn = "afterimage_psnr";
  return guarded([&] {
    require(reference != nullptr && test != nullptr, fn, "reference or test is NULL");
    require(out != nullptr, fn, "out is NULL");
    *out = afterimage::psnr(view_of(*reference), view_of(*test), range_of(hdr));
  });
}

afterimage_status afterimage_ssim(const afterimage_buffer* reference, const afterimage_buffer* test,
                                  int hdr, double* out) {
  const char* fn = "afterimage_ssim";
  return guarded([&] {
    require(reference != nullptr && test != nullptr, fn, "reference or test is NULL");
    require(out != nullptr, fn, "out is NULL");
    *out = afterimage::ssim(view_of(*reference), view_of(*test), range_of(hdr));
  });
}

afterimage_status afterimage_ldr_flip(const afterimage_buffer* reference,
                                      const afterimage_buffer* test, double ppd, double* out) {
  const char* fn = "afterimage_ldr_flip";
  return guarded([&] {
    require(reference != nullptr && test != nullptr, fn, "reference or test is NULL");
    require(out != nullptr, fn, "out is NULL");
    *out = afterimage::ldr_flip(view_of(*reference), view_of(*test), ppd);
  });
}

afterimage_status afterimage_hdr_flip(const afterimage_buffer* reference,
                                      const afterimage_buffer* test, double* out) {
  const char* fn = "afterimage_hdr_flip";
  return guarded([&] {
    require(reference != nullptr && test != nullptr, fn, "reference or test is NULL");
    require(out != nullptr, fn, "out is NULL");
    *out = afterimage::hdr_flip(view_of(*reference), view_of(*test));
  });
}

afterimage_status afterimage_temporal_error(const afterimage_buffer* output_prev,
                                            const afterimage_buffer* output,
                                            const afterimage_buffer* reference_prev,
                                            const afterimage_buffer* reference, double* out) {
  const char* fn = "afterimage_temporal_error";
  return guarded([&] {
    require(output_prev && output && reference_prev && reference, fn, "a buffer is NULL");
    require(out != nullptr, fn, "out is NULL");
    *out = afterimage::temporal_error(view_of(*output_prev), view_of(*output),
                                      view_of(*reference_prev), view_of(*reference));
  });
}

// ---- Files --------------------------------------------------------------------------------------

afterimage_status afterimage_write_exr(const char* path, const afterimage_buffer* color,
                                       const afterimage_camera* camera) {
  const char* fn = "afterimage_write_exr";
  return guarded([&] {
    require(path != nullptr, fn, "path is NULL");
    require(color != nullptr, fn, "color is NULL");
    afterimage::write_exr(path, view_of(*color), camera ? camera_of(*camera) : FrameCamera{});
  });
}

afterimage_status afterimage_run_files(const char* spec, const char* const* settings,
                                       int settings_count, const char* in_dir, const char* out_dir,
                                       const char* format, afterimage_progress_fn progress,
                                       void* user, afterimage_run_summary* out) {
  const char* fn = "afterimage_run_files";
  return guarded([&] {
    require(spec != nullptr, fn, "spec is NULL");
    require(in_dir != nullptr && out_dir != nullptr, fn, "in_dir or out_dir is NULL");
    const std::vector<std::string> s = strings_of(settings, settings_count, fn, "settings");
    afterimage::RunOptions options;
    if (format) options.format = format;
    afterimage::ProgressFn each;
    if (progress)
      each = [&](size_t done, size_t total, const std::string& path) {
        progress(user, done, total, path.c_str());
      };
    const afterimage::RunSummary r =
        afterimage::run_files(spec, s, in_dir, out_dir, options, each,
                              [](const std::string& note) { notify(AFTERIMAGE_OK, note.c_str()); });
    if (out) {
      out->frames = r.frames;
      out->seconds = r.seconds;
      out->process_seconds = r.process_seconds;
      copy_fixed(out->layout, r.layout);
    }
  });
}

afterimage_status afterimage_evaluate(const char* const* output_dirs, int count,
                                      const char* reference_dir, int warmup, const char* json_path,
                                      afterimage_sequence_scores* scores) {
  const char* fn = "afterimage_evaluate";
  return guarded([&] {
    const std::vector<std::string> dirs = strings_of(output_dirs, count, fn, "output_dirs");
    require(reference_dir != nullptr, fn, "reference_dir is NULL");
    afterimage::EvaluateOptions options;
    options.warmup = warmup;
    if (json_path) options.json_path = json_path;
    const std::vector<afterimage::SequenceScores> r =
        afterimage::evaluate(dirs, reference_dir, options,
                             [](const std::string& note) { notify(AFTERIMAGE_OK, note.c_str()); });
    if (!scores) return;
    for (size_t i = 0; i < std::min(dirs.size(), r.size()); ++i) {
      afterimage_sequence_scores& o = scores[i];
      copy_fixed(o.label, r[i].label);
      o.frames = r[i].frames;
      o.frames_measured = r[i].frames_measured;
      o.psnr = r[i].psnr;
      o.psnr_linear = r[i].psnr_linear;
      o.ssim = r[i].ssim;
      o.flip = r[i].flip;
      o.temporal_error = r[i].temporal_error;
    }
  });
}

}  // extern "C"
