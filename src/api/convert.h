// Between the public API's types (include/afterimage/afterimage.hpp) and the modules': the
// caller's strided buffers to planar images and back, a FrameInput to a Frame, the camera.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "afterimage/afterimage.hpp"
#include "core/image.h"
#include "core/parallel.h"
#include "frame/frame.h"
#include "frame/sequence_method.h"

namespace afterimage::api {

Exec to_exec(const ExecOptions& o);

// A spec that names a post stage or lists several stages ("taa,bloom") is a chain
// (run/post_pipeline.h, `afterimage run`); any other is one registry method (run/methods.h).
bool is_chain(const std::string& spec);
// The method or chain of `spec` with `settings` ("key=value" for a method, "stage.key=value"
// for a chain); `display_output` as make_pipeline_method's.
std::unique_ptr<SequenceMethod> make_method_or_chain(const std::string& spec,
                                                     const std::vector<std::string>& settings,
                                                     const Exec& ex, bool display_output = false);

// InputError "<what>: <problem>" unless `b` is a usable view of width x height (0: any) with
// `min_channels`..`max_channels` channels.
void check_view(const BufferView& b, const std::string& what, int min_channels, int max_channels,
                int width = 0, int height = 0);
// Channel c of `b` alone, as a 1-channel view with `b`'s strides (RGBA's alpha).
BufferView channel_view(const BufferView& b, int c);
// The first `channels` channels of `b` as a planar float image (f16 widened, u32 converted).
ImageF to_image(const BufferView& b, int channels);
// `b` (1 channel, u32 or f32 holding integers) as ids.
ImageU32 to_ids(const BufferView& b, const std::string& what);
// Writes `img`'s planes into the first img.channels() channels of `out` (f32 or f16, rounded to
// nearest even), and `fill` into any channel after them.
void write_image(const ImageF& img, const BufferView& out, float fill = 1.0f);
void write_ids(const ImageU32& img, const BufferView& out);

// The camera part of a frame header, both ways.
void apply_camera(const FrameCamera& c, FrameHeader& h);
FrameCamera camera_of(const FrameHeader& h);

// A Frame from the caller's buffers (copied), through its conventions, with ReadPolicy's
// repairs of non-finite values (warnings to `note`); InputError naming `what`.
Frame to_frame(const FrameInput& in, const std::string& what, const WarnFn& note = {});

}  // namespace afterimage::api
