#include "io/video.h"

#include <fmt/format.h>
#include <unistd.h>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <vector>

#include "core/error.h"
#include "io/io.h"

namespace afterimage::io {

namespace fs = std::filesystem;

bool have_program(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  const std::string p(path);
  size_t start = 0;
  while (start <= p.size()) {
    size_t end = p.find(':', start);
    if (end == std::string::npos) end = p.size();
    std::error_code ec;
    if (fs::exists(fs::path(p.substr(start, end - start)) / name, ec)) return true;
    start = end + 1;
  }
  return false;
}

namespace {

// Runs argv[0] from PATH with stdin from /dev/null and without a shell, so file names with
// quotes or spaces reach the program unchanged. Returns the exit status (-1: not started).
int run_program(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
  pid_t pid = 0;
  const int err = posix_spawnp(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (err != 0) return -1;
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

void write_mp4(const std::string& path, size_t frames, const std::function<ImageF(size_t)>& frame,
               int fps) {
  if (!have_program("ffmpeg")) throw OutputError(fmt::format("{}: ffmpeg is not on PATH", path));
  // PNG frames in a private directory beside the output, then one ffmpeg call.
  const fs::path tmp = fs::path(path).parent_path() /
                       fmt::format(".{}.frames-{}", fs::path(path).stem().string(), getpid());
  fs::remove_all(tmp);
  fs::create_directories(tmp);
  for (size_t t = 0; t < frames; ++t)
    write_rgb((tmp / fmt::format("{:04d}.png", t)).string(), frame(t));
  const std::string part = path + ".part.mp4";
  // Even dimensions for yuv420p; stdin is /dev/null so ffmpeg never waits for a key.
  const int rc =
      run_program({"ffmpeg", "-loglevel", "error", "-y", "-framerate", std::to_string(fps), "-i",
                   (tmp / "%04d.png").string(), "-vf", "scale=trunc(iw/2)*2:trunc(ih/2)*2", "-c:v",
                   "libx264", "-pix_fmt", "yuv420p", "-crf", "18", part});
  fs::remove_all(tmp);
  std::error_code ec;
  if (rc != 0) {
    fs::remove(part, ec);
    throw OutputError(fmt::format("{}: ffmpeg failed (exit {})", path, rc));
  }
  fs::rename(part, path, ec);
  if (ec) throw OutputError(fmt::format("{}: cannot rename into place: {}", path, ec.message()));
}

}  // namespace afterimage::io
