// Fuzz target: bytes -> "<tmp>/...-frame.exr" -> io::read_frame with the default layout and
// the channels TAA requires (what `afterimage resolve` does with every input frame). A frame
// that loads must satisfy the loader's contract (validate_frame, required channels present,
// depth finite or background) and is pushed twice through TAA (small frames only), so
// hostile pixel values reach the resolver too. The same file then goes through
// describe_file (`afterimage info`). (read_rgb / read_channels, the compare and eval inputs,
// decode the file again and would halve the exec rate: a harness of their own is a TODO.)
#include <OpenImageIO/imageio.h>

#include <cstdio>

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

}  // namespace
}  // namespace afterimage::fuzz

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // Decode on the calling thread: deterministic, and no thread pools in the way of the
  // sanitizers.
  OIIO::attribute("threads", 1);
  OIIO::attribute("exr_threads", 1);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace afterimage;
  using namespace afterimage::fuzz;
  static const ScratchFile scratch("frame", ".exr");
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
