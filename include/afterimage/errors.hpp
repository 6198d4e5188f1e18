// The exceptions the C++ API throws: one-line messages naming the file, frame or setting.
// The library's own code throws the same types (src/core/error.h).
#pragma once

#include <stdexcept>

#include "afterimage/export.h"

namespace afterimage {
// The ABI's version: a release that breaks it moves every public name to v1.
inline namespace v0 {

// A problem with what the caller gave (a file, a frame, a setting) or with writing results.
class AFTERIMAGE_API Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// Unreadable or inconsistent input data (a file, a frame's buffers or camera).
class AFTERIMAGE_API InputError : public Error {
 public:
  using Error::Error;
};
// An unknown or impossible setting, method or stage name.
class AFTERIMAGE_API SettingsError : public Error {
 public:
  using Error::Error;
};
// A result could not be written (directory, disk full, rename). Naming an input as an output
// is an InputError: nothing failed on disk.
class AFTERIMAGE_API OutputError : public Error {
 public:
  using Error::Error;
};

}  // namespace v0
}  // namespace afterimage
