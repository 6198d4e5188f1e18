// Frame extrapolation and interpolation by forward reprojection (issue 13, seed 004
// "Reprojection Techniques"; reproject/forward.h): the frame that missed its deadline is
// synthesised from the last rendered frame and the new camera, as VR asynchronous reprojection
// does, or (interpolation) from the rendered frames on both sides.
//
// Schedule: input frames are counted from 0 in file order (k); with skip N, frames with
// k % (N + 1) == 0 are "rendered" (their color is kept) and the others are synthesised from
// a = k - k % (N + 1) — its pixels, and only the header (view, projection, jitter) of frame k,
// never frame k's pixels — and, with interpolation, from b = a + N + 1 too when it exists
// (both splatted into k, one depth test across both). Displacements: a -> a + 1 through a's
// motion_next and b -> b - 1 through b's motion when the frame has the channel (exact, object
// motion included); every other pair through depth and the two cameras (camera-only: a moving
// object lands where it was in the source frame). A source separated from k by a camera cut
// (Frame::camera_cut, or a gap in the numbering) is not used when the other one is in k's
// shot; extrapolation across a cut goes through the cameras only (the result is then wrong,
// as any reprojection across a cut is).
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/parallel.h"
#include "frame/frame.h"
#include "io/io.h"
#include "io/sequence_input.h"
#include "reproject/forward.h"

namespace afterimage {

struct ExtrapolateSettings {
  int skip = 1;              // N >= 1 synthesised frames after each rendered one
  bool interpolate = false;  // also splat the next rendered frame (when there is one)
  reproject::FillSettings fill;
  void validate() const;  // throws SettingsError
};

// Role of frame k in the schedule.
bool is_rendered_frame(size_t k, int skip);
size_t previous_rendered_frame(size_t k, int skip);  // a = k - k % (skip + 1)

// A rendered frame used as a source of frame k: the frame (color, depth, and motion_next /
// motion if it has them), its position in the sequence, and whether a camera cut lies between
// it and the target.
struct SourceFrame {
  const Frame* frame = nullptr;
  size_t position = 0;
  bool same_shot = true;
};

// What one synthesised frame came from.
struct SynthesisReport {
  size_t a = 0;
  std::optional<size_t> b;  // set when b was splatted too (interpolation)
  bool used_a = true;
  reproject::DisplacementKind kind_a = reproject::DisplacementKind::camera;
  reproject::DisplacementKind kind_b = reproject::DisplacementKind::camera;
  double hole_fraction = 0;      // target pixels no source sample landed in (before the fill)
  std::string describe() const;  // "from 0 (motion_next) + 2 (motion), holes 1.23%"
};

// Which displacement a source at `source_position` takes to `target_position` (forward.h).
reproject::DisplacementKind choose_displacement(const SourceFrame& s, size_t target_position);

// Frame `target` (header only: its camera and jitter) synthesised from `a` and, if given and
// in the target's shot, `b`. `splat` (may be null) receives the unfilled splat.
ImageF synthesize_frame(const SourceFrame& a, const SourceFrame* b, const FrameHeader& target,
                        size_t target_position, const ExtrapolateSettings& settings, const Exec& ex,
                        SynthesisReport* report = nullptr,
                        reproject::ForwardSplat* splat = nullptr);

// In memory: every frame's output color (rendered frames: their color; the others
// synthesised), in order. Rendered frames need color and depth; the headers of all frames are
// used (camera_cut marks shots).
struct ExtrapolationResult {
  std::vector<ImageF> color;
  std::vector<bool> synthesized;
  std::vector<SynthesisReport> reports;  // per frame; meaningful where synthesized
};
ExtrapolationResult extrapolate_sequence(const std::vector<Frame>& frames,
                                         const ExtrapolateSettings& settings, const Exec& ex);

// Files to files (`afterimage extrapolate`): reads IN through io::SequenceReader (layouts,
// sidecars), checks every header before writing (rendered frames: color and depth; every
// frame: equal sizes, a known camera; no output path an input), and writes OUT/<input file
// name> for every frame: the color (rendered frames copied, the others synthesised) with the
// frame's own header, EXR. Keeps at most the two rendered frames around the group in memory.
struct ExtrapolateFiles {
  io::SequenceInput in;
  std::string out_dir;
  std::string out_name;  // as SequenceFiles::out_name
  io::FrameWriteOptions exr;
};
struct ExtrapolateRunStats {
  size_t frames = 0, synthesized = 0;
  double mean_hole_fraction = 0, max_hole_fraction = 0;
  double seconds = 0;
  std::string layout;  // io::SequenceReader::layout_choice
};
// After each frame written: (position, total, output path, report or null for a rendered one).
using ExtrapolateProgressFn =
    std::function<void(size_t k, size_t total, const std::string& path, const SynthesisReport*)>;
ExtrapolateRunStats extrapolate_files(const ExtrapolateFiles& files,
                                      const ExtrapolateSettings& settings, const Exec& ex,
                                      const ExtrapolateProgressFn& progress = {},
                                      const WarnFn& note = {});

}  // namespace afterimage
