// The cache behind allocate_frame_buffer / free_frame_buffer (core/image.h): freed frame
// buffers kept mapped for the next request of about their size. The process uses one
// (image.cpp); the class is here so that its policy can be tested with a limit of the test's
// choosing.
#pragma once

#include <cstddef>
#include <mutex>
#include <unordered_map>
#include <vector>

namespace afterimage {

// The freed frame buffers, oldest first. A request takes the most recently freed buffer of at
// least its size and at most four times it: the one likeliest still in cache. On the 1080p
// chain (2 threads, with the CLI's mallopt, against glibc's heap; mean differences of 3-8
// alternating runs) exact sizes only measured +1.5 ms, the smallest fitting buffer +1.2, up to
// twice the size +0.3 to +0.9, up to four times -0.1, any size -0.5 to +0.2.
// At most `limit` bytes are kept: a freed buffer larger than the limit goes back to the system,
// and over the limit the buffers freed longest ago leave first (the least likely still in
// cache).
class FrameBufferCache {
 public:
  explicit FrameBufferCache(size_t limit) : limit_(limit) {}
  FrameBufferCache(const FrameBufferCache&) = delete;
  FrameBufferCache& operator=(const FrameBufferCache&) = delete;
  ~FrameBufferCache() { release(); }

  // A buffer of `bytes` (64-byte aligned): a cached one, or new (std::bad_alloc as any
  // allocation).
  void* take(size_t bytes);
  // Back to the cache (p from take; `bytes` is ignored for a buffer take handed out, whose
  // own size is remembered).
  void give(void* p, size_t bytes) noexcept;
  // Every cached buffer back to the system; returns their bytes.
  size_t release() noexcept;
  size_t cached_bytes() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return cached_;
  }

  // An eighth of the physical memory (after a 1080p post chain frame the cache holds ~100 MB);
  // none under AddressSanitizer, whose use-after-free checks a reused buffer would hide.
  static size_t default_limit();

 private:
  struct Block {
    void* p;
    size_t bytes;
  };
  mutable std::mutex mutex_;
  std::vector<Block> free_;
  std::unordered_map<void*, size_t> live_;  // buffers handed out: their sizes
  size_t cached_ = 0;
  const size_t limit_;
};

}  // namespace afterimage
