#include "run/sequence.h"

#include <fmt/format.h>

#include <tbb/parallel_pipeline.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <filesystem>
#include <limits>
#include <memory>
#include <mutex>
#include <utility>

#include "core/atomic_file.h"
#include "core/error.h"
#include "io/io.h"
#include "run/alpha.h"

namespace afterimage {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}
}  // namespace

OutputFormat parse_output_format(const std::string& name) {
  if (name == "exr") return OutputFormat::exr;
  if (name == "png") return OutputFormat::png;
  if (name == "jpg" || name == "jpeg") return OutputFormat::jpg;
  throw SettingsError(fmt::format("--out-format '{}': expected exr, png or jpg", name));
}

const char* extension(OutputFormat f) {
  switch (f) {
    case OutputFormat::png:
      return ".png";
    case OutputFormat::jpg:
      return ".jpg";
    default:
      return ".exr";
  }
}

Tonemap parse_tonemap(const std::string& name) {
  if (name == "reinhard") return Tonemap::reinhard;
  if (name == "clamp") return Tonemap::clamp;
  throw SettingsError(fmt::format("--tonemap '{}': expected reinhard or clamp", name));
}

void SequenceOutput::validate() const {
  if (keep_gbuffer && format != OutputFormat::exr)
    throw SettingsError("--keep-gbuffer writes the G-buffer channels: it needs --out-format exr");
  // EXR options on an 8-bit output would be silently ignored: the user meant something else.
  if (format != OutputFormat::exr &&
      (exr.compression != io::FrameWriteOptions{}.compression || exr.half_color))
    throw SettingsError("--compression / --half are EXR options: they need --out-format exr");
  if (!(exposure > 0.0f) || !std::isfinite(exposure))
    throw SettingsError(fmt::format("--exposure {}: must be a positive number", exposure));
  io::check_exr_compression(exr.compression);
}

ImageF display_image(const ImageF& linear_rgb, const SequenceOutput& o, const Exec& ex) {
  metrics::DisplaySettings d;
  d.exposure = o.exposure;
  if (o.tonemap == Tonemap::reinhard) return metrics::to_display(linear_rgb, d, ex);
  if (o.tonemap == Tonemap::encoded) {  // already display values: only clipped (NaN to 0)
    ImageF clipped = linear_rgb;
    for (float& v : clipped.data()) v = v > 0.0f ? std::min(v, 1.0f) : 0.0f;
    return clipped;
  }
  // Clamp: exposure, then sRGB encoding of the value clipped to [0, 1].
  d.tonemap = false;
  ImageF scaled = linear_rgb;
  for (float& v : scaled.data()) v *= o.exposure;
  return metrics::to_display(scaled, d, ex);
}

void write_color_output(const std::string& path, const ImageF& linear_rgb, const SequenceOutput& o,
                        const io::InputRegistry* inputs, const Exec& ex) {
  if (o.format == OutputFormat::exr) {
    Frame f;
    f.width = linear_rgb.width();
    f.height = linear_rgb.height();
    f.color = linear_rgb;
    io::write_frame(path, f, inputs, o.exr);
    return;
  }
  io::write_rgb(path, display_image(linear_rgb, o, ex), inputs);
}

namespace {

// Writes one output frame as `o` says. `in` is the input frame (its G-buffer is moved into
// the output with keep_gbuffer).
void write_output(const std::string& path, Frame&& out, Frame&& in, const SequenceOutput& o,
                  const io::InputRegistry& inputs) {
  if (o.format == OutputFormat::exr) {
    if (o.keep_gbuffer) out.adopt_missing_channels(std::move(in));
    io::write_frame(path, out, &inputs, o.exr);
    return;
  }
  write_color_output(path, out.color, o, &inputs);
}

}  // namespace

