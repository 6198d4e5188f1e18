// Shared helpers of the fuzz harnesses (tests/fuzz/README.md). Every harness defines
// LLVMFuzzerTestOneInput; the same source links either with libFuzzer (clang,
// AFTERIMAGE_BUILD_FUZZERS) or with replay_main.cpp (any compiler, CTest corpus replay).
//
// Outcome policy: afterimage::InputError and afterimage::SettingsError are the expected answer
// to hostile bytes, so expect_errors() swallows exactly those. Anything else — another
// exception (it escapes, std::terminate aborts), a crash, an AI_CHECK abort, a sanitizer
// report, an allocation over -malloc_limit_mb — is a finding.
#pragma once

#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <type_traits>

#include "core/error.h"
#include "frame/frame.h"

namespace afterimage::fuzz {

// Runs fn(); returns true if it completed, false if it threw InputError or SettingsError.
template <class Fn>
bool expect_errors(Fn&& fn) {
  try {
    fn();
    return true;
  } catch (const InputError&) {
  } catch (const SettingsError&) {
  }
  return false;
}

[[noreturn]] inline void harness_failure(const char* what) {
  std::fprintf(stderr, "fuzz harness: %s: %s\n", what, std::strerror(errno));
  std::abort();
}

// One scratch file per process, reused by every input: "<tmp>/afterimage-fuzz-<pid>-<tag><ext>"
// (TMPDIR picks the directory; run_fuzzer.sh points it at /dev/shm). Removed at exit.
class ScratchFile {
 public:
  ScratchFile(const std::string& tag, const std::string& ext) {
    path_ = (std::filesystem::temp_directory_path() /
             ("afterimage-fuzz-" + std::to_string(::getpid()) + "-" + tag + ext))
                .string();
  }
  ~ScratchFile() { ::unlink(path_.c_str()); }
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;

  const std::string& path() const { return path_; }

  // Replaces the file's content with `size` bytes (plain write(): the harness's own I/O, not
  // the code under test).
  void write(const void* data, size_t size) const {
    const int fd = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd < 0) harness_failure("cannot create the scratch file");
    const auto* p = static_cast<const unsigned char*>(data);
    while (size > 0) {
      const ssize_t n = ::write(fd, p, size);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) harness_failure("cannot write the scratch file");
      p += n;
      size -= size_t(n);
    }
    if (::close(fd) != 0) harness_failure("cannot close the scratch file");
  }

 private:
  std::string path_;
};

// A deterministic w x h frame with every channel of the table (the seed frames and the
// frames the harnesses push through a loaded method): smooth values, a little motion, ids
// OpenImageIO / OpenEXR decode on the calling thread: deterministic, and no thread pools in
// the way of the sanitizers (the harnesses that read image files call it once).
inline void decode_on_calling_thread() {
  OIIO::attribute("threads", 1);
  OIIO::attribute("exr_threads", 1);
}

// 0..3, depth with one background pixel.
inline Frame tiny_frame(int w, int h, int index) {
  ChannelSet all;
  for (const ChannelInfo& r : kChannelTable) all.insert(r.key);
  Frame f = Frame::allocate(w, h, all);
  f.index = index;
  f.time = index / 24.0;
  f.jitter = {0.25 * ((index & 1) ? 1 : -1), -0.125};
  for (const ChannelInfo& r : kChannelTable)
    f.visit(r.key, [&](auto& img) {
      for (int c = 0; c < img.channels(); ++c)
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x) {
            using T = std::remove_reference_t<decltype(img.at(x, y, c))>;
            const int v = (x * 7 + y * 13 + c * 5 + int(r.key) * 3 + index) % 16;
            if constexpr (std::is_same_v<T, uint32_t>)
              img.at(x, y, c) = uint32_t(v % 4);
            else
              img.at(x, y, c) = float(v) / 16.0f;
          }
    });
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.depth.at(x, y, 0) = 1.0f + 0.25f * float(x + y);
      f.motion.at(x, y, 0) = 0.5f;
      f.motion.at(x, y, 1) = -0.25f;
    }
  f.depth.at(w - 1, 0, 0) = kBackgroundDepth;
  return f;
}

}  // namespace afterimage::fuzz
