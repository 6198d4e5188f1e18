// Video export with ffmpeg (Debian's `ffmpeg` package), for side-by-side demo clips.
#pragma once

#include <functional>
#include <string>

#include "core/image.h"

namespace afterimage::io {

// True if an executable named `name` is on PATH.
bool have_program(const std::string& name);

// Writes `frames` display images (3 planes, sRGB-encoded values in [0, 1], all of one size)
// as an H.264 MP4 (yuv420p, CRF 18) at `fps`; frame(t) supplies frame t, so a long clip is
// never held in memory. Encoded to a temporary name and renamed into place. Throws
// OutputError if ffmpeg is missing or fails.
void write_mp4(const std::string& path, size_t frames, const std::function<ImageF(size_t)>& frame,
               int fps = 30);

}  // namespace afterimage::io