SequenceRunStats run_sequence(SequenceMethod& method, const SequenceFiles& io_files,
                              const SequenceProgressFn& progress, const WarnFn& warn) {
  const auto t0 = Clock::now();
  const io::SequenceReader reader(io_files.in, warn);
  const std::vector<io::SequenceFile>& files = reader.files();
  const ChannelSet required = method.required_channels();
  const std::string who = method.name();

  // Everything that can be checked is checked before the first byte is written.
  io::InputRegistry inputs;
  for (const auto& f : files) inputs.add(f.path);
  for (const auto& p : io_files.other_outputs) {
    inputs.check_writable(p);
    std::error_code ec;
    if (fs::exists(p, ec) && !fs::is_regular_file(p, ec))
      throw OutputError(fmt::format("{}: exists and is not a regular file", p));
  }
  io_files.out.validate();
  const SequenceOutput& oo = io_files.out;
  std::vector<std::string> out_paths;
  for (const auto& f : files) {
    const std::string name = io::sequence_output_name(f, io_files.out_name, extension(oo.format));
    out_paths.push_back((fs::path(io_files.out_dir) / name).string());
    inputs.check_writable(out_paths.back());
  }
  const auto checked = reader.check_all([&](size_t) { return required; }, who);
  const FrameHeader& first = checked.headers.front();
  // Motion vectors point to the previous *rendered* frame: after a gap it is missing.
  const std::vector<bool>& restart = checked.gap;
  if (warn)
    for (const std::string& line :
         io::describe_gaps(files, restart, "history restarts (as at a camera cut)"))
      warn(line);
  // The method's output size (upsampling makes it larger) is checked before writing too.
  std::pair<int, int> out_size;
  try {
    out_size = method.output_size(first.width, first.height);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", files[0].path, e.what()));
  }
  // Notes about the run come once, for the first frame.
  const WarnFn first_note = [&](const std::string& m) {
    if (warn) warn(fmt::format("{}: {}", files[0].path, m));
  };
  for (size_t i = 0; i < files.size(); ++i) {
    try {
      method.check_header(checked.headers[i], i == 0 ? first_note : WarnFn{});
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", files[i].path, e.what()));
    }
  }
  if (oo.keep_gbuffer && out_size != std::pair<int, int>(first.width, first.height) && warn)
    warn(
        fmt::format("--keep-gbuffer: the output is {}x{}, the input G-buffer {}x{}; its channels "
                    "are not copied",
                    out_size.first, out_size.second, first.width, first.height));
  create_output_directory(io_files.out_dir);
  if (const int n = remove_stale_temporaries(io_files.out_dir); n > 0 && warn)
    warn(fmt::format("warning: {}: removed {} temporary file(s) left by an interrupted run",
                     io_files.out_dir, n));

  // Three stages, each in frame order: read t+1 | process t | write t-1 (at most three frames
  // in memory). An error is recorded with its frame index k instead of cancelling the
  // pipeline: frames < k still in flight are finished and written, frames >= k are neither
  // processed nor written, and the error is rethrown at the end, as a one-frame-at-a-time
  // run would throw it.
  const ChannelSet load = oo.keep_gbuffer ? ChannelSet{} : method.used_channels();
  const size_t n = files.size();
  constexpr size_t kNone = std::numeric_limits<size_t>::max();
  std::atomic<size_t> failed_at{kNone};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto fail = [&](size_t i) {
    std::lock_guard<std::mutex> lock(error_mutex);
    if (i < failed_at.load()) {
      failed_at = i;
      error = std::current_exception();
    }
  };
  struct Work {
    size_t i = 0;
    Frame in, out;
  };
  using WorkPtr = std::shared_ptr<Work>;
  SequenceRunStats st;
  st.layout = reader.layout_choice();
  size_t next = 0;
  bool alpha_noted = false, alpha_seen = false, alpha_gap_noted = false;  // (a serial stage)
  tbb::parallel_pipeline(
      oo.pipelined ? 3 : 1,
      tbb::make_filter<void, WorkPtr>(tbb::filter_mode::serial_in_order,
                                      [&](tbb::flow_control& fc) -> WorkPtr {
                                        if (next >= n || next >= failed_at.load()) {
                                          fc.stop();
                                          return nullptr;
                                        }
                                        auto w = std::make_shared<Work>();
                                        w->i = next++;
                                        try {
                                          // Inputs are registered above; the registry is read
                                          // concurrently by writers.
                                          w->in = reader.read(w->i, required, who, nullptr, false,
                                                              load);
                                          if (restart[w->i]) w->in.camera_cut = true;
                                        } catch (...) {
                                          fail(w->i);
                                          fc.stop();
                                          return nullptr;
                                        }
                                        return w;
                                      }) &
          tbb::make_filter<WorkPtr, WorkPtr>(tbb::filter_mode::serial_in_order,
                                             [&](WorkPtr w) -> WorkPtr {
                                               if (!w || w->i >= failed_at.load()) return nullptr;
                                               const auto p0 = Clock::now();
                                               try {
                                                 try {
                                                   w->out = method.process(w->in);
                                                 } catch (const InputError& e) {
                                                   throw InputError(fmt::format(
                                                       "{}: {}", files[w->i].path, e.what()));
                                                 }
                                               } catch (...) {
                                                 fail(w->i);
                                                 return nullptr;
                                               }
                                               st.process_seconds += seconds_since(p0);
                                               return w;
                                             }) &
          tbb::make_filter<WorkPtr, void>(tbb::filter_mode::serial_in_order, [&](WorkPtr w) {
            if (!w || w->i >= failed_at.load()) return;
            try {
              // A frame without the alpha its sequence's earlier frames had: its output has
              // none either (said once; every frame is written all the same).
              const bool has_alpha = w->out.has(Channel::alpha);
              if (has_alpha) {
                alpha_seen = true;
              } else if (alpha_seen && !alpha_gap_noted && warn) {
                alpha_gap_noted = true;
                warn(
                    fmt::format("{}: no alpha where earlier frames have one, so its output has "
                                "none (said once)",
                                files[w->i].path));
              }
              // 8-bit images are written without alpha (run/alpha.h): said once.
              if (oo.format != OutputFormat::exr && !alpha_noted && has_alpha &&
                  !fully_opaque(w->out.alpha) && warn) {
                alpha_noted = true;
                warn(fmt::format(
                    "{}: alpha below 1 (a transparent background): {} images carry no alpha, so "
                    "the color is written over black; --out-format exr keeps it (said once)",
                    files[w->i].path, extension(oo.format) + 1));
              }
              write_output(out_paths[w->i], std::move(w->out), std::move(w->in), oo, inputs);
              ++st.frames;
              if (progress) progress(w->i + 1, n, out_paths[w->i]);
            } catch (...) {
              fail(w->i);
            }
          }));
  if (error) std::rethrow_exception(error);
  st.seconds = seconds_since(t0);
  return st;
}

SequenceRunStats run_sequence(SequenceMethod& method, const std::vector<Frame>& frames,
                              const std::function<void(size_t, Frame&&)>& out,
                              const SequenceProgressFn& progress) {
  const auto t0 = Clock::now();
  SequenceRunStats st;
  for (size_t t = 0; t < frames.size(); ++t) {
    const auto p0 = Clock::now();
    Frame f = method.process(frames[t]);
    st.process_seconds += seconds_since(p0);
    ++st.frames;
    out(t, std::move(f));
    if (progress) progress(t + 1, frames.size(), "");
  }
  st.seconds = seconds_since(t0);
  return st;
}

}  // namespace afterimage
