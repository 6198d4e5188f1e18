// Software prefetch for row loops that stream many planes at once (TAA resolve, TAAU upscale;
// docs/perf/profile-taa-resolve.md): more streams than the hardware prefetcher follows, so
// each lane block first asks for one line per plane some pixels ahead. Three groups, each
// with its own row: planes read in this frame, planes written, planes of the previous frame.
// A prefetch never changes a value.
#pragma once

#include <hwy/base.h>

#include <cstddef>

#include "core/error.h"

namespace afterimage {

// How far ahead a row loop streaming full-resolution planes asks for their lines, in 4-byte
// values: 16 cache lines, 16 lane blocks ahead at 16 lanes.
constexpr int kRowPrefetchAhead = 256;

class PlanePrefetch {
 public:
  static constexpr int kMaxPlanes = 20;
  enum Group { kRead, kWrite, kPrevious, kGroups };

  // `plane` of 4-byte values (float or uint32); rows and columns are in elements.
  void add(Group g, const void* plane) {
    AI_CHECK(count_[g] < kMaxPlanes);
    planes_[g][count_[g]++] = static_cast<const float*>(plane);
  }
  void set_row(Group g, size_t row_offset) { row_[g] = row_offset; }

  // One line of every plane, at column `read_x` of the read group's row, `write_x` (for
  // writing) and `previous_x`. Inlined: called out of line, GCC finds it pure (a prefetch has no
  // side effect) and drops the call.
  HWY_INLINE void lines(size_t read_x, size_t write_x, size_t previous_x) const {
    for (int i = 0; i < count_[kRead]; ++i)
      __builtin_prefetch(planes_[kRead][i] + row_[kRead] + read_x);
    for (int i = 0; i < count_[kWrite]; ++i)
      __builtin_prefetch(planes_[kWrite][i] + row_[kWrite] + write_x, 1);
    for (int i = 0; i < count_[kPrevious]; ++i)
      __builtin_prefetch(planes_[kPrevious][i] + row_[kPrevious] + previous_x);
  }

 private:
  const float* planes_[kGroups][kMaxPlanes] = {};
  int count_[kGroups] = {};
  size_t row_[kGroups] = {};
};

}  // namespace afterimage
