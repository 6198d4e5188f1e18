// Limits on what a file or an argument may ask of the machine (issue 9, "memory exhaustion
// from small inputs"): image sizes are checked from headers before any allocation, thread
// counts before an arena is created. The values are generous for rendering work (8K x 8K,
// 13 float channels = 3.5 GB per frame) and far below what crashes a 24 GB machine.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <fmt/format.h>

namespace afterimage {

inline constexpr int64_t kMaxImageSide = 65536;
inline constexpr int64_t kMaxImagePixels = int64_t(8192) * 8192;
// TBB creates one OS thread per arena slot; tens of thousands exhaust the process (a crash
// inside a worker was seen at about 70000).
inline constexpr int kMaxThreads = 1024;

// Why a width x height image is not acceptable, or nothing if it is.
inline std::optional<std::string> image_size_problem(int64_t width, int64_t height) {
  if (width <= 0 || height <= 0) return fmt::format("empty image size {}x{}", width, height);
  if (width > kMaxImageSide || height > kMaxImageSide || width * height > kMaxImagePixels)
    return fmt::format(
        "size {}x{} exceeds the limit of {} pixels per side and {} pixels "
        "(8192x8192) in all",
        width, height, kMaxImageSide, kMaxImagePixels);
  return std::nullopt;
}

// Why `threads` is not an acceptable --threads value (0 = all hardware threads), or nothing.
inline std::optional<std::string> thread_count_problem(int64_t threads) {
  if (threads < 0 || threads > kMaxThreads)
    return fmt::format("thread count {} outside [0, {}] (0 = all hardware threads)", threads,
                       kMaxThreads);
  return std::nullopt;
}

}  // namespace afterimage
