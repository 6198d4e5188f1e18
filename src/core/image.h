// Image<T>: planar storage (one contiguous plane per channel), row-major, origin top-left.
// Pixel (i, j) covers [i, i+1) x [j, j+1); its center is (i + 0.5, j + 0.5) (DESIGN.md §3).
// Planar layout lets per-pixel kernels load a full SIMD vector of one channel per row.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/error.h"

namespace afterimage {

// Advises the 2 MB pages from the one p starts in to p + bytes into transparent huge pages
// (Linux madvise MADV_HUGEPAGE; the kernel backs those wholly inside the mapping; a no-op
// elsewhere or when refused). Changes no value: only how many TLB entries the planes need.
void advise_huge_pages(void* p, size_t bytes) noexcept;

// Frame buffers (DefaultInitAllocator::kCachedFrom bytes and up) from a process-wide cache of
// freed ones: a buffer freed by one frame's pass is handed, its pages still mapped, to a later
// request of up to its size (image.cpp FrameBufferCache). Without it a program using the
// library paid for glibc's defaults, which the CLI raises (mallopt in apps/cli/main.cpp): every
// block above glibc's largest dynamic mmap threshold (32 MB: the 1080p DoF grid, any 4K plane)
// was a fresh mapping each frame whose pages the kernel zeroed again, and the heap's top was
// trimmed and faulted in again below it. The 1080p post chain on 2 threads, called without
// mallopt: 35-43 ms a frame before, 26-28 with the cache, as the CLI (668c016;
// docs/perf/2026-log.md). Values are never read from a reused buffer (Image fills it or a pass
// writes it), so the cache changes no result. It keeps at most an eighth of the physical memory
// (evicting the buffers freed longest ago) and is off under AddressSanitizer, so that a use after
// free stays detectable.
void* allocate_frame_buffer(size_t bytes);
void free_frame_buffer(void* p, size_t bytes) noexcept;
// Returns every cached buffer to the system (a long-running program between sequences);
// returns the bytes released.
size_t release_cached_frame_buffers() noexcept;

// std::allocator whose value-less construct() default-initialises: a vector<float> of n
// elements is then not zero-filled. Only Image::uninitialized() relies on it; every other
// construction passes a value. Storage starts on a 64-byte boundary (a cache line, an AVX-512
// vector), so a plane whose size is a multiple of 16 values starts aligned and kernels can use
// streaming stores on it (core/simd.h store_streaming); alignment changes no value.
// Buffers of kHugeFrom bytes or more (a 960x540 three-plane image and up) are advised into
// transparent huge pages before their first touch: a 1080p plane spans 2025 4 KB pages, and a
// pass that reads several planes likely outruns the second-level TLB (each miss a two-level
// page walk in a VM; no counters here to confirm the cause, only the time). `post.chain` at 1080p
// on 2 threads, 8 alternating runs: 30.2-33.1 -> 29.0-30.4 ms (543f383). The
// heap (the CLI's mallopt) and the frame buffer cache keep them between frames, so their huge
// pages are zeroed once.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  static constexpr std::align_val_t kAlign{64};
  static constexpr size_t kHugeFrom = size_t(4) << 20;
  // Buffers of this size and up come from the frame buffer cache (allocate_frame_buffer): glibc's
  // initial mmap threshold, above which its freed blocks leave the process.
  static constexpr size_t kCachedFrom = size_t(128) << 10;
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  T* allocate(size_t n) {
    const size_t bytes = n * sizeof(T);
    if (bytes >= kCachedFrom) return static_cast<T*>(allocate_frame_buffer(bytes));
    return static_cast<T*>(::operator new(bytes, kAlign));
  }
  void deallocate(T* p, size_t n) noexcept {
    const size_t bytes = n * sizeof(T);
    if (bytes >= kCachedFrom)
      free_frame_buffer(p, bytes);
    else
      ::operator delete(p, bytes, kAlign);
  }
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

template <class T>
class Image {
 public:
  using Storage = std::vector<T, DefaultInitAllocator<T>>;

  Image() = default;
  Image(int width, int height, int channels, T fill = T{})
      : w_(width), h_(height), c_(channels), data_(size_t(width) * height * channels, fill) {
    AI_CHECK(width >= 0 && height >= 0 && channels >= 0);
  }
  // An image whose values are indeterminate: for outputs a pass writes completely (skips
  // the serial zero fill of a large allocation). Reading a value before writing it is a bug.
  static Image uninitialized(int width, int height, int channels) {
    AI_CHECK(width >= 0 && height >= 0 && channels >= 0);
    Image img;
    img.w_ = width;
    img.h_ = height;
    img.c_ = channels;
    img.data_ = Storage(size_t(width) * height * channels);
    return img;
  }

  int width() const { return w_; }
  int height() const { return h_; }
  int channels() const { return c_; }
  size_t plane_size() const { return size_t(w_) * h_; }
  bool empty() const { return data_.empty(); }
  bool same_shape(const Image& o) const { return w_ == o.w_ && h_ == o.h_ && c_ == o.c_; }

  T* plane(int c) {
    AI_DCHECK(c >= 0 && c < c_);
    return data_.data() + size_t(c) * plane_size();
  }
  const T* plane(int c) const {
    AI_DCHECK(c >= 0 && c < c_);
    return data_.data() + size_t(c) * plane_size();
  }
  T* row(int c, int y) { return plane(c) + size_t(y) * w_; }
  const T* row(int c, int y) const { return plane(c) + size_t(y) * w_; }

  T& at(int x, int y, int c) {
    AI_DCHECK(x >= 0 && x < w_ && y >= 0 && y < h_);
    return plane(c)[size_t(y) * w_ + x];
  }
  const T& at(int x, int y, int c) const {
    AI_DCHECK(x >= 0 && x < w_ && y >= 0 && y < h_);
    return plane(c)[size_t(y) * w_ + x];
  }
  // Clamp-to-edge read (border handling of neighbourhood kernels).
  const T& at_clamped(int x, int y, int c) const {
    x = x < 0 ? 0 : (x >= w_ ? w_ - 1 : x);
    y = y < 0 ? 0 : (y >= h_ ? h_ - 1 : y);
    return plane(c)[size_t(y) * w_ + x];
  }

  Storage& data() { return data_; }
  const Storage& data() const { return data_; }
  void fill(T v) { std::fill(data_.begin(), data_.end(), v); }

  bool operator==(const Image& o) const = default;

 private:
  int w_ = 0, h_ = 0, c_ = 0;
  Storage data_;
};

using ImageF = Image<float>;
using ImageU32 = Image<uint32_t>;

// Makes `img` a w x h x c image for a pass that then writes all of it: reallocated (values
// indeterminate) only when its shape differs, so per-frame scratch keeps its memory.
template <class T>
void ensure_shape(Image<T>& img, int w, int h, int c) {
  if (img.width() != w || img.height() != h || img.channels() != c)
    img = Image<T>::uninitialized(w, h, c);
}

// A read-only view of one float plane (what samplers take).
struct PlaneView {
  const float* data = nullptr;
  int width = 0, height = 0;
  float at(int x, int y) const { return data[size_t(y) * width + x]; }
  float at_clamped(int x, int y) const {
    x = x < 0 ? 0 : (x >= width ? width - 1 : x);
    y = y < 0 ? 0 : (y >= height ? height - 1 : y);
    return data[size_t(y) * width + x];
  }
};
inline PlaneView view(const ImageF& img, int c) {
  return {img.plane(c), img.width(), img.height()};
}

}  // namespace afterimage
