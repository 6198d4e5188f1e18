#include "pipeline/sequence.h"

#include <fmt/format.h>

#include <chrono>
#include <filesystem>

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

SequenceRunStats run_sequence(SequenceMethod& method, const std::string& in_dir,
                              const std::string& out_dir, const std::string& name,
                              const SequenceProgressFn& progress) {
  io::SequenceInput in;
  in.dir = in_dir;
  in.name = name;
  in.layout = "afterimage";
  return run_sequence(method, in, out_dir, progress);
}

SequenceRunStats run_sequence(SequenceMethod& method, const io::SequenceInput& input,
                              const std::string& out_dir, const SequenceProgressFn& progress,
                              const io::NoteFn& note) {
  const auto t0 = Clock::now();
  const io::SequenceReader reader(input, note);
  std::vector<std::string> files;
  for (const auto& f : reader.files()) files.push_back(f.path);
  io::InputRegistry inputs;
  for (const auto& f : files) inputs.add(f);
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) throw InputError(fmt::format("{}: cannot create directory: {}", out_dir, ec.message()));

  SequenceRunStats st;
  const ChannelSet required = method.required_channels();
  const std::string who = method.name();
  for (size_t i = 0; i < files.size(); ++i) {
    const std::string& path = files[i];
    Frame in = reader.read(i, required, who, &inputs);
    const auto p0 = Clock::now();
    Frame out;
    try {
      out = method.process(in);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", path, e.what()));
    }
    st.process_seconds += seconds_since(p0);
    out.adopt_missing_channels(std::move(in));  // the output keeps the input's G-buffer
    const std::string out_path = (fs::path(out_dir) / fs::path(path).filename()).string();
    io::write_frame(out_path, out, &inputs);
    ++st.frames;
    if (progress) progress(i + 1, files.size(), out_path);
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
