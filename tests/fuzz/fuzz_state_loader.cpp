// Fuzz target: bytes -> state file -> StateReader (core/state_file.h) and TAA's load_state
// (`afterimage resolve --load-state`).
//
// Input format: one mode byte, then the file. Mode bit 0 set: the harness appends the
// correct FNV-1a checksum to the file, so mutations reach the section parser and the TAA
// loader instead of stopping at "checksum mismatch"; clear: the bytes are the whole file.
//
// Beyond "no crash", two contracts of SequenceMethod are checked:
//  * a failed load_state changes nothing (the state saved after it equals the one before);
//  * a successful load continues bit-identically: saving the loaded state and loading it
//    into a second method gives the same output for the next frame.
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <vector>

#include "core/state_file.h"
#include "fuzz_common.h"
#include "taa/presets.h"
#include "taa/taa_method.h"

namespace afterimage::fuzz {
namespace {

[[noreturn]] void contract_broken(const char* what) {
  std::fprintf(stderr, "fuzz_state_loader: contract broken: %s\n", what);
  std::abort();
}

std::vector<unsigned char> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// Every getter on every section, with its own type and with a wrong one.
void read_all_sections(const StateReader& r) {
  for (const StateReader::Section& s : r.sections()) {
    expect_errors([&] {
      switch (s.type) {
        case ElemType::U8:
          (void)r.get<uint8_t>(s.name);
          break;
        case ElemType::I32:
          (void)r.get<int32_t>(s.name);
          break;
        case ElemType::U32:
          (void)r.get<uint32_t>(s.name);
          break;
        case ElemType::I64:
          (void)r.get<int64_t>(s.name);
          break;
        case ElemType::U64:
          (void)r.get<uint64_t>(s.name);
          break;
        case ElemType::F32:
          (void)r.get<float>(s.name);
          break;
        case ElemType::F64:
          (void)r.get<double>(s.name);
          break;
      }
    });
    expect_errors([&] { (void)r.get_i64(s.name); });
    expect_errors([&] { (void)r.get_f64(s.name); });
    ImageF img(2, 2, 1);
    expect_errors([&] { r.get(s.name, img); });
  }
  expect_errors([&] { (void)r.section("no such section"); });
}

std::unique_ptr<taa::TaaMethod> make_taa() {
  return std::make_unique<taa::TaaMethod>("taa:afterimage", taa::preset_afterimage(),
                                          Exec{1, true});
}

bool same_bits(const ImageF& a, const ImageF& b) {
  // memcmp of two empty images would be given null pointers (undefined even for 0 bytes).
  return a.same_shape(b) && (a.data().empty() || std::memcmp(a.data().data(), b.data().data(),
                                                             a.data().size() * sizeof(float)) == 0);
}

}  // namespace
}  // namespace afterimage::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace afterimage;
  using namespace afterimage::fuzz;
  static const ScratchFile input("state-in", ".state");
  static const ScratchFile resaved("state-out", ".state");
  static const Frame frame0 = tiny_frame(8, 4, 0), frame1 = tiny_frame(8, 4, 1);
  if (size == 0) return 0;

  std::vector<unsigned char> bytes(data + 1, data + size);
  if (data[0] & 1) {
    const uint64_t sum = state_checksum(bytes.data(), bytes.size());
    const auto* p = reinterpret_cast<const unsigned char*>(&sum);
    bytes.insert(bytes.end(), p, p + sizeof(sum));
  }
  input.write(bytes.data(), bytes.size());

  // 1. The generic reader.
  expect_errors([&] {
    const StateReader r(input.path(), "taa", 1);
    read_all_sections(r);
  });

  // 2. TAA's loader, on a method that already has history (one frame processed).
  auto a = make_taa();
  (void)a->process(frame0);
  a->save_state(resaved.path());
  const std::vector<unsigned char> before = file_bytes(resaved.path());
  if (!expect_errors([&] { a->load_state(input.path()); })) {
    a->save_state(resaved.path());
    if (file_bytes(resaved.path()) != before) contract_broken("a failed load_state changed state");
    return 0;
  }

  // 3. Continuation: A (loaded) and B (loaded from A's save) give the same next frame.
  a->save_state(resaved.path());
  auto b = make_taa();
  b->load_state(resaved.path());  // our own file: any error is a finding
  // A loaded state may refuse a frame (an InputError, e.g. a size other than the state's):
  // then both must refuse it.
  for (const Frame* f : {&frame1, &frame0}) {
    Frame oa, ob;
    const bool ok_a = expect_errors([&] { oa = a->process(*f); });
    const bool ok_b = expect_errors([&] { ob = b->process(*f); });
    if (ok_a != ok_b || !same_bits(oa.color, ob.color))
      contract_broken("save/load does not continue identically");
  }
  return 0;
}
