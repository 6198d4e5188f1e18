// AFTERIMAGE_API marks what the library exports; everything else in it is hidden. A program
// linking the static library defines AFTERIMAGE_STATIC (the CMake package and afterimage.pc do).
#pragma once

#if defined(AFTERIMAGE_STATIC)
#define AFTERIMAGE_API
#elif defined(_WIN32)
#if defined(AFTERIMAGE_BUILDING_LIBRARY)
#define AFTERIMAGE_API __declspec(dllexport)
#else
#define AFTERIMAGE_API __declspec(dllimport)
#endif
#else
#define AFTERIMAGE_API __attribute__((visibility("default")))
#endif
