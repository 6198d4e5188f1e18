// Reading and writing frames and images with OpenImageIO (the only module that uses OIIO).
// File layout (DESIGN.md §3): one OpenEXR per frame, <name>.<frame:04d>.exr, the channels of
// the table in frame/channels.inc (R G B, Z, N.X N.Y N.Z, albedo.R albedo.G albedo.B,
// motion.X motion.Y, id, then the optional rows) in table order; header
// attributes afterimage:view, afterimage:projection (row-major), afterimage:jitter,
// afterimage:frame, afterimage:time, afterimage:lens_* (focal mm, f-number, focus distance,
// sensor width mm, blades, blade rotation deg), afterimage:camera_cut.
// Every write goes through core/atomic_file.h (unique temporary, synced, renamed into place)
// and throws OutputError when it fails; no write replaces a file that was read as input in
// the same process (see InputRegistry).
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "frame/frame.h"
#include "frame/layout.h"

namespace afterimage::io {

// Files opened for reading in this run; writers refuse to replace them.
class InputRegistry {
 public:
  void add(const std::string& path);
  bool contains(const std::string& path) const;
  // Throws InputError "<path>: refusing to overwrite an input file" if `path` is a registered
  // input: a usage error (an input named as output), not a failed write, so not OutputError.
  void check_writable(const std::string& path) const;

