// Writes the seed corpora and the dictionaries of the fuzz harnesses (tests/fuzz/README.md):
//
//   make_seeds OUT_DIR
//
// creates OUT_DIR/corpus/<harness>/seed-* and OUT_DIR/dict/<harness>.dict from the library
// itself (write_frame, save_state, the parameter tables, the channel table), so the seeds stay
// valid when those change. The committed corpora started from its output.
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "core/state_file.h"
#include "fuzz_common.h"
#include "io/io.h"
#include "post/sharpen.h"
#include "run/methods.h"
#include "taa/presets.h"
#include "taa/settings.h"
#include "taa/taa_method.h"

namespace fs = std::filesystem;
using namespace afterimage;

namespace {

fs::path g_out;

void write_file(const fs::path& p, std::string_view bytes) {
  fs::create_directories(p.parent_path());
  std::ofstream f(p, std::ios::binary);
  f.write(bytes.data(), std::streamsize(bytes.size()));
  if (!f) throw std::runtime_error("cannot write " + p.string());
}

std::string read_file(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}

fs::path corpus(const std::string& harness, const std::string& name) {
  return g_out / "corpus" / harness / ("seed-" + name);
}

// libFuzzer dictionary entry: "\xNN" escapes for anything but printable ASCII.
std::string dict_entry(std::string_view bytes) {
  std::string s = "\"";
  for (unsigned char c : bytes) {
    if (c >= 0x20 && c < 0x7f && c != '"' && c != '\\')
      s += char(c);
    else
      s += fmt::format("\\x{:02x}", c);
  }
  return s + "\"\n";
}

void write_dict(const std::string& harness, const std::set<std::string>& entries) {
  std::string text =
      fmt::format("# {} dictionary, written by tests/fuzz/make_seeds.cpp\n", harness);
  for (const auto& e : entries) text += dict_entry(e);
  write_file(g_out / "dict" / (harness + ".dict"), text);
}

// Re-encodes an EXR with another compression / pixel type / tiling (OpenEXR's decoders are
// the loader's largest attack surface).
void reencode(const fs::path& from, const fs::path& to, const std::string& compression, bool half,
              bool tiled) {
  OIIO::ImageBuf buf(from.string());
  if (!buf.read(0, 0, true)) throw std::runtime_error(buf.geterror());
  OIIO::ImageSpec spec = buf.spec();
  spec.attribute("compression", compression);
  if (half) {
    spec.set_format(OIIO::TypeDesc::HALF);
    spec.channelformats.clear();
  }
  if (tiled) spec.tile_width = spec.tile_height = 4, spec.tile_depth = 1;
  auto out = OIIO::ImageOutput::create(to.string());
  if (!out || !out->open(to.string(), spec))
    throw std::runtime_error("cannot open " + to.string() + ": " + OIIO::geterror());
  if (!buf.write(out.get())) throw std::runtime_error(buf.geterror());
  out->close();
}

void frame_seeds() {
  const std::string h = "fuzz_frame_loader";
  Frame all = fuzz::tiny_frame(8, 4, 1);
  all.view.m[0][3] = 2.5;
  all.camera_cut = true;
  io::write_frame(corpus(h, "8x4-all.exr").string(), all);

  Frame core = Frame::allocate(4, 2);
  core.color.fill(0.5f);
  core.depth.at(1, 1, 0) = std::numeric_limits<float>::infinity();
  core.color.at(0, 0, 1) = std::numeric_limits<float>::quiet_NaN();
  io::write_frame(corpus(h, "4x2-core-nan.exr").string(), core);

  Frame minimal = Frame::allocate(3, 3, {Channel::color, Channel::depth, Channel::motion});
  minimal.motion.fill(-40.0f);
  io::write_frame(corpus(h, "3x3-taa-channels.exr").string(), minimal);

  Frame color_only = Frame::allocate(2, 2, {Channel::color});
  io::write_frame(corpus(h, "2x2-color-only.exr").string(), color_only);

  const fs::path src = corpus(h, "4x2-core-nan.exr");
  for (const char* c : {"none", "rle", "zips", "piz", "pxr24", "b44", "dwaa"})
    reencode(src, corpus(h, fmt::format("4x2-{}.exr", c)), c, false, false);
  reencode(src, corpus(h, "4x2-half-piz.exr"), "piz", true, false);
  reencode(src, corpus(h, "4x2-tiled-zip.exr"), "zip", false, true);

  std::set<std::string> dict = {std::string("\x76\x2f\x31\x01", 4),
                                "channels",
                                "chlist",
                                "compression",
                                "dataWindow",
                                "displayWindow",
                                "box2i",
                                "lineOrder",
                                "pixelAspectRatio",
                                "screenWindowCenter",
                                "screenWindowWidth",
                                "tiles",
                                "tiledesc",
                                "type",
                                "name",
                                "scanlineimage",
                                "tiledimage",
                                "deepscanline",
                                "chunkCount",
                                "version",
                                "string",
                                "float",
                                "double",
                                "int",
                                "m44d",
                                "m44f",
                                "v2d",
                                "v2f",
                                "afterimage:view",
                                "afterimage:projection",
                                "afterimage:jitter",
                                "afterimage:frame",
                                "afterimage:time",
                                "afterimage:camera_cut",
                                "afterimage:lens_focal_mm"};
  for (const ChannelInfo& r : kChannelTable)
    for (int c = 0; c < r.planes; ++c) dict.insert(r.exr[size_t(c)]);
  write_dict(h, dict);
}

void state_seeds() {
  const std::string h = "fuzz_state_loader";
  const fs::path tmp = g_out / "tmp.state";
  auto save = [&](const SequenceMethod& m, const std::string& name) {
    m.save_state(tmp.string());
    const std::string file = read_file(tmp);
    // Mode 0: the file as written; mode 1: without its checksum (the harness appends it).
    write_file(corpus(h, name + "-raw"), std::string(1, '\0') + file);
    write_file(corpus(h, name + "-fixsum"), std::string(1, '\1') + file.substr(0, file.size() - 8));
    fs::remove(tmp);
  };
  taa::TaaMethod m("taa:afterimage", taa::preset_afterimage(), Exec{1, true});
  save(m, "empty");
  m.process(fuzz::tiny_frame(8, 4, 0));
  m.process(fuzz::tiny_frame(8, 4, 1));
  save(m, "8x4-two-frames");
  Frame small = Frame::allocate(2, 1, {Channel::color});
  m.process(small);
  save(m, "2x1-color-only");

  std::set<std::string> dict = {"AFTERIMAGE-STATE",
                                "taa",
                                std::string("\x04\x03\x02\x01", 4),
                                std::string("\x01\x02\x03\x04", 4),
                                std::string("\x00\x00\x01\x00", 4),
                                std::string("\xff\xff\xff\xff", 4)};
  for (const char* s : {"width", "height", "valid", "frames", "history", "count", "prev_depth",
                        "prev_motion", "prev_id"}) {
    dict.insert(s);
    const uint32_t len = uint32_t(std::string_view(s).size());
    dict.insert(std::string(reinterpret_cast<const char*>(&len), 4) + s);
  }
  write_dict(h, dict);
}

void settings_seeds() {
  const std::string h = "fuzz_settings";
  std::set<std::string> dict = {"taa:", "taa", "+",  "=",   "true", "false", "on",
                                "off",  "1e9", "-0", "nan", "inf",  "1e-45", "0x1p-3"};
  for (const std::string& name : registered_method_names()) {
    write_file(corpus(h, name.substr(name.find(':') + 1)), name);
    dict.insert(name);
    dict.insert(name.substr(name.find(':') + 1));
  }
  // Every key at its default, as --set lines (the CLI path) and as one spec.
  const taa::TaaSettings d;
  std::string lines = "hdrp", spec = "taa:ue4";
  for (const auto& f : taa::TaaSettings::params().fields()) {
    const std::string kv = f.key + "=" + f.get(d);
    lines += "\n" + kv;
    spec += "+" + kv;
    dict.insert(f.key);
    dict.insert(f.key + "=");
    for (const auto& n : f.names) dict.insert(n);
  }
  write_file(corpus(h, "all-keys-lines"), lines);
  write_file(corpus(h, "all-keys-spec"), spec);
  write_file(corpus(h, "sharpen"), "inside+sharpen=0.5+alpha=0.2\nsharpen=4\nalpha_min=0.001");
  write_file(corpus(h, "errors"), "svgf:x\nalpha\n=1\nalpha=2\nhistory=bicubic");
  dict.insert("sharpen");
  dict.insert("sharpen=");
  write_dict(h, dict);
}

void layout_seeds() {
  const std::string h = "fuzz_layout";
  std::string own = "require color depth motion\n";
  std::set<std::string> dict = {"map ", "unmap ", "require ", ":-1:0", ":1:0.5", ":", "\n"};
  for (const ChannelInfo& r : kChannelTable) {
    own += fmt::format("map {}", r.name);
    for (int c = 0; c < r.planes; ++c) own += fmt::format(" {}", r.exr[size_t(c)]);
    own += "\n";
    dict.insert(r.name);
    for (int c = 0; c < r.planes; ++c) dict.insert(r.exr[size_t(c)]);
  }
  write_file(corpus(h, "afterimage"), own);
  write_file(corpus(h, "foreign"),
             "map color albedo.R albedo.G albedo.B\n"
             "map depth Z:0.5:1\n"
             "map motion motion.X:1:0 motion.Y:-1:0\n"
             "unmap id\n"
             "require color motion\n");
  write_file(corpus(h, "bad-counts"), "map color R G\nmap id id:2:0\nmap depth nosuch\n");
  write_dict(h, dict);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUT_DIR\n", argv[0]);
    return 2;
  }
  g_out = argv[1];
  try {
    frame_seeds();
    state_seeds();
    settings_seeds();
    layout_seeds();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_seeds: %s\n", e.what());
    return 1;
  }
  std::printf("seeds and dictionaries written under %s\n", g_out.c_str());
  return 0;
}
