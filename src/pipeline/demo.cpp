#include "pipeline/demo.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "io/io.h"
#include "metrics/metrics.h"
#include "pipeline/evaluate.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "taa/presets.h"
#include "taa/resolver.h"

namespace afterimage {

namespace fs = std::filesystem;

namespace {

// Bump when the renderer's output changes, so stale caches are re-rendered.
constexpr int kCacheVersion = 1;

const char* scene_description(const std::string& name) {
  for (const auto& s : render::builtin_scenes())
    if (name == s.name) return s.description;
  return "";
}

nlohmann::json cache_stamp(const std::string& scene, const DemoSettings& s) {
  return {{"version", kCacheVersion},
          {"scene", scene},
          {"width", s.width},
          {"height", s.height},
          {"frames", s.frames},
          {"reference_spp", s.reference_spp},
          {"ssaa", s.ssaa}};
}

std::vector<int> ssaa_list(const DemoSettings& s) {
  std::vector<int> v = {1};  // 1 sample at the pixel center = no anti-aliasing
  for (int n : s.ssaa)
    if (n != 1) v.push_back(n);
  return v;
}

// One-line progress on stderr, rewritten in place.
void progress(const std::string& what, int done, int total) {
  std::fprintf(stderr, "\r%-40s %4d/%d", what.c_str(), done, total);
  if (done == total) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

bool have_program(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::string p(path);
  size_t start = 0;
  while (start <= p.size()) {
    size_t end = p.find(':', start);
    if (end == std::string::npos) end = p.size();
    fs::path cand = fs::path(p.substr(start, end - start)) / name;
    std::error_code ec;
    if (fs::exists(cand, ec)) return true;
    start = end + 1;
  }
  return false;
}

ImageF hstack(const std::vector<const ImageF*>& images) {
  int w = 0, h = images.front()->height();
  for (auto* i : images) w += i->width();
  ImageF out(w, h, 3);
  int x0 = 0;
  for (auto* i : images) {
    for (int c = 0; c < 3; ++c)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < i->width(); ++x) out.at(x0 + x, y, c) = i->at(x, y, c);
    x0 += i->width();
  }
  return out;
}

// no-AA | TAA | reference side by side, encoded with ffmpeg (H.264, yuv420p).
void write_video(const std::string& path, const std::vector<ImageF>& noaa,
                 const std::vector<ImageF>& taa, const std::vector<ImageF>& ref,
                 const metrics::DisplaySettings& display, const Exec& ex) {
  fs::path tmp = fs::path(path).parent_path() / (fs::path(path).stem().string() + ".frames");
  fs::remove_all(tmp);
  fs::create_directories(tmp);
  for (size_t t = 0; t < ref.size(); ++t) {
    ImageF a = metrics::to_display(noaa[t], display, ex),
           b = metrics::to_display(taa[t], display, ex),
           c = metrics::to_display(ref[t], display, ex);
    io::write_rgb((tmp / fmt::format("{:04d}.png", t)).string(), hstack({&a, &b, &c}));
  }
  const std::string part = path + ".part.mp4";
  const std::string cmd = fmt::format(
      "ffmpeg -loglevel error -y -framerate 30 -i '{}/%04d.png' -vf "
      "'scale=trunc(iw/2)*2:trunc(ih/2)*2' "
      "-c:v libx264 -pix_fmt yuv420p -crf 18 '{}' < /dev/null",
      tmp.string(), part);
  const int rc = std::system(cmd.c_str());
  fs::remove_all(tmp);
  if (rc != 0) {
    std::error_code ec;
    fs::remove(part, ec);
    throw InputError(fmt::format("{}: ffmpeg failed (exit {})", path, rc));
  }
  fs::rename(part, path);
}

}  // namespace

taa::TaaSettings parse_preset_spec(const std::string& spec) {
  size_t plus = spec.find('+');
  taa::TaaSettings t = taa::make_preset(spec.substr(0, plus));
  while (plus != std::string::npos) {
    size_t next = spec.find('+', plus + 1);
    t.set_assignment(spec.substr(plus + 1, next == std::string::npos ? next : next - plus - 1));
    plus = next;
  }
  t.validate();
  return t;
}

void DemoSettings::validate() const {
  if (width < 16 || height < 16 || width > 8192 || height > 8192)
    throw SettingsError(fmt::format("demo: size {}x{} outside 16..8192", width, height));
  if (frames < 2 || frames > 10000)
    throw SettingsError(fmt::format("demo: frames {} outside 2..10000", frames));
  if (warmup < 0 || warmup >= frames)
    throw SettingsError(fmt::format("demo: warmup {} must be in [0, frames)", warmup));
  if (scenes.empty()) throw SettingsError("demo: no scenes");
  const auto names = render::builtin_scene_names();
  for (const auto& sc : scenes)
    if (std::find(names.begin(), names.end(), sc) == names.end())
      throw SettingsError(
          fmt::format("demo: unknown scene '{}' (valid: {})", sc, fmt::join(names, ", ")));
  render::samples_per_axis(reference_spp, "--reference");
  for (int n : ssaa) render::samples_per_axis(n, "--ssaa");
  for (const auto& p : presets) parse_preset_spec(p);  // throws on unknown names / keys
}

SceneSequence load_or_render_scene(const std::string& scene, const DemoSettings& s,
                                   const Exec& ex) {
  const fs::path dir = fs::path(s.out_dir) / "cache" /
                       fmt::format("{}-{}x{}-{}f", scene, s.width, s.height, s.frames);
  const fs::path stamp = dir / "stamp.json";
  const auto want = cache_stamp(scene, s);
  const auto spps = ssaa_list(s);
  SceneSequence seq;

  bool cached = false;
  if (fs::exists(stamp)) {
    try {
      nlohmann::json have = nlohmann::json::parse(std::ifstream(stamp));
      cached = have == want;
    } catch (const std::exception&) {
      cached = false;
    }
  }
  if (cached) {
    try {
      for (int t = 0; t < s.frames; ++t) {
        seq.gbuffer.push_back(
            io::read_frame(io::frame_path(dir.string(), t),
                           {"color", "depth", "normal", "albedo", "motion", "id"}));
        seq.reference.push_back(
            io::read_frame(io::frame_path((dir / "reference").string(), t)).color);
      }
      for (int n : spps) {
        std::vector<ImageF> v;
        for (int t = 0; t < s.frames; ++t)
          v.push_back(
              io::read_frame(io::frame_path((dir / fmt::format("ssaa{}", n)).string(), t)).color);
        seq.ssaa.push_back({n, std::move(v)});
      }
      fmt::print(stderr, "{}: using cached renders in {}\n", scene, dir.string());
      return seq;
    } catch (const InputError& e) {
      fmt::print(stderr, "{}: cache unusable ({}); rendering again\n", scene, e.what());
      seq = {};
    }
  }

  fs::create_directories(dir);
  std::error_code ec;
  fs::remove(stamp, ec);
  const render::Scene sc = render::make_builtin_scene(scene, false);
  render::RenderSettings rs;
  rs.width = s.width;
  rs.height = s.height;
  render::RenderStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  for (int t = 0; t < s.frames; ++t) {
    progress(fmt::format("{}: rendering G-buffer + references", scene), t, s.frames);
    Frame g = render::render_gbuffer(sc, t, rs, ex, &stats);
    io::write_frame(io::frame_path(dir.string(), t), g);
    seq.gbuffer.push_back(std::move(g));
    Frame r = render::render_reference(sc, t, s.reference_spp, rs, ex, &stats);
    io::write_frame(io::frame_path((dir / "reference").string(), t), r);
    seq.reference.push_back(std::move(r.color));
  }
  for (int n : spps) {
    std::vector<ImageF> v;
    for (int t = 0; t < s.frames; ++t) {
      Frame r = render::render_reference(sc, t, n, rs, ex, &stats);
      io::write_frame(io::frame_path((dir / fmt::format("ssaa{}", n)).string(), t), r);
      v.push_back(std::move(r.color));
    }
    seq.ssaa.push_back({n, std::move(v)});
  }
  progress(fmt::format("{}: rendering G-buffer + references", scene), s.frames, s.frames);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  fmt::print(stderr, "{}: rendered in {:.1f} s, {:.2f} Mrays/s\n", scene, secs,
             stats.rays() / std::max(secs, 1e-9) / 1e6);
  std::ofstream(stamp) << want.dump(2) << "\n";
  return seq;
}

std::string run_demo(const DemoSettings& s, const Exec& ex) {
  s.validate();
  fs::create_directories(s.out_dir);
  std::vector<std::string> presets = s.presets;
  if (presets.empty())  // every published preset; "none" (no rectification) is for tests
    for (const auto& p : taa::preset_names())
      if (p != "none") presets.push_back(p);
  metrics::MetricsSettings ms = default_eval_metrics();
  ms.warmup = s.warmup;

  ReportData report;
  report.title = "Afterimage demo: TAA presets vs. supersampling on the built-in scenes";
  report.commands.push_back(s.command_line);
  report.notes.push_back(fmt::format(
      "{}x{}, {} frames at 30 fps; reference = {} stratified samples per pixel (box filter); "
      "no-AA = 1 sample at the pixel center; TAA input = 1 jittered sample per pixel "
      "(Halton 2,3 x16). Means exclude the first {} frames. Display metrics after a per-channel "
      "Reinhard tonemap and sRGB encoding. ghosting = mean error 1-4 frames after "
      "disocclusion; sharpness = gradient energy relative to the reference (1 = as sharp).",
      s.width, s.height, s.frames, s.reference_spp, s.warmup));
  nlohmann::json all_json;

  for (const auto& scene : s.scenes) {
    SceneSequence seq = load_or_render_scene(scene, s, ex);
    std::vector<MethodEvaluation> evals;
    auto evaluate_images = [&](const std::string& label, const std::vector<ImageF>& frames,
                               const std::string& how, double ms_per_frame) {
      MethodEvaluator ev(label, ms, ex);
      for (int t = 0; t < s.frames; ++t) ev.add(frames[t], seq.reference[t], &seq.gbuffer[t]);
      evals.push_back(ev.finish(frames.back(), how, ms_per_frame));
    };
    for (const auto& [n, frames] : seq.ssaa)
      evaluate_images(n == 1 ? "no-AA" : fmt::format("SSAA {}x", n), frames,
                      fmt::format("afterimage render --scene {} --ssaa {}", scene, n), -1);
    std::vector<ImageF> default_taa;
    for (const auto& p : presets) {
      progress(fmt::format("{}: TAA preset {}", scene, p), 0, s.frames);
      taa::TemporalResolver resolver(parse_preset_spec(p), ex);
      std::vector<ImageF> out;
      double total_ms = 0;
      for (int t = 0; t < s.frames; ++t) {
        const auto t0 = std::chrono::steady_clock::now();
        out.push_back(resolver.process(seq.gbuffer[t]));
        total_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                        .count();
      }
      progress(fmt::format("{}: TAA preset {}", scene, p), s.frames, s.frames);
      evaluate_images("TAA " + p, out, "afterimage resolve --preset " + p, total_ms / s.frames);
      if (p == "afterimage" || default_taa.empty()) default_taa = std::move(out);
    }
    fmt::print("\n== {} ({}x{}, {} frames, means after frame {}) ==\n{}", scene, s.width, s.height,
               s.frames, s.warmup, format_eval_table(evals));

    SceneSection sec;
    sec.name = scene;
    sec.description = scene_description(scene);
    for (const auto& e : evals) sec.methods.push_back(to_summary(e));
    sec.figures = make_figures(evals, seq.reference.back(), ms.display, 2, ex);
    report.scenes.push_back(std::move(sec));
    all_json[scene] = eval_to_json(evals, ms);

    if (s.video && have_program("ffmpeg") && !seq.ssaa.empty()) {
      const std::string mp4 = (fs::path(s.out_dir) / (scene + ".mp4")).string();
      write_video(mp4, seq.ssaa.front().second, default_taa, seq.reference, ms.display, ex);
      fmt::print("video (no-AA | TAA {} | reference): {}\n",
                 std::find(presets.begin(), presets.end(), "afterimage") != presets.end()
                     ? "afterimage"
                     : presets.front(),
                 mp4);
    }
  }
  const std::string json_path = (fs::path(s.out_dir) / "metrics.json").string();
  std::ofstream(json_path) << all_json.dump(2) << "\n";
  const std::string report_path = (fs::path(s.out_dir) / "report.html").string();
  std::ofstream(report_path) << render_report_html(report);
  fmt::print("\nmetrics: {}\nreport: {}\n", json_path, report_path);
  return report_path;
}

}  // namespace afterimage
