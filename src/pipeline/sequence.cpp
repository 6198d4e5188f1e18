#include "pipeline/sequence.h"

#include <fmt/format.h>

#include <chrono>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "io/io.h"

namespace afterimage {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
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
  std::vector<std::string> out_paths;
  for (const auto& f : files) {
    out_paths.push_back((fs::path(io_files.out_dir) / fs::path(f.path).filename()).string());
    inputs.check_writable(out_paths.back());
  }
  std::vector<bool> restart(files.size(), false);
  io::FrameShape first;
  for (size_t i = 0; i < files.size(); ++i) {
    const io::FrameShape shape = reader.check(i, required, who);
    if (i == 0) first = shape;
    if (shape.width != first.width || shape.height != first.height)
      throw InputError(fmt::format("{}: size {}x{} differs from the sequence's {}x{} ({})",
                                   files[i].path, shape.width, shape.height, first.width,
                                   first.height, files[0].path));
    if (i > 0 && files[i].number != files[i - 1].number + 1) {
      // Motion vectors point to the previous *rendered* frame, which is missing.
      restart[i] = true;
      if (warn)
        warn(
            fmt::format("{}: frame(s) {}..{} missing before it; history restarts here (as at a "
                        "camera cut)",
                        files[i].path, files[i - 1].number + 1, files[i].number - 1));
    }
  }
  create_output_directory(io_files.out_dir);
  if (const int n = remove_stale_temporaries(io_files.out_dir); n > 0 && warn)
    warn(fmt::format("warning: {}: removed {} temporary file(s) left by an interrupted run",
                     io_files.out_dir, n));

  SequenceRunStats st;
  for (size_t i = 0; i < files.size(); ++i) {
    const std::string& path = files[i].path;
    Frame in = reader.read(i, required, who, &inputs);
    if (restart[i]) in.camera_cut = true;
    const auto p0 = Clock::now();
    Frame out;
    try {
      out = method.process(in);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", path, e.what()));
    }
    st.process_seconds += seconds_since(p0);
    out.adopt_missing_channels(std::move(in));  // the output keeps the input's G-buffer
    io::write_frame(out_paths[i], out, &inputs);
    ++st.frames;
    if (progress) progress(i + 1, files.size(), out_paths[i]);
  }
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
