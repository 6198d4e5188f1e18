// Fuzz target: layouts (frame/layout.h, io/layouts.h). Inputs starting with '{' are a JSON
// layout file (io::layout_from_json_text); inputs starting with "--map " are lines of --map
// specs applied to our layout (io::apply_map). Any other input is a small line language the
// harness parses into Layout::map / unmap calls. The resulting layout reads a fixed, valid
// 8x4 frame with every channel through io::read_frame:
//
//   map <channel key> <file name>[:<scale>:<offset>] ...   Layout::map (conversions given
//                                                          when any token has them)
//   unmap <channel key>                                    Layout::unmap
//   require <channel key> ...                              channels read_frame must find
//
// Unknown words and channel keys are skipped (harness syntax, not library input).
// A frame that loads must satisfy the loader's contract, and every plane read through a
// same-type mapping must hold scale * file value + offset of the file channel it names.
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "frame/layout.h"
#include "fuzz_common.h"
#include "io/io.h"
#include "io/layouts.h"

namespace afterimage::fuzz {
namespace {

[[noreturn]] void contract_broken(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_layout: contract broken: %s: %s\n", what, detail.c_str());
  std::abort();
}

struct FilePlane {
  PixelType type;
  std::vector<double> values;
};

// The frame every layout reads, written once per process, and its planes by file name.
struct Source {
  ScratchFile file{"layout", ".exr"};
  Frame frame = tiny_frame(8, 4, 3);
  std::map<std::string, FilePlane> planes;
  Source() {
    io::write_frame(file.path(), frame);
    for (const ChannelInfo& r : kChannelTable)
      frame.visit(r.key, [&](const auto& img) {
        for (int c = 0; c < r.planes; ++c) {
          FilePlane& p = planes[r.exr[size_t(c)]];
          p.type = r.type;
          p.values.assign(img.plane(c), img.plane(c) + img.plane_size());
        }
      });
  }
};

struct Parsed {
  Layout layout{"fuzz"};
  ChannelSet required;
};

Parsed parse(std::string_view text) {
  Parsed p;
  std::istringstream in{std::string(text)};
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    std::string verb, key;
    words >> verb >> key;
    const ChannelInfo* r = find_channel(key);
    if (!r) continue;
    if (verb == "unmap") {
      p.layout.unmap(r->key);
    } else if (verb == "require") {
      p.required.insert(r->key);
      while (words >> key)
        if (const ChannelInfo* more = find_channel(key)) p.required.insert(more->key);
    } else if (verb == "map") {
      std::vector<std::string> names;
      std::vector<PlaneSource> conv;
      bool any_conversion = false;
      std::string tok;
      while (words >> tok) {
        PlaneSource ps;
        const size_t a = tok.find(':');
        names.push_back(tok.substr(0, a));
        if (a != std::string::npos) {
          any_conversion = true;
          const std::string rest = tok.substr(a + 1);
          const size_t b = rest.find(':');
          ps.scale = std::strtod(rest.substr(0, b).c_str(), nullptr);
          if (b != std::string::npos) ps.offset = std::strtod(rest.substr(b + 1).c_str(), nullptr);
        }
        conv.push_back(ps);
      }
      if (!any_conversion) conv.clear();
      expect_errors([&] { p.layout.map(r->key, names, conv); });
    }
  }
  return p;
}

bool close_enough(double got, double want) {
  if (std::isnan(got) || std::isnan(want)) return std::isnan(got) && std::isnan(want);
  if (std::isinf(got) || std::isinf(want)) return got == want;
  return std::abs(got - want) <= 1e-6 * std::max(1.0, std::abs(want));
}

void check_loaded(const Frame& f, const Parsed& p, const Source& src) {
  validate_frame(f, "layout fuzz frame");  // throws: escapes as a finding
  if (f.width != src.frame.width || f.height != src.frame.height)
    contract_broken("size changed", "");
  for (const ChannelInfo& r : kChannelTable) {
    if (p.required.contains(r.key) && !f.has(r.key))
      contract_broken("required channel absent", r.name);
    const ChannelSource* cs = p.layout.find(r.key);
    if (!cs || !f.has(r.key)) continue;
    f.visit(r.key, [&](const auto& img) {
      for (int c = 0; c < r.planes; ++c) {
        const PlaneSource& ps = cs->planes[size_t(c)];
        const auto it = src.planes.find(ps.file_name);
        if (it == src.planes.end()) contract_broken("read a channel the file lacks", ps.file_name);
        if (it->second.type != r.type) continue;  // cross-type reads convert in OIIO
        for (size_t i = 0; i < img.plane_size(); ++i) {
          double want = ps.scale * it->second.values[i] + ps.offset;
          if (r.type == PixelType::F32) want = double(float(want));
          // io::ReadPolicy: depth outside (0, background) is background; non-finite values
          // of other channels but color become 0.
          if (r.key == Channel::depth && !(want > 0.0 && want < kBackgroundDepth))
            want = kBackgroundDepth;
          else if (r.key != Channel::color && r.type == PixelType::F32 && !std::isfinite(want))
            want = 0.0;
          if (!close_enough(double(img.plane(c)[i]), want))
            contract_broken("plane value is not scale * file + offset",
                            std::string(r.name) + " from " + ps.file_name);
        }
      }
    });
  }
}

// The user-facing parsers: their errors are expected; a layout they accept must read the
// frame or refuse it with an error (read_frame validates what it loads).
void fuzz_layout_specs(const std::string& text, const Source& src) {
  Layout layout = afterimage_layout();
  const bool parsed = expect_errors([&] {
    if (text[0] == '{') {
      layout = io::layout_from_json_text(text, "fuzz layout");
      return;
    }
    std::istringstream in{text};
    std::string line;
    while (std::getline(in, line))
      if (line.rfind("--map ", 0) == 0) io::apply_map(layout, line.substr(6));
  });
  if (!parsed) return;
  expect_errors([&] { io::read_frame(src.file.path(), ChannelSet{}, "fuzz", nullptr, layout); });
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
  static const Source src;
  if (size > 4096) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (!text.empty() && (text[0] == '{' || text.rfind("--map ", 0) == 0)) {
    fuzz_layout_specs(text, src);
    return 0;
  }
  const Parsed p = parse(std::string_view(reinterpret_cast<const char*>(data), size));
  Frame f;
  if (expect_errors(
          [&] { f = io::read_frame(src.file.path(), p.required, "fuzz", nullptr, p.layout); }))
    check_loaded(f, p, src);
  return 0;
}
