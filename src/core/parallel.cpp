#include "core/parallel.h"

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

}  // namespace afterimage
