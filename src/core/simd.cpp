#include "core/simd.h"

#include <fmt/format.h>

namespace afterimage {

std::string simd_description() {
  return fmt::format("{}, {} float lanes", hwy::TargetName(HWY_STATIC_TARGET),
                     hn::Lanes(FullTag()));
}

}  // namespace afterimage
