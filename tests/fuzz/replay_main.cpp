// Corpus replay without libFuzzer (tests/fuzz/README.md): links one harness's
// LLVMFuzzerTestOneInput and runs it once on every file named on the command line or found
// (recursively, in sorted order) under a directory named there. Any finding aborts the
// process, so CTest reports the harness's replay test as failed; stderr names the input
// being replayed. Works with any compiler, so the default (g++) build runs the corpora.
//
//   replay_<harness> DIR_OR_FILE...
//
// Huge allocations are findings here too, as under libFuzzer's -malloc_limit_mb: outside
// sanitizer builds (whose allocator owns operator new) a replacement operator new aborts on
// any single allocation above AFTERIMAGE_REPLAY_MALLOC_LIMIT_MB (default 1024), and the
// address space is capped at AFTERIMAGE_REPLAY_MAX_MB (default 4096; 0 = off), so an input
// that makes the code allocate gigabytes in pieces fails with std::bad_alloc, which no
// harness expects, instead of swapping the machine. (Reaches the shared libraries too:
// OpenEXR's new[] resolves to this operator new.)
#include <sys/resource.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <new>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);
extern "C" __attribute__((weak)) int LLVMFuzzerInitialize(int* argc, char*** argv);

#if defined(__SANITIZE_ADDRESS__)
#define AFTERIMAGE_REPLAY_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define AFTERIMAGE_REPLAY_ASAN 1
#endif
#endif

#ifndef AFTERIMAGE_REPLAY_ASAN
namespace {
size_t malloc_limit_bytes() {
  static const size_t limit = [] {
    unsigned long mb = 1024;
    if (const char* e = std::getenv("AFTERIMAGE_REPLAY_MALLOC_LIMIT_MB"))
      mb = std::strtoul(e, nullptr, 10);
    return mb == 0 ? SIZE_MAX : size_t(mb) << 20;
  }();
  return limit;
}
}  // namespace

// operator new[] and the nothrow forms call this one in libstdc++; delete is free().
void* operator new(size_t size) {
  if (size > malloc_limit_bytes()) {
    std::fprintf(stderr, "replay: allocation of %zu bytes exceeds the malloc limit (%zu MB)\n",
                 size, malloc_limit_bytes() >> 20);
    std::abort();
  }
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
#endif

namespace {

namespace fs = std::filesystem;

void cap_address_space() {
#ifndef AFTERIMAGE_REPLAY_ASAN  // ASan reserves terabytes of shadow memory
  unsigned long mb = 4096;
  if (const char* e = std::getenv("AFTERIMAGE_REPLAY_MAX_MB")) mb = std::strtoul(e, nullptr, 10);
  if (mb == 0) return;
  const rlim_t bytes = rlim_t(mb) << 20;
  rlimit lim{bytes, bytes};
  if (setrlimit(RLIMIT_AS, &lim) != 0) std::perror("replay: setrlimit(RLIMIT_AS)");
#endif
}

std::vector<fs::path> inputs_under(const fs::path& p) {
  std::vector<fs::path> files;
  if (fs::is_directory(p)) {
    for (const auto& e : fs::recursive_directory_iterator(p))
      if (e.is_regular_file() && e.path().filename().string().front() != '.')
        files.push_back(e.path());
    std::sort(files.begin(), files.end());
  } else if (fs::is_regular_file(p)) {
    files.push_back(p);
  } else {
    std::fprintf(stderr, "replay: %s: no such file or directory\n", p.c_str());
    std::exit(2);
  }
  return files;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s DIR_OR_FILE...\n", argv[0]);
    return 2;
  }
  std::vector<fs::path> files;
  for (int i = 1; i < argc; ++i) {
    std::vector<fs::path> more = inputs_under(argv[i]);
    files.insert(files.end(), more.begin(), more.end());
  }
  cap_address_space();
  if (LLVMFuzzerInitialize) LLVMFuzzerInitialize(&argc, &argv);
  for (const fs::path& f : files) {
    std::ifstream in(f, std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), {});
    if (in.bad()) {
      std::fprintf(stderr, "replay: %s: read error\n", f.c_str());
      return 2;
    }
    std::fprintf(stderr, "replay: %s (%zu bytes)\n", f.c_str(), bytes.size());
    LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  }
  std::printf("replayed %zu input(s): no findings\n", files.size());
  return 0;
}
