// Fuzz target: bytes -> "<tmp>/...-frame.exr" -> io::read_frame with the default layout and
// the channels TAA requires (what `afterimage resolve` does with every input frame). A frame
// that loads must satisfy the loader's contract (validate_frame, required channels present,
// depth finite or background) and is pushed twice through TAA (small frames only), so
// hostile pixel values reach the resolver too. The same file then goes through
// describe_file (`afterimage info`). read_rgb / read_channels (compare's inputs) are not
// fuzzed here: they share open_input's checks but would decode the file again and halve the
// exec rate (README.md, "Not covered").
#include <OpenImageIO/imageio.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>

#include "fuzz_common.h"
#include "io/io.h"
#include "taa/presets.h"
#include "taa/taa_method.h"

namespace afterimage::fuzz {
namespace {

[[noreturn]] void contract_broken(const char* what) {
  std::fprintf(stderr, "fuzz_frame_loader: contract broken: %s\n", what);
  std::abort();
}

void check_loaded(const Frame& f, ChannelSet required, const std::string& path) {
  validate_frame(f, path);  // would throw InputError: let it escape as a finding
  for (const ChannelInfo& r : kChannelTable)
    if (required.contains(r.key) && !f.has(r.key)) contract_broken("a required channel is absent");
  for (float d : f.depth.data())
    if (!(d <= kBackgroundDepth)) contract_broken("depth NaN or above kBackgroundDepth");
}

// Frames above this many pixels are only loaded, not resolved (keeps execs fast).
constexpr size_t kMaxResolvePixels = 64 * 64;

// With AFTERIMAGE_FUZZ_SKIP_OPEN=1 inputs that hit the open findings of README.md ("Findings")
// are skipped, so a campaign gets past them instead of stopping (or, in fork mode, restarting)
// at each one. Only the EXR header of a single-part file is looked at: an attribute whose
// declared size exceeds the file (OpenEXR allocates it first), or a data window of more than
// 2^24 pixels (read_frame allocates it first). Replay never skips.
bool hits_open_finding(const uint8_t* data, size_t size) {
  static const bool skip = [] {
    const char* e = std::getenv("AFTERIMAGE_FUZZ_SKIP_OPEN");
    return e && std::string_view(e) == "1";
  }();
  if (!skip || size < 8 || std::memcmp(data, "v/1\x01", 4) != 0) return false;
  size_t p = 8;
  // The NUL-terminated string at p (empty names and types are legal to OpenEXR); false if the
  // file ends first.
  auto cstr = [&](std::string_view& out) {
    const void* z = p < size ? std::memchr(data + p, 0, size - p) : nullptr;
    if (!z) return false;
    const size_t n = size_t(static_cast<const uint8_t*>(z) - (data + p));
    out = std::string_view(reinterpret_cast<const char*>(data + p), n);
    p += n + 1;
    return true;
  };
  while (p < size && data[p] != 0) {
    std::string_view name, type;
    if (!cstr(name) || !cstr(type) || size - p < 4) return false;
    int32_t n;
    std::memcpy(&n, data + p, 4);
    p += 4;
    if (n < 0 || size_t(n) > size - p) return true;
    if (name == "dataWindow" && type == "box2i" && n == 16) {
      int32_t box[4];
      std::memcpy(box, data + p, 16);
      const double w = double(box[2]) - box[0] + 1, h = double(box[3]) - box[1] + 1;
      if (w * h > double(1 << 24)) return true;
    }
    p += size_t(n);
  }
  return false;
}

}  // namespace
}  // namespace afterimage::fuzz

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  afterimage::fuzz::decode_on_calling_thread();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace afterimage;
  using namespace afterimage::fuzz;
  static const ScratchFile scratch("frame", ".exr");
  if (hits_open_finding(data, size)) return 0;
  static taa::TaaMethod method("taa:afterimage", taa::preset_afterimage(), Exec{1, true});
  const ChannelSet required = method.required_channels();
  scratch.write(data, size);
  const std::string& path = scratch.path();

  Frame f;
  if (expect_errors([&] { f = io::read_frame(path, required, "taa"); })) {
    check_loaded(f, required, path);
    if (size_t(f.width) * size_t(f.height) <= kMaxResolvePixels) {
      method.reset();
      // A frame read_frame accepted is a valid TAA input: any exception here is a finding.
      for (int i = 0; i < 2; ++i) {
        const Frame out = method.process(f);
        if (out.color.width() != f.width || out.color.height() != f.height)
          contract_broken("TAA output size differs from the input");
      }
    }
  }
  expect_errors([&] { (void)io::describe_file(path); });
  return 0;
}
