// One row-loop helper for per-pixel kernels written once as templates on a Highway
// descriptor `d` (tev's simdFor habit, DESIGN.md §6). The body runs at full SIMD width and
// then at 1 lane (CappedTag<float, 1>) for the tail. With Exec::simd == false every pixel
// takes the 1-lane path: that is the reference path the tests compare against.
#pragma once

// Kernels are compiled for the kernel ISA, the rest of the code for the base ISA
// (cmake/AfterimageIsa.cmake gives each file its -march by whether it includes this header).
#if !defined(AFTERIMAGE_KERNEL_ISA)
#error "core/simd.h in a file not compiled for the kernel ISA: see cmake/AfterimageIsa.cmake"
#endif

#include <hwy/highway.h>

#include <cstdint>
#include <cstring>
#include <string>

#if defined(__SSE__)
#include <xmmintrin.h>
#endif

#include "core/parallel.h"
#include "core/simd_target.h"

namespace afterimage {
namespace hn = hwy::HWY_NAMESPACE;

using FullTag = hn::ScalableTag<float>;
using OneTag = hn::CappedTag<float, 1>;

// Calls body(d, x) for x in [0, width): with a full-width tag while a whole vector fits
// (only if ex.simd), then with a 1-lane tag. `body` is a generic lambda. T: the lane type
// (float, or double for the metrics that sum in double).
template <class T = float, class Body>
inline void for_each_lane_block(const Exec& ex, int width, Body&& body) {
  int x = 0;
  if (ex.simd) {
    const hn::ScalableTag<T> d;
    const int n = int(hn::Lanes(d));
    for (; x + n <= width; x += n) body(d, x);
  }
  const hn::CappedTag<T, 1> d1;
  for (; x < width; ++x) body(d1, x);
}

// Stores v at p, with a non-temporal (streaming) store when d is a full vector and p is
// vector-aligned, else an ordinary one: for a plane written once and read back only after the
// caches have turned over (1080p planes are 8 MB), the streaming store skips reading each
// destination line first (df19793; docs/perf/2026-log.md). The same bits either way; the row
// task that used it ends with stream_fence() so the stores are visible before the task's
// completion is.
template <class D>
HWY_INLINE void store_streaming(hn::Vec<D> v, D d, float* p) {
  if constexpr (hn::MaxLanes(D()) > 1) {
    if (reinterpret_cast<uintptr_t>(p) % (hn::Lanes(d) * sizeof(float)) == 0) {
      hn::Stream(v, d, p);
      return;
    }
  }
  hn::StoreU(v, d, p);
}
inline void stream_fence() {
#if defined(__SSE__)
  _mm_sfence();
#endif
}

// Copies n 4-byte values (float bits, ids), with non-temporal (streaming) stores from the first
// vector-aligned destination address on: for a copy that is read only much later (a frame's
// G-buffer kept for the next one, far more than the caches hold) the store then skips reading
// every destination line first. A copy: the same bits whatever the path; fenced before return.
inline void stream_copy(const void* src, void* dst, size_t n) {
  const FullTag d;
  const size_t lanes = hn::Lanes(d), align = lanes * sizeof(float);
  const auto* s = static_cast<const unsigned char*>(src);
  auto* t = static_cast<unsigned char*>(dst);
  const size_t bytes = n * sizeof(float);
  size_t head = (align - reinterpret_cast<uintptr_t>(t) % align) % align;
  if (head > bytes || head % sizeof(float) != 0) head = bytes;
  std::memcpy(t, s, head);
  size_t i = head;
  for (; i + align <= bytes; i += align)
    hn::Stream(hn::LoadU(d, reinterpret_cast<const float*>(s + i)), d,
               reinterpret_cast<float*>(t + i));
  std::memcpy(t + i, s + i, bytes - i);
#if defined(__SSE__)
  _mm_sfence();
#endif
}

// Lanes first, first + 1, ...: hn::Iota(d, first), the same values (one rounding of
// first + i), computed in registers. Highway 1.0's Iota writes its lanes to memory one at a
// time and loads them as one vector, a store-forwarding stall when `first` is only known at
// run time (perf: about half of SVGF's accumulate, and every consecutiveness test of the
// history gathers); Iota(d, 0) is a constant.
template <class D, class T>
HWY_INLINE hn::Vec<D> iota_from(D d, T first) {
  return hn::Add(hn::Iota(d, 0), hn::Set(d, static_cast<hn::TFromD<D>>(first)));
}

// Pixel-center x coordinates x + 0.5, x + 1.5, ... of the lanes of a block starting at x.
template <class D>
inline hn::Vec<D> pixel_center_x(D d, int x) {
  return hn::Add(iota_from(d, float(x)), hn::Set(d, 0.5f));
}

}  // namespace afterimage

// While alive, floating-point results below the smallest normal float are flushed to 0 and
// such inputs read as 0 (x86 MXCSR FTZ | DAZ), on this thread only; the previous mode is
// restored on destruction. A kernel whose tiny values do not matter uses it per row task:
// Intel cores take a microcode assist (~100+ cycles) for each subnormal result or input,
// which made SVGF's paper à-trous ~1.8x slower where weights underflow (5a64497). The
// same rows, lanes and --simd off all run under it, so results stay identical among them.
// `on` false: no effect. No-op off x86.
class FlushSubnormals {
 public:
  explicit FlushSubnormals(bool on = true) {
#if defined(__SSE__)
    if (on) {
      saved_ = _mm_getcsr();
      _mm_setcsr(saved_ | 0x8040u);  // FTZ (bit 15) | DAZ (bit 6)
      active_ = true;
    }
#else
    (void)on;
#endif
  }
  ~FlushSubnormals() {
#if defined(__SSE__)
    if (active_) _mm_setcsr(saved_);
#endif
  }
  FlushSubnormals(const FlushSubnormals&) = delete;
  FlushSubnormals& operator=(const FlushSubnormals&) = delete;

 private:
  unsigned saved_ = 0;
  bool active_ = false;
};
