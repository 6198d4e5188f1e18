// Running a sequence method over frames (DESIGN.md §2, §6 "thin CLI"): files to files for
// `resolve` (and later `denoise` / `run`), in memory for the demo and the bench. Commands only
// parse arguments and call these.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/error.h"
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

// The files of a files-to-files run.
struct SequenceFiles {
  io::SequenceInput in;  // directory, name, layout, --map, jitter / camera sidecar
  std::string out_dir;
  // Other files the command will write (a saved state, a report): refused before anything
  // is written if one of them is an input frame.
  std::vector<std::string> other_outputs;
};

// Reads the input frames in frame order through io::SequenceReader (layout, conventions,
// sidecar; with the channels the method requires), processes
// each frame and writes it under OUT with the same file name; an output frame keeps the
// input's channels that the method did not produce. Before writing anything (issue 9) it
// checks every input's header (readable regular file, channels and pixel types, equal sizes),
// the frame numbering (duplicates refused; a gap warns and restarts history there, as a
// camera cut) and that no output path is an input. Corrupt pixel data found later stops the
// run with the frames already written complete. Removes stale temporaries of killed runs in
// OUT. Notes (layout chosen, camera unknown) and repaired input values are reported
// through `note`. Errors name the file.
SequenceRunStats run_sequence(SequenceMethod& method, const SequenceFiles& files,
                              const SequenceProgressFn& progress = {}, const WarnFn& note = {});

// In-memory form: out(t, frame) receives each method output (its header and the channels it
// produced) in order; process time only.
SequenceRunStats run_sequence(SequenceMethod& method, const std::vector<Frame>& frames,
                              const std::function<void(size_t, Frame&&)>& out,
                              const SequenceProgressFn& progress = {});

}  // namespace afterimage
