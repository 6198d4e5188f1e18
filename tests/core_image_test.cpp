// core/image.h storage: large buffers are advised into transparent huge pages (Linux) and
// reused from the frame buffer cache, which must change nothing but their backing.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <tbb/parallel_for.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/frame_buffer_cache.h"
#include "core/image.h"

using namespace afterimage;

namespace {

// The THPeligible field of the /proc/self/smaps mapping holding `p` (-1: not found).
int thp_eligible(const void* p) {
  std::ifstream smaps("/proc/self/smaps");
  const auto addr = reinterpret_cast<uintptr_t>(p);
  std::string line;
  bool inside = false;
  while (std::getline(smaps, line)) {
    uintptr_t begin = 0, end = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> begin >> dash >> end && dash == '-') {
      inside = addr >= begin && addr < end;
      continue;
    }
    if (inside && line.rfind("THPeligible:", 0) == 0) return std::stoi(line.substr(12));
  }
  return -1;
}

// "madvise" or "always" when the kernel offers transparent huge pages, else "".
std::string thp_mode() {
  std::ifstream f("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string s;
  std::getline(f, s);
  if (s.find("[madvise]") != std::string::npos) return "madvise";
  if (s.find("[always]") != std::string::npos) return "always";
  return "";
}

}  // namespace

TEST(ImageStorage, LargeBuffersAreHugePageEligibleAndKeepTheirValues) {
  ImageF img(1920, 1080, 3, 0.25f);  // 25 MB: above DefaultInitAllocator::kHugeFrom
  EXPECT_EQ(reinterpret_cast<uintptr_t>(img.plane(0)) % 64, 0u);
  img.at(1919, 1079, 2) = 7.0f;
  EXPECT_EQ(img.at(0, 0, 0), 0.25f);
  EXPECT_EQ(img.at(1919, 1079, 2), 7.0f);
  if (thp_mode().empty() || thp_eligible(img.plane(0)) < 0)
    GTEST_SKIP() << "no transparent huge pages or no THPeligible field in /proc/self/smaps";
  // The middle of the buffer lies in a whole 2 MB page of the advised range. In "madvise" mode
  // only the advice makes it eligible (this fails without it); in "always" mode it is anyway.
  EXPECT_EQ(thp_eligible(img.plane(1)), 1);
}

TEST(ImageStorage, AdviceOnOddRangesChangesNothing) {
  std::vector<float> v(1000, 3.0f);
  advise_huge_pages(v.data() + 1, 13);  // smaller than a page, unaligned
  advise_huge_pages(nullptr, 0);
  for (float x : v) ASSERT_EQ(x, 3.0f);
}

namespace {
long minor_faults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_minflt;
}
}  // namespace

// A frame loop frees and asks again for buffers of the same sizes. 36 MB lies above glibc's
// largest dynamic mmap threshold (32 MB), so without the cache each request is a fresh mapping
// whose pages fault in again (at least 18 faults: 2 MB huge pages, else 9000 small ones; 619
// measured).
TEST(ImageStorage, FreedFrameBuffersServeTheNextRequestOfTheirSizeWithoutPageFaults) {
  constexpr int kW = 2000, kH = 1501;  // a size no other test uses
  const float* first = nullptr;
  const long f0 = minor_faults();
  {
    ImageF a(kW, kH, 3, 1.0f);
    first = a.plane(0);
    a.at(kW - 1, kH - 1, 2) = 9.0f;
  }
  const long f1 = minor_faults();
  EXPECT_GE(f1 - f0, 18) << "the first buffer's pages should fault in";
  {
    ImageF b(kW, kH, 3, 0.5f);  // filled again: nothing of `a` shows
    EXPECT_EQ(b.plane(0), first);
    EXPECT_EQ(b.at(0, 0, 0), 0.5f);
    EXPECT_EQ(b.at(kW - 1, kH - 1, 2), 0.5f);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(b.plane(0)) % 64, 0u);
  }
  const long f2 = minor_faults();
  EXPECT_LT(f2 - f1, 18) << "the reused buffer's pages should still be mapped";
  // A smaller request takes the freed buffer down to a quarter of its size, not below.
  {
    ImageF c(kW, kH, 1, 0.0f);
    EXPECT_EQ(c.plane(0), first);
  }
  ImageF d(kW / 2, kH, 1, 0.0f);
  EXPECT_NE(d.plane(0), first);
  // Released, the cache no longer holds the first buffer.
  EXPECT_GE(release_cached_frame_buffers(), size_t(kW) * kH * 3 * sizeof(float));
  EXPECT_EQ(release_cached_frame_buffers(), 0u);
}

