// Atomic file output (DESIGN.md §3): every file we write goes to a unique temporary sibling,
// is checked, synced to disk and renamed into place, so a crash or a full disk never leaves
// a half file under the final name and an existing file stays intact until the new one is
// complete. Failures throw OutputError "<path>: <what failed>: <reason>".
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <string_view>

namespace afterimage {

// A new, empty file next to `target` (same directory, same extension, so format-by-extension
// writers still work), named ".afterimage-<pid>-<thread>-<random>.tmp<ext>" and created with
// O_EXCL (never an existing file, whatever other processes or threads do). Removed by the
// destructor unless release()d. Throws OutputError if it cannot be created.
class TempFile {
 public:
  explicit TempFile(const std::string& target);
  ~TempFile();
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;

  const std::string& path() const { return path_; }
  void release() { released_ = true; }  // keep the file (it was renamed away)

 private:
  std::string path_;
  bool released_ = false;
};

// Called with the temporary path; must write the complete file there. Reports failure by
// throwing: an afterimage::Error passes through unchanged (so it should name the final
// path), a std::system_error (I/O, filesystem) becomes OutputError "<path>: write failed:
// <what>"; anything else (bad_alloc, ...) passes through. Either way the temporary is removed.
using WriteToFn = std::function<void(const std::string& tmp_path)>;

// Creates the parent directories of `path`, a TempFile beside it, calls `write_to(tmp)`,
// fsyncs the temporary and renames it to `path`. On any failure the temporary is removed,
// an existing `path` is left untouched, and OutputError is thrown.
void write_file_atomic(const std::string& path, const WriteToFn& write_to);

// Creates `dir` and its parents for outputs. Throws OutputError "<dir>: ..." when it cannot
// (a path component is a file, permission denied), including when `dir` exists as a file.
void create_output_directory(const std::string& dir);

// Removes the temporaries TempFile left in `dir` when its process was killed (kill -9, power
// loss): files of TempFile's naming whose process id no longer exists. Returns the count.
// Never touches other files or temporaries of a live process; errors are ignored (a
// leftover is harmless, the run itself must not fail because of one).
int remove_stale_temporaries(const std::string& dir);

// write_file_atomic with the whole content given.
void write_bytes_atomic(const std::string& path, const void* data, size_t size);
void write_text_atomic(const std::string& path, std::string_view text);

// Writes `size` bytes to `file` (created or truncated) with POSIX write(), retrying short
// writes and EINTR, and checks close(). Throws std::system_error on failure (ENOSPC included:
// a full disk is an error, never a silently truncated file). The callback of
// write_bytes_atomic; public so the disk-full path can be tested against /dev/full.
void write_all_to(const std::string& file, const void* data, size_t size);

}  // namespace afterimage
