#include "core/image.h"

#include "core/frame_buffer_cache.h"

#include <cstdint>
#include <mutex>
#include <new>
#include <unordered_map>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace afterimage {

void advise_huge_pages(void* p, size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  // From the 2 MB page the buffer starts in (its head shares that page with what lies before,
  // as glibc's own huge-page option advises its chunks) to the buffer's end.
  constexpr uintptr_t kPage = uintptr_t(2) << 20;
  const uintptr_t begin = reinterpret_cast<uintptr_t>(p) & ~(kPage - 1);
  const uintptr_t end = reinterpret_cast<uintptr_t>(p) + bytes;
  // Advice only: a kernel without transparent huge pages refuses it, which changes nothing.
  if (p && bytes > 0) (void)madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
  (void)p;
  (void)bytes;
#endif
}

namespace {
constexpr std::align_val_t kFrameAlign{64};
}  // namespace

void* FrameBufferCache::take(size_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (size_t i = free_.size(); i-- > 0;)
    if (free_[i].bytes >= bytes && free_[i].bytes / 4 <= bytes) {
      const Block b = free_[i];
      live_.emplace(b.p, b.bytes);
      free_.erase(free_.begin() + ptrdiff_t(i));
      cached_ -= b.bytes;
      return b.p;
    }
  void* p = ::operator new(bytes, kFrameAlign);  // std::bad_alloc as any allocation
  try {
    live_.emplace(p, bytes);
  } catch (...) {
    ::operator delete(p, bytes, kFrameAlign);
    throw;
  }
  if (bytes >= DefaultInitAllocator<float>::kHugeFrom) advise_huge_pages(p, bytes);
  return p;
}

void FrameBufferCache::give(void* p, size_t bytes) noexcept {
  std::lock_guard<std::mutex> lock(mutex_);
  if (const auto it = live_.find(p); it != live_.end()) {
    bytes = it->second;
    live_.erase(it);
  }
  if (bytes > limit_) {
    ::operator delete(p, bytes, kFrameAlign);
    return;
  }
  try {
    free_.push_back({p, bytes});
  } catch (const std::bad_alloc&) {  // no room to remember it
    ::operator delete(p, bytes, kFrameAlign);
    return;
  }
  cached_ += bytes;
  // Over the limit, the oldest leave first.
  size_t n = 0;
  for (; cached_ > limit_ && n < free_.size(); ++n) {
    cached_ -= free_[n].bytes;
    ::operator delete(free_[n].p, free_[n].bytes, kFrameAlign);
  }
  free_.erase(free_.begin(), free_.begin() + ptrdiff_t(n));
}

size_t FrameBufferCache::release() noexcept {
  std::vector<Block> all;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    all.swap(free_);
    cached_ = 0;
  }
  size_t bytes = 0;
  for (const Block& b : all) {
    ::operator delete(b.p, b.bytes, kFrameAlign);
    bytes += b.bytes;
  }
  return bytes;
}

size_t FrameBufferCache::default_limit() {
#if defined(__SANITIZE_ADDRESS__)
  return 0;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  return 0;
#endif
#endif
#if defined(__linux__)
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  if (pages > 0 && page > 0) return size_t(pages) / 8 * size_t(page);
#endif
  return size_t(1) << 30;
}

namespace {

// Never destroyed: images in static storage may be freed after any destructor would run.
FrameBufferCache& frame_buffer_cache() {
  static FrameBufferCache* cache = new FrameBufferCache(FrameBufferCache::default_limit());
  return *cache;
}

}  // namespace

void* allocate_frame_buffer(size_t bytes) {
  return frame_buffer_cache().take(bytes);
}
void free_frame_buffer(void* p, size_t bytes) noexcept {
  if (p) frame_buffer_cache().give(p, bytes);
}
size_t release_cached_frame_buffers() noexcept {
  return frame_buffer_cache().release();
}

}  // namespace afterimage
