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
#include "metrics/display.h"

namespace afterimage {

// Called after each frame with (frames done, total, output path or "").
using SequenceProgressFn = std::function<void(size_t done, size_t total, const std::string&)>;

struct SequenceRunStats {
  size_t frames = 0;
  double seconds = 0;          // wall time of the whole run (read, process, write)
  double process_seconds = 0;  // time inside method.process
  std::string layout;          // io::SequenceReader::layout_choice of the input
};

// What a files-to-files run writes per frame (DESIGN.md §3 "Files").
enum class OutputFormat { exr, png, jpg };
OutputFormat parse_output_format(const std::string& name);  // throws SettingsError
const char* extension(OutputFormat f);                      // ".exr", ".png", ".jpg"

// The 8-bit writer's transform of linear color: Reinhard, or a clamp to [0, 1] (values a
// tonemap made), then sRGB; `encoded`: values a tonemap stage already sRGB-encoded, only clipped
// to [0, 1] (`run` with a sharpen stage after the tonemap, run/post_pipeline.h).
enum class Tonemap { reinhard, clamp, encoded };
Tonemap parse_tonemap(const std::string& name);  // throws SettingsError

struct SequenceOutput {
  OutputFormat format = OutputFormat::exr;
  // EXR: the method's output (color) and the input's camera metadata; with `keep_gbuffer`
  // also every input channel the method did not produce (the G-buffer pass-through).
  bool keep_gbuffer = false;
  io::FrameWriteOptions exr;
  // PNG / JPEG: display images, 8-bit sRGB after the metrics' display transform
  // (metrics/display.h): exposure, then Reinhard x/(1+x) per channel or a clamp to [0, 1].
  float exposure = 1.0f;
  Tonemap tonemap = Tonemap::reinhard;
  // Overlap reading frame t+1, processing t and writing t-1 (false: one frame at a time;
  // the files are bit-identical either way).
  bool pipelined = true;
  void validate() const;  // throws SettingsError
};

// The display image written for PNG / JPEG: values in [0, 1], sRGB-encoded.
ImageF display_image(const ImageF& linear_rgb, const SequenceOutput& o, const Exec& ex = {});
// Writes a linear RGB image as `o` says: an EXR frame holding only the color (o.exr), or the
// display image (PNG / JPEG). Refuses to replace a file of `inputs`.
void write_color_output(const std::string& path, const ImageF& linear_rgb, const SequenceOutput& o,
                        const io::InputRegistry* inputs = nullptr, const Exec& ex = {});

// The files of a files-to-files run.
struct SequenceFiles {
  io::SequenceInput in;  // directory, name, layout, --map, jitter / camera sidecar
  std::string out_dir;
  // "" (default): each output keeps its input's file name and frame number; else
  // OUT_NAME.NNNN.EXT with the input's number (io::sequence_output_name).
  std::string out_name;
  SequenceOutput out;
  // Other files the command will write (a saved state, a report): refused before anything
  // is written if one of them is an input frame.
  std::vector<std::string> other_outputs;
};

// Reads the input frames in frame order through io::SequenceReader (layout, conventions,
// sidecar; the channels the method uses, or all with keep_gbuffer), processes each frame and
// writes it under OUT with the same file name (the extension of the output format); see
// SequenceOutput for what is written. Reading, processing and writing of consecutive frames
// overlap (a three-stage pipeline, each stage in frame order). Before writing anything (issue 9) it
// checks every input's header (readable regular file, channels and pixel types, equal sizes),
// the frame numbering (duplicates refused; a gap warns and restarts history there, as a
// camera cut) and that no output path is an input. Corrupt pixel data found later stops the
// run: an error on frame k (reading, processing or writing) leaves frames < k written and
// complete, no frame >= k and no temporary; it is the error a one-frame-at-a-time run
// would throw. Removes stale temporaries of killed runs in
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
