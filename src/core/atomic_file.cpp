#include "core/atomic_file.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <functional>
#include <random>
#include <string_view>
#include <system_error>
#include <thread>

#include "core/error.h"

namespace afterimage {

namespace fs = std::filesystem;

namespace {

constexpr std::string_view kTempPrefix = ".afterimage-";
constexpr std::string_view kTempInfix = ".tmp";

std::string errno_text(int err) {
  return std::error_code(err, std::generic_category()).message();
}

}  // namespace

TempFile::TempFile(const std::string& target) {
  const fs::path p(target);
  // pid + thread + random: unique across processes and threads without shared state; O_EXCL
  // makes a collision a retry, never a shared file. The name does not contain the target's
  // stem, so any valid target name (up to NAME_MAX) has a valid temporary name.
  std::random_device rd;
  const size_t tid = std::hash<std::thread::id>{}(std::this_thread::get_id());
  int err = 0;
  for (int attempt = 0; attempt < 16; ++attempt) {
    const std::string name = fmt::format("{}{}-{:06x}-{:08x}{}{}", kTempPrefix, getpid(),
                                         tid & 0xffffffu, rd(), kTempInfix, p.extension().string());
    std::string candidate = (p.parent_path() / name).string();
    // 0666 & ~umask like any newly created output (mkstemp would force 0600).
    const int fd = ::open(candidate.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) {
      ::close(fd);
      path_ = std::move(candidate);
      return;
    }
    err = errno;
    if (err != EEXIST) break;
  }
  throw OutputError(fmt::format("{}: cannot create temporary file: {}", target, errno_text(err)));
}

TempFile::~TempFile() {
  if (!released_) ::unlink(path_.c_str());
}

void create_output_directory(const std::string& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw OutputError(fmt::format("{}: exists and is not a directory", dir));
  fs::create_directories(dir, ec);
  if (ec) throw OutputError(fmt::format("{}: cannot create directory: {}", dir, ec.message()));
}

void write_file_atomic(const std::string& path, const WriteToFn& write_to) {
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty()) {
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) throw OutputError(fmt::format("{}: cannot create directory: {}", path, ec.message()));
  }
  TempFile tmp(path);  // removed on every exit below except the successful rename
  try {
    write_to(tmp.path());
  } catch (const Error&) {
    throw;
  } catch (const std::system_error& e) {
    throw OutputError(fmt::format("{}: {}", path, e.what()));
  }
  // Data on disk before the rename: after a crash `path` holds the old or the new complete
  // file. Some filesystems only report a full disk here (delayed allocation).
  const int fd = ::open(tmp.path().c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0)
    throw OutputError(fmt::format("{}: cannot reopen temporary file: {}", path, errno_text(errno)));
  const int sync_err = ::fsync(fd) == 0 ? 0 : errno;
  ::close(fd);
  if (sync_err != 0)
    throw OutputError(fmt::format("{}: cannot sync to disk: {}", path, errno_text(sync_err)));
  if (std::rename(tmp.path().c_str(), path.c_str()) != 0)
    throw OutputError(fmt::format("{}: cannot rename into place: {}", path, errno_text(errno)));
  tmp.release();
}

void write_all_to(const std::string& file, const void* data, size_t size) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) throw std::system_error(errno, std::generic_category(), "cannot open");
  const char* p = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = ::write(fd, p, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      // write() returning 0 for a non-empty request means no progress: treat as no space.
      const int err = n < 0 ? errno : ENOSPC;
      ::close(fd);
      throw std::system_error(err, std::generic_category(), "write failed");
    }
    p += n;
    size -= size_t(n);
  }
  if (::close(fd) != 0) throw std::system_error(errno, std::generic_category(), "close failed");
}

void write_bytes_atomic(const std::string& path, const void* data, size_t size) {
  write_file_atomic(path, [&](const std::string& tmp) { write_all_to(tmp, data, size); });
}

void write_text_atomic(const std::string& path, std::string_view text) {
  write_bytes_atomic(path, text.data(), text.size());
}

}  // namespace afterimage

namespace afterimage {

int remove_stale_temporaries(const std::string& dir) {
  std::error_code ec;
  int removed = 0;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    // ".afterimage-<pid>-<thread>-<random>.tmp<ext>"
    if (name.rfind(kTempPrefix, 0) != 0 || name.find(kTempInfix) == std::string::npos) continue;
    const char* digits = name.c_str() + kTempPrefix.size();
    char* end_pid = nullptr;
    const long pid = std::strtol(digits, &end_pid, 10);
    if (end_pid == digits || *end_pid != '-' || pid <= 0) continue;
    // Only temporaries of processes that no longer exist: a concurrent run's file stays.
    if (pid == long(getpid()) || ::kill(pid_t(pid), 0) == 0 || errno != ESRCH) continue;
    std::error_code rm;
    if (it->is_regular_file(rm) && fs::remove(it->path(), rm)) ++removed;
  }
  return removed;
}

}  // namespace afterimage
