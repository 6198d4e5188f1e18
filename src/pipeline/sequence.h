// Running a sequence method over frames (DESIGN.md §2, §6 "thin CLI"): files to files for
// `resolve` (and later `denoise` / `run`), in memory for the demo and the bench. Commands only
// parse arguments and call these.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/parallel.h"
#include "frame/frame.h"
#include "frame/sequence_method.h"
#include "io/sequence_input.h"

namespace afterimage {

// Called after each frame with (frames done, total, output path or "").
using SequenceProgressFn = std::function<void(size_t done, size_t total, const std::string&)>;

struct SequenceRunStats {
  size_t frames = 0;
  double seconds = 0;          // wall time of the whole run (read, process, write)
  double process_seconds = 0;  // time inside method.process
};

// Reads DIR/NAME.NNNN.exr in frame order (with the channels the method requires), processes
// each frame and writes it under `out_dir` with the same file name; an output frame keeps the
// input's channels that the method did not produce. Every input is registered
// before anything is written, so no output replaces an input even when out_dir == in_dir.
// Errors name the file: "<path>: <problem>".
SequenceRunStats run_sequence(SequenceMethod& method, const std::string& in_dir,
                              const std::string& out_dir, const std::string& name = "frame",
                              const SequenceProgressFn& progress = {});
// The same for any input (layout, name pattern, jitter / camera sidecar: io/sequence_input.h);
// `note` receives one-line notes (layout chosen, camera unknown).
SequenceRunStats run_sequence(SequenceMethod& method, const io::SequenceInput& in,
                              const std::string& out_dir, const SequenceProgressFn& progress = {},
                              const io::NoteFn& note = {});

// In-memory form: out(t, frame) receives each method output (its header and the channels it
// produced) in order; process time only.
SequenceRunStats run_sequence(SequenceMethod& method, const std::vector<Frame>& frames,
                              const std::function<void(size_t, Frame&&)>& out,
                              const SequenceProgressFn& progress = {});

}  // namespace afterimage