// The cache's policy with a limit of the test's own (the process's cache keeps an eighth of the
// physical memory): the most recently freed fitting buffer first, none more than four times the
// request, the oldest evicted over the limit, a buffer above the limit not kept at all.
TEST(ImageStorage, FrameBufferCacheEvictsTheOldestOverItsLimit) {
  constexpr size_t kMB = size_t(1) << 20;
  FrameBufferCache cache(5 * kMB / 2);  // room for two 1 MB buffers, not three
  void* a = cache.take(kMB);
  void* b = cache.take(kMB);
  void* c = cache.take(kMB);
  ASSERT_TRUE(a && b && c);
  EXPECT_EQ(reinterpret_cast<uintptr_t>(a) % 64, 0u);
  cache.give(a, kMB);
  cache.give(b, kMB);
  EXPECT_EQ(cache.cached_bytes(), 2 * kMB);
  cache.give(c, kMB);  // over the limit: a, freed first, leaves
  EXPECT_EQ(cache.cached_bytes(), 2 * kMB);
  // The most recent first, then the next; `a` is gone (the third request is served anew).
  EXPECT_EQ(cache.take(kMB), c);
  EXPECT_EQ(cache.take(kMB / 2), b);  // a quarter of b's size or more: b serves it
  EXPECT_EQ(cache.cached_bytes(), 0u);
  void* d = cache.take(kMB);
  cache.give(c, kMB);
  cache.give(b, 0);  // the size handed out is remembered, whatever the caller passes
  cache.give(d, kMB);
  EXPECT_EQ(cache.cached_bytes(), 2 * kMB);  // c evicted, b and d kept
  // Below a quarter of every cached size: a new buffer, the cache untouched.
  void* small = cache.take(kMB / 4 - 1);
  EXPECT_NE(small, b);
  EXPECT_NE(small, d);
  EXPECT_EQ(cache.cached_bytes(), 2 * kMB);
  cache.give(small, 0);  // kept: 2.25 MB in all
  EXPECT_EQ(cache.cached_bytes(), 2 * kMB + kMB / 4 - 1);
  // Larger than the limit: returned to the system at once, nothing evicted for it.
  void* big = cache.take(3 * kMB);
  cache.give(big, 3 * kMB);
  EXPECT_EQ(cache.cached_bytes(), 2 * kMB + kMB / 4 - 1);
  EXPECT_EQ(cache.release(), 2 * kMB + kMB / 4 - 1);
  EXPECT_EQ(cache.cached_bytes(), 0u);
  EXPECT_EQ(cache.release(), 0u);
}

// Buffers alive at once are distinct (the cache hands a freed buffer to one request only);
// tasks allocating and freeing them at once each get one of their own.
TEST(ImageStorage, ConcurrentFrameBuffersAreDistinct) {
  {
    ImageF a(1000, 1000, 1, 1.0f);
    { ImageF freed(1000, 1000, 1, 0.0f); }                  // now cached
    ImageF b(1000, 1000, 1, 2.0f), c(1000, 1000, 1, 3.0f);  // one takes it, the other is new
    EXPECT_NE(a.plane(0), b.plane(0));
    EXPECT_NE(a.plane(0), c.plane(0));
    EXPECT_NE(b.plane(0), c.plane(0));
    EXPECT_EQ(a.at(999, 999, 0), 1.0f);
    EXPECT_EQ(b.at(999, 999, 0), 2.0f);
    EXPECT_EQ(c.at(999, 999, 0), 3.0f);
  }
  tbb::parallel_for(0, 64, [](int i) {
    ImageF img(1024 + (i % 4), 1024, 2, float(i));  // 8 MB, four sizes
    img.at(5, 5, 1) = float(i) + 0.5f;
    for (int y = 0; y < 1024; y += 97) ASSERT_EQ(img.at(3, y, 0), float(i)) << "task " << i;
    ASSERT_EQ(img.at(5, 5, 1), float(i) + 0.5f) << "task " << i;
  });
}
