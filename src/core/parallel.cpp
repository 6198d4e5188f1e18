#include "core/parallel.h"

#include <cstdlib>
#include <string>

namespace afterimage {

Exec Exec::from_env() {
  Exec e;
  if (const char* s = std::getenv("AFTERIMAGE_SIMD")) {
    std::string v(s);
    if (v == "off" || v == "0" || v == "false") e.simd = false;
  }
  if (const char* t = std::getenv("AFTERIMAGE_THREADS")) e.threads = std::max(0, std::atoi(t));
  return e;
}

}  // namespace afterimage
