// The SIMD target the kernels were compiled for, without Highway's headers, so that a file
// that only reports it (the CLI's --version, the API) is not a kernel file
// (cmake/AfterimageIsa.cmake).
#pragma once

#include <string>

namespace afterimage {

// "AVX3_ZEN4, 16 float lanes": the Highway target these kernels were compiled for and its width
// (`afterimage --version`; golden baselines are kept per lane width, scripts/golden.sh).
std::string simd_description();

}  // namespace afterimage
