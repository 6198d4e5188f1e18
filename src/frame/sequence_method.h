// The interface every temporal technique implements (DESIGN.md §2): a method consumes a
// frame sequence one frame at a time, keeps its own history, and returns one output frame per
// input frame. TAA implements it now (taa/taa_method.h); SVGF and the reprojection cache
// follow. `run/methods.h` registers methods by name ("taa:hdrp", ...) and
// `run/sequence.h` runs any of them over files or in-memory frames, so commands, the demo
// and the bench are loops over this interface and never name a technique's classes.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/parallel.h"
#include "frame/frame.h"

namespace afterimage {

// Planes of 4-byte values per output pixel that one frame streams: each plane read at least
// once (a 3x3 neighbourhood or a resampling footprint counts once, as its rows stay in cache),
// each written plane once. `afterimage bench` times its bandwidth floor over exactly these
// (DESIGN.md §5, "The bandwidth floor").
struct PlaneTraffic {
  int read = 0, write = 0;
};

class SequenceMethod {
 public:
  virtual ~SequenceMethod() = default;

  // Registry name with its overrides, e.g. "taa:afterimage" (for reports and errors).
  virtual std::string name() const = 0;
  // Channels a frame must carry (rows of frame/channels.inc): readers ask for exactly these,
  // so a missing one is a one-line error naming the file, the channel and this method.
  virtual ChannelSet required_channels() const = 0;
  // Channels the method reads when a frame carries them (a superset of required_channels):
  // readers that write only the method's output load just these.
  virtual ChannelSet used_channels() const { return required_channels(); }
  // Size of the output frames for inputs of width x height: the same for most methods, larger
  // for upsampling (taau/). Throws InputError for input sizes the method cannot process, so
  // commands refuse them before writing anything.
  virtual std::pair<int, int> output_size(int width, int height) const { return {width, height}; }
  // Throws InputError for a frame the method cannot process, judged by its header alone (the
  // DoF's lens, motion blur's camera), so commands refuse it before writing anything; `note` (given
  // for a sequence's first frame only) hears what the user should know about the run, e.g. that a
  // stage will leave every frame unchanged.
  virtual void check_header(const FrameHeader& /*header*/, const WarnFn& /*note*/) const {}

  // Processes the next frame of the sequence: the output has the input's header (camera; the
  // size output_size gives) and the channels the technique produces (`color` at least);
  // run_sequence hands it the rest of the input G-buffer (Frame::adopt_missing_channels) when
  // the sizes agree, so methods never copy planes they do not change. Throws InputError on unusable
  // frames.
  virtual Frame process(const Frame& frame) = 0;
  // Forgets all history: the next frame starts a new sequence.
  virtual void reset() = 0;
  // Continuation across runs: saving after frame k and loading into a method with the same
  // settings continues bit-identically. load_state changes nothing unless the file is valid.
  virtual void save_state(const std::string& path) const = 0;
  virtual void load_state(const std::string& path) = 0;

  // Every setting of this instance, as JSON text (reports) and as a listing (--list-settings).
  virtual std::string settings_json() const = 0;
  virtual std::string describe_settings() const = 0;

  virtual void set_exec(const Exec& exec) = 0;

  // The planes the last process() streamed (PlaneTraffic); {0, 0} when a method does not
  // report them (the bench then takes its family's minimum).
  virtual PlaneTraffic last_traffic() const { return {}; }
};

}  // namespace afterimage
