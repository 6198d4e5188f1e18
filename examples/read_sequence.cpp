// Files to files, two ways: a loop over an EXR sequence read through the library
// (FrameReader -> Method -> write_exr), and the same run in one call (run_files). Both outputs
// are read back and must hold the same pixels.
//
//   read_sequence IN_DIR OUT_DIR [METHOD]      METHOD defaults to taa:afterimage
//
// IN_DIR: frames such as `afterimage render --scene motion --frames 6 --size 96x54 --out IN_DIR`
// writes (color, depth, motion, ... and the camera in each file's header), or another tool's
// that the automatic layout recognises. Outputs: OUT_DIR/frame.NNNN.exr and OUT_DIR-files/.
#include <afterimage/afterimage.hpp>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace {

// Notes from the reader (a repaired pixel value, a camera sidecar taken) go to stderr.
void note(const std::string& text) {
  std::fprintf(stderr, "note: %s\n", text.c_str());
}

// True when channel `name` holds the same values in both frames (or is in neither).
bool same_channel(const afterimage::FrameData& a, const afterimage::FrameData& b,
                  const std::string& name) {
  if (a.has(name) != b.has(name)) return false;
  if (!a.has(name)) return true;
  // FrameData's views are planar and packed: width * height * channels floats.
  const afterimage::BufferView va = a.channel(name), vb = b.channel(name);
  if (va.width != vb.width || va.height != vb.height || va.channels != vb.channels) return false;
  const size_t bytes = size_t(va.width) * va.height * va.channels * sizeof(float);
  return std::memcmp(va.data, vb.data, bytes) == 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4) {
    std::fprintf(stderr, "usage: %s IN_DIR OUT_DIR [METHOD]   (METHOD: taa:afterimage)\n", argv[0]);
    return 2;
  }
  const std::string in_dir = argv[1];
  std::string out_dir = argv[2];
  while (out_dir.size() > 1 && out_dir.back() == '/') out_dir.pop_back();
  const std::string spec = argc > 3 ? argv[3] : "taa:afterimage";
  const std::string files_dir = out_dir + "-files";

  try {
    // write_exr writes where it is told: keep the loop's outputs off the inputs.
    std::error_code ec;
    if (std::filesystem::equivalent(in_dir, out_dir, ec)) {
      std::fprintf(stderr, "error: %s: the output folder is the input folder\n", out_dir.c_str());
      return 1;
    }

    // 1. Frame by frame. The reader checks each file as it reads it; a problem is an
    //    afterimage::InputError naming the file.
    afterimage::FrameReader reader(in_dir, {}, note);
    afterimage::Method method(spec);
    std::printf("%s: %zu frames, layout %s; %s needs", in_dir.c_str(), reader.size(),
                reader.layout().c_str(), method.name().c_str());
    for (const std::string& c : method.required_channels()) std::printf(" %s", c.c_str());
    std::printf("\n");

    std::vector<float> out;  // the output color, interleaved, reused for every frame
    double process_seconds = 0;
    for (size_t i = 0; i < reader.size(); ++i) {
      const afterimage::FrameData frame = reader.read(i);
      // TAAU's output is larger than its input; RGBA when the input has coverage alpha.
      const auto [ow, oh] = method.output_size(frame.width(), frame.height());
      const int channels = frame.has("alpha") ? 4 : 3;
      out.resize(size_t(ow) * oh * channels);
      const auto view = afterimage::BufferView::interleaved(out.data(), ow, oh, channels);

      const auto t0 = std::chrono::steady_clock::now();
      method.process(frame.input(), view);
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      process_seconds += ms / 1000;

      // The output keeps the input's frame number and camera (view, projection, jitter, lens).
      char name[32];
      std::snprintf(name, sizeof name, "/frame.%04d.exr", frame.camera().index);
      const std::string path = out_dir + name;
      afterimage::write_exr(path, view, frame.camera());
      std::printf("  %s -> %s  %dx%d, %.1f ms\n", reader.path(i).c_str(), path.c_str(), ow, oh, ms);
    }
    std::printf("%zu frames in %.3f s of processing (%.1f ms a frame)\n", reader.size(),
                process_seconds, reader.size() ? 1000 * process_seconds / reader.size() : 0.0);

    // 2. The same in one call: every input header is checked before anything is written.
    const afterimage::RunSummary summary =
        afterimage::run_files(spec, {}, in_dir, files_dir, {}, {}, note);
    std::printf("run_files: %zu frames into %s in %.3f s (%.3f s processing), layout %s\n",
                summary.frames, files_dir.c_str(), summary.seconds, summary.process_seconds,
                summary.layout.c_str());

    // 3. Both outputs, read back, hold the same pixels: the API and the CLI's files-to-files run
    //    compute the same bits.
    const afterimage::FrameReader a(out_dir, {}, note), b(files_dir, {}, note);
    if (a.size() != reader.size() || b.size() != reader.size()) {
      std::fprintf(stderr, "error: %zu and %zu output frames for %zu inputs\n", a.size(), b.size(),
                   reader.size());
      return 1;
    }
    for (size_t i = 0; i < a.size(); ++i) {
      const afterimage::FrameData fa = a.read(i), fb = b.read(i);
      if (!same_channel(fa, fb, "color") || !same_channel(fa, fb, "alpha")) {
        std::fprintf(stderr, "error: %s and %s differ\n", a.path(i).c_str(), b.path(i).c_str());
        return 1;
      }
    }
    std::printf("%s and %s hold the same pixels\n", out_dir.c_str(), files_dir.c_str());
    return 0;
  } catch (const afterimage::Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
