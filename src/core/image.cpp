#include "core/image.h"

#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
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

}  // namespace afterimage
