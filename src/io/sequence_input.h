// Reading an input sequence of any supported tool (DESIGN.md §3 "Files"): where the frames
// are, which layout reads them, where jitter and camera come from. Every command that reads
// frames (resolve, eval) goes through SequenceReader, so layouts, conventions and sidecars
// behave the same everywhere.
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "camera/camera.h"
#include "frame/frame.h"
#include "frame/layout.h"
#include "io/io.h"
#include "io/layouts.h"

namespace afterimage::io {

struct SequenceInput {
  std::string dir;
  std::string name;               // file stem; "" = the only stem in `dir`
  std::string layout = "auto";    // see resolve_layout
  std::vector<std::string> maps;  // --map overrides, in order
  std::string jitter;             // "" = from the files; "none"; "haltonN[:start]"
  std::string jitter_file;        // camera sidecar (see CameraRecord); overrides `jitter`
  // With neither jitter nor jitter_file: a kCameraSidecarName beside the frames gives them
  // (false for sequences whose camera does not matter, e.g. eval's references).
  bool sidecar_beside = true;
};

// The camera sidecar's name beside the frames: with no --jitter or --jitter-file, a sequence
// whose files carry no camera (Blender's, an engine's) takes it from `dir`/kCameraSidecarName
// when that file exists (the reader notes it; --jitter none ignores it). The name our Blender
// script writes (tests/data/blender/make_blender_set.py).
inline constexpr const char* kCameraSidecarName = "jitter.json";

// One frame of a camera sidecar (tests/data/blender/*/jitter.json):
//   {"frames": [{"frame": 1, "jitter": [x, y], "view": [16], "projection": [16],
//                "lens": {"f_number": 2.8, "focal_length_mm": 50, "focus_distance": 4,
//                         "sensor_width_mm": 36, "blades": 0, "blade_rotation_deg": 0}}, ...]}
// jitter in pixels, y down; view (world to camera) and the unjittered projection row-major,
// our conventions (DESIGN.md §3); the lens as camera/camera.h's ThinLens (focus distance in
// scene units along the view axis; sensor width, blades and rotation optional: 36 mm, disc,
// 0). "frame", the matrices and the lens are optional.
struct CameraRecord {
  int frame = -1;  // -1: matched by position
  Vec2d jitter{0.0, 0.0};
  bool has_camera = false;
  Mat4 view = Mat4::identity(), projection = Mat4::identity();
  bool has_lens = false;
  ThinLens lens;
};
std::vector<CameraRecord> parse_camera_sidecar(const std::string& text, const std::string& what);
std::vector<CameraRecord> read_camera_sidecar(const std::string& path);

// Receives one-line notes for the user (the CLI prints them on stderr): layout chosen,
// camera unknown, and the warnings of repaired input (io::ReadPolicy).
using NoteFn = WarnFn;

// What to tell the user of a sequence's gaps (`gap` as SequenceReader::check_all gives it):
// frame numbers that do not follow the frame before, so that its motion vectors point to a
// frame that is not there and `consequence` follows ("history restarts"). A sequence
// rendered every Nth frame is one line, not one a frame; otherwise a line a gap, at most three,
// then one counting the rest. Empty without gaps.
std::vector<std::string> describe_gaps(const std::vector<SequenceFile>& files,
                                       const std::vector<bool>& gap, std::string_view consequence);

class SequenceReader {
 public:
  // Lists the frames, chooses the layout (noting an automatic choice) and loads the sidecar;
  // the first read() that needs motion notes when the camera is unknown.
  explicit SequenceReader(const SequenceInput& in, const NoteFn& note = {});

  size_t size() const { return files_.size(); }
  const std::vector<SequenceFile>& files() const { return files_; }
  const Layout& layout() const { return layout_; }
  // Which layout reads the frames and how it was chosen, for a summary line: "afterimage
  // (recognised)", "blender:ViewLayer (recognised)", or the name given to --layout.
  const std::string& layout_choice() const { return layout_choice_; }
  bool camera_known() const { return camera_known_; }

  // Frame i through the layout, then: jitter and camera from the sidecar or --jitter,
  // named depth / motion conventions, and (camera known, foreign files) background motion
  // from the camera change.
  // Non-finite values as io::ReadPolicy says (warnings go to the note function);
  // `refuse_non_finite_color` for scoring. `load`: channels to load besides `required`
  // (io::ReadPolicy::load; empty = all).
  Frame read(size_t i, ChannelSet required, std::string_view required_by,
             InputRegistry* inputs = nullptr, bool refuse_non_finite_color = false,
             ChannelSet load = {}) const;
  // io::check_frame_header of frame i through this reader's layout (no pixel is read), with
  // the frame number, jitter, camera and lens read() gives it.
  FrameHeader check(size_t i, ChannelSet required, std::string_view required_by) const;
  // check() of every frame, frame i needing required_of(i); then one size for all (InputError
  // naming the first frame that differs). Returns the headers and, per frame, whether its
  // number does not follow the previous frame's (a gap: the callers' motion and history
  // refer to a frame that is not there).
  struct SequenceShape {
    std::vector<FrameHeader> headers;  // one a frame; all of one size
    std::vector<bool> gap;
  };
  SequenceShape check_all(const std::function<ChannelSet(size_t)>& required_of,
                          std::string_view required_by) const;

 private:
  const CameraRecord* record(size_t i) const;
  // What the reader sets in frame i's header besides the file's own: the number from the file
  // name (foreign files), the sidecar's jitter, camera and lens, or --jitter's jitter.
  void apply_sidecar(size_t i, FrameHeader& h) const;

  SequenceInput in_;
  std::vector<SequenceFile> files_;
  Layout layout_{"auto"};
  std::string layout_choice_;
  std::vector<CameraRecord> sidecar_;
  bool camera_known_ = false;
  JitterSequence halton_{JitterPattern::None, 1};
  long halton_start_ = 0;
  bool jitter_override_ = false;
  NoteFn note_;
  mutable bool camera_noted_ = false;  // the camera note is said once per sequence
};

}  // namespace afterimage::io
