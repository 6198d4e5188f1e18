#include "core/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstdlib>
#include <string>

#include "core/limits.h"

namespace afterimage {

Exec Exec::from_env() {
  Exec e;
  if (const char* s = std::getenv("AFTERIMAGE_SIMD")) {
    std::string v(s);
    if (v == "off" || v == "0" || v == "false") e.simd = false;
  }
  // Out-of-range values are kept (as -1 for unparsable or huge ones) so the CLI's range check
  // names them instead of silently clamping.
  if (const char* t = std::getenv("AFTERIMAGE_THREADS")) {
    char* end = nullptr;
    const long v = std::strtol(t, &end, 10);
    e.threads = (end == t || *end != '\0' || v < 0 || v > kMaxThreads + 1L) ? -1 : int(v);
  }
  return e;
}

void run_row_ranges(const Exec& ex, int height, RowRangeBody body) {
  auto run = [&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, height, 1),
                      [&](const tbb::blocked_range<int>& r) { body(r.begin(), r.end()); });
  };
  if (ex.threads > 1 && ex.threads != tbb::this_task_arena::max_concurrency()) {
    // Clamped for library callers (the CLI refuses larger counts): results do not depend on
    // the thread count, and an arena of ~70000 threads crashes inside TBB.
    // Only when the count differs from the current arena's: a new arena per call costs ~40 us
    // more than running in the current one (2 threads, a 16-row loop: 68-80 against 35-44 us),
    // and the post chain makes 43 such calls a frame (counted in gdb), many over small images.
    tbb::task_arena arena(std::min(ex.threads, kMaxThreads));
    arena.execute(run);
  } else {
    run();
  }
}

}  // namespace afterimage