 private:
  std::vector<std::string> canonical_;
};

// "<dir>/<name>.<frame:04d>.exr"
std::string frame_path(const std::string& dir, int frame, const std::string& name = "frame");

// What read_frame does with values no renderer should write (issue 9: non-finite values never
// reach history or an output file). Every channel but color is always repaired, with one
// warning per channel and file: depth NaN or <= 0 -> background (+Inf and huge values are
// background by convention, silently); any other float channel non-finite -> 0 (a zero
// normal fails every normal-consistency test, so such a pixel never reuses history).
struct ReadPolicy {
  // Color: false = loaded as is and counted in a warning; every SequenceMethod replaces
  // non-finite color before it reaches history or output (TAA: by the neighbourhood mean,
  // core/sanitize.h). true = InputError naming the first bad pixel (scoring: eval, compare).
  bool refuse_non_finite_color = false;
  WarnFn warn;  // receives "warning: <path>: <count> <what was done>"
  // Channels to load besides `required`; empty = every channel the layout maps and the file
  // holds. The header check covers every mapped channel either way.
  ChannelSet load;
};

// ReadPolicy's repairs of a loaded frame's non-finite values (and refusal of non-finite color
// when the policy says so), warnings naming `what`: read_frame's, and the library API's for
// frames built from a caller's buffers.
void repair_non_finite(Frame& f, const std::string& what, const ReadPolicy& policy);

// How write_frame stores pixels. Defaults chosen by measurement (DESIGN.md §3 "Compression").
struct FrameWriteOptions {
  // OpenEXR compression: none, rle, zips, zip, piz, pxr24, b44, b44a, dwaa, dwab (dwaa:Q and
  // zip:LEVEL as OpenImageIO spells them). See check_exr_compression.
  std::string compression = "none";
  // Color (R G B) stored as 16-bit half (values beyond half's range clamped to +-65504); every
  // other channel keeps its table type, so depth, motion and ids stay exact.
  bool half_color = false;
};
// Throws SettingsError unless `c` names an OpenEXR compression (with an optional ":N").
void check_exr_compression(const std::string& c);

// Writes every present channel of `f` in table order, each with its table pixel type, and
// the camera metadata (atomic).
void write_frame(const std::string& path, const Frame& f, const InputRegistry* inputs = nullptr,
                 const FrameWriteOptions& options = {});

// OpenImageIO's global settings for this process: `threads` (0 = all) for its own pools and
// OpenEXR's (exr_threads), which decode and encode line blocks in parallel. Reading goes
// through OpenEXR's core library (OIIO "openexr:core"), measured 2-10x faster than the C++
// API on our files (DESIGN.md §3 "Compression").
void set_io_threads(int threads);

// Reads a frame through `layout` (default: our own files, as write_frame writes them). Every
// channel the layout maps and the file holds is loaded (or those of ReadPolicy::load); the
// others stay empty. All loaded channels come from one decode of the file (one read over a
// channel range: OpenEXR decompresses whole line blocks, so a read per channel would
// decompress the file once per channel). `required`
// channels must be present; `required_by` names who needs them (a technique, "taa"), for the
// one-line error "<path>: missing channel(s) motion.X motion.Y (motion, required by taa)".
// A partly present channel is an error too; so is a channel stored with a pixel type that
// OpenImageIO would rescale (integer color/depth/motion, float id), a file that is not a
// regular readable file, a deep image, or one larger than core/limits.h allows (checked from
// the header, before any allocation). Non-finite values: see ReadPolicy. The header must be
// finite (camera matrices, time, lens) and the jitter within [-0.5, 0.5]. Throws InputError
// "<path>: <problem>".
Frame read_frame(const std::string& path, ChannelSet required, std::string_view required_by,
                 InputRegistry* inputs = nullptr, const Layout& layout = afterimage_layout(),
                 const ReadPolicy& policy = {});
// The same with requirements spelled as channel keys ("color", "depth", "motion", ...; see
// the name column of the table). Throws SettingsError on an unknown key.
Frame read_frame(const std::string& path, const std::vector<std::string>& required = {"color"},
                 InputRegistry* inputs = nullptr, const Layout& layout = afterimage_layout());

// Everything read_frame checks before it reads pixel data, from the header alone: regular
// readable file, not deep, size within limits, the layout's channels for `required` present
// with usable pixel types. Commands call it on every frame of a sequence before writing any
// output (issue 9: check before writing). Returns the file's header (size, and the camera and
// lens metadata our files carry; defaults, lens_known false, for files without). Throws
// InputError.
FrameHeader check_frame_header(const std::string& path, ChannelSet required,
                               std::string_view required_by,
                               const Layout& layout = afterimage_layout());

// One frame file of a sequence directory.
struct SequenceFile {
  int number = 0;  // the frame number in the file name
  std::string path;
};
// What a sequence directory holds: linear EXR frames (every command), or display images
// (PNG / JPEG, 8-bit sRGB after a tonemap: `resolve --out-format png|jpg`), which `eval`
// scores as display-referred outputs.
enum class SequenceKind { exr, display };
// The frames <dir>/<name><sep><digits>.exr (display: .png, .jpg or .jpeg, any case) with sep
// '.' (ours: frame.0001.exr) or '_' (Blender's name_####), sorted by number. `name` is a
// file-name stem taken literally (no pattern characters); "" takes the only stem in the
// directory (InputError if there are several). Throws InputError if the directory is missing
// or holds no such frames, if two files carry the same number (frame.0003.exr,
// frame.003.exr) or a number has more than 9 digits; SettingsError if `name` holds '/'.
std::vector<SequenceFile> scan_sequence(const std::string& dir, const std::string& name = "",
                                        SequenceKind kind = SequenceKind::exr);
// The kind of frames `dir` holds: display if it has PNG / JPEG frames and no EXR frames, else
// exr (scan_sequence then reports what is missing).
SequenceKind sequence_kind(const std::string& dir);
// The file name an output of input frame `in` gets: the input's own name with extension `ext`
// (".exr", ".png", ...) if `name` is empty, else NAME.NNNN<ext> with the input's frame number
// (at least 4 digits). Throws SettingsError if `name` holds a slash, a backslash or NUL.
std::string sequence_output_name(const SequenceFile& in, const std::string& name,
                                 std::string_view ext);
// The paths of scan_sequence.
std::vector<std::string> list_sequence(const std::string& dir, const std::string& name = "");

// Plain RGB images (compare / metrics / report). EXR and other float formats are read as
// linear; 8/16-bit PNG is read as sRGB-encoded and decoded to linear when `decode_srgb`.
ImageF read_rgb(const std::string& path, bool decode_srgb = true, InputRegistry* inputs = nullptr);
// Every channel of an image file as float planes, no color decoding (test data, maps).
ImageF read_channels(const std::string& path, InputRegistry* inputs = nullptr);
// Throws InputError "<path>: size WxH differs from the sequence's WxH" on mismatch.
void check_same_size(const Frame& f, int width, int height, const std::string& path);
// Writes an RGB(A) float image: EXR as linear float (ZIP); PNG and JPEG take values already
// encoded for display in [0, 1] and quantise to 8 bits (rounding to nearest).
void write_rgb(const std::string& path, const ImageF& img, const InputRegistry* inputs = nullptr);
// Encodes an 8-bit PNG into memory (for the HTML report's embedded images).
std::vector<unsigned char> encode_png(const ImageF& display_rgb);
// Writes a text file (JSON, HTML) atomically, refusing to replace a registered input.
// Throws OutputError when the write fails.
void write_text(const std::string& path, std::string_view text,
                const InputRegistry* inputs = nullptr);

// Channel names of an image file in file order, opened with every check read_frame makes
// before reading (regular file, OpenEXR header walk, size limit). Throws InputError.
std::vector<std::string> file_channel_names(const std::string& path);

// Header metadata of any image file, for `afterimage info`: one "key: value" per line.
std::string describe_file(const std::string& path);

}  // namespace afterimage::io
