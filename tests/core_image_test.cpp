// core/image.h storage: large buffers are advised into transparent huge pages (Linux), which
// must change nothing but their backing.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

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
