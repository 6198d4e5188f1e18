#include "apps/demo/demo.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <tuple>
#include <utility>

#include "apps/demo/demo_lights.h"
#include "apps/demo/demo_post.h"
#include "apps/demo/demo_reprojection.h"
#include "apps/demo/demo_split.h"
#include "apps/demo/demo_svgf.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "eval/evaluate.h"
#include "io/io.h"
#include "io/video.h"
#include "metrics/metrics.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "run/methods.h"
#include "run/sequence.h"
#include "taau/resample.h"

namespace afterimage {

namespace fs = std::filesystem;

namespace {

// Bump when the renderer's output changes, so stale caches are re-rendered.
constexpr int kCacheVersion = 2;  // 2: direct light composed from its demodulated split

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
          {"warmup", s.warmup},
          {"warmup_reference_spp", s.warmup_reference_spp},
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

}  // namespace

void DemoSettings::validate() const {
  if (width < 16 || height < 16 || width > 8192 || height > 8192)
    throw SettingsError(fmt::format("demo: size {}x{} outside 16..8192", width, height));
  if (frames < 2 || frames > 10000)
    throw SettingsError(fmt::format("demo: frames {} outside 2..10000", frames));
  if (warmup < 0 || warmup >= frames)
    throw SettingsError(fmt::format("demo: warmup {} must be in [0, frames)", warmup));
  const auto names = render::builtin_scene_names();
  for (const auto* list :
       {&scenes, &cache_scenes, &extrapolate_scenes, &light_scenes, &denoise_scenes})
    for (const auto& sc : *list)
      if (std::find(names.begin(), names.end(), sc) == names.end())
        throw SettingsError(
            fmt::format("demo: unknown scene '{}' (valid: {})", sc, fmt::join(names, ", ")));
  if (!effect_sections.empty()) {
    if (effect_frames < 1 || effect_frames > 10000)
      throw SettingsError(fmt::format("demo: effect frames {} outside 1..10000", effect_frames));
    render::samples_per_axis(effect_spp, "demo effect spp");
    for (const auto& sec : effect_sections) {
      const size_t colon = sec.find(':');
      const std::string stage = sec.substr(0, colon),
                        scene = colon == std::string::npos ? "" : sec.substr(colon + 1);
      if ((stage != "dof" && stage != "motion_blur") ||
          std::find(names.begin(), names.end(), scene) == names.end())
        throw SettingsError(fmt::format(
            "demo: effect section '{}': expected dof:SCENE or motion_blur:SCENE (scenes: {})", sec,
            fmt::join(names, ", ")));
    }
  }
  if (!frames_format.empty()) parse_output_format(frames_format);  // throws SettingsError
  if (!denoise_scenes.empty() &&
      (denoise_frames < 2 || denoise_frames > 10000 || denoise_spp < 1 || denoise_spp > 1 << 16))
    throw SettingsError(
        fmt::format("demo: denoise frames {} outside 2..10000 or spp {} outside "
                    "1..65536",
                    denoise_frames, denoise_spp));
  if (!light_scenes.empty() && (light_frames < 1 || light_frames > 10000))
    throw SettingsError(fmt::format("demo: light frames {} outside 1..10000", light_frames));
  if ((!cache_scenes.empty() || !extrapolate_scenes.empty()) &&
      (cache_frames < 3 || cache_frames > 10000))
    throw SettingsError(fmt::format("demo: cache frames {} outside 3..10000", cache_frames));
  render::samples_per_axis(reference_spp, "--reference");
  render::samples_per_axis(warmup_reference_spp, "--warmup-reference");
  for (int n : ssaa) render::samples_per_axis(n, "--ssaa");
  for (const auto& m : methods) {
    // Throws on unknown names / keys; the main table scores outputs at the rendered size.
    if (make_method(m)->output_size(width, height) != std::pair(width, height))
      throw SettingsError(fmt::format(
          "demo: method '{}' changes the frame size; upsampling runs in the TAAU section "
          "(--taau-methods)",
          m));
  }
  if (taau_scale != 0.0f && !(taau_scale >= 1.0f && taau_scale <= 4.0f))
    throw SettingsError(
        fmt::format("demo: --taau-scale {} must be 0 (no TAAU section) or in [1, 4]", taau_scale));
  if (taau_scale != 0.0f) {
    const auto [lw, lh] = render::scaled_render_size(width, height, taau_scale);
    for (const auto& m : taau_method_list())
      if (make_method(m)->output_size(lw, lh) != std::pair(width, height))
        throw SettingsError(fmt::format(
            "demo: TAAU method '{}' does not upsample {}x{} to {}x{} (set its scale to {} or "
            "output_width/output_height)",
            m, lw, lh, width, height, taau_scale));
  }
}

std::vector<std::string> default_taau_demo_methods(float scale) {
  // The registry's default TAAU variant at the section's scale.
  const std::string spec = "taau:" + default_variant("taau");
  return {scale == 2.0f ? spec : fmt::format("{}+scale={:g}", spec, scale)};
}

std::vector<std::string> DemoSettings::taau_method_list() const {
  return taau_methods.empty() ? default_taau_demo_methods(taau_scale) : taau_methods;
}

int ssaa_first_frame(int n, const DemoSettings& s) {
  return n == 1 ? 0 : std::clamp(s.warmup, 0, s.frames);
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
            io::read_frame(io::frame_path(dir.string(), t), core_channels(), "the demo"));
        seq.reference.push_back(
            io::read_frame(io::frame_path((dir / "reference").string(), t)).color);
      }
      for (int n : spps) {
        std::vector<ImageF> v;
        for (int t = 0; t < s.frames; ++t)
          v.push_back(
              t < ssaa_first_frame(n, s)
                  ? ImageF()
                  : io::read_frame(io::frame_path((dir / fmt::format("ssaa{}", n)).string(), t))
                        .color);
        seq.ssaa.push_back({n, std::move(v)});
      }
      fmt::print(stderr, "{}: using cached renders in {}\n", scene, dir.string());
      return seq;
    } catch (const InputError& e) {
      fmt::print(stderr, "{}: cache unusable ({}); rendering again\n", scene, e.what());
      seq = {};
    }
  }

  create_output_directory(dir.string());
  std::error_code ec;
  fs::remove(stamp, ec);
  const render::Scene sc = render::make_builtin_scene(scene, false);
  render::RenderSettings rs;
  rs.width = s.width;
  rs.height = s.height;
  render::RenderStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  // Passes per frame: G-buffer, reference, then each SSAA count (1 = no-AA).
  std::vector<render::RenderPass> passes = {{"gbuffer", 0}, {"reference", s.reference_spp}};
  passes[1].early_frames = s.warmup;
  passes[1].early_spp = s.warmup_reference_spp;
  passes[1].early_seed = rs.seed + 1;  // not SSAA 16x's samples when the counts match
  std::vector<std::string> dirs = {dir.string(), (dir / "reference").string()};
  for (int n : spps) {
    passes.push_back({fmt::format("ssaa {}", n), n});
    passes.back().first_frame = ssaa_first_frame(n, s);
    dirs.push_back((dir / fmt::format("ssaa{}", n)).string());
    seq.ssaa.push_back({n, std::vector<ImageF>(size_t(s.frames))});
  }
  render::render_sequence(
      sc, s.frames, passes, rs, ex,
      [&](int t, size_t pass, Frame&& f) {
        if (pass == 0)
          progress(fmt::format("{}: rendering G-buffer + references", scene), t, s.frames);
        io::write_frame(io::frame_path(dirs[pass], t), f);
        if (pass == 0)
          seq.gbuffer.push_back(std::move(f));
        else if (pass == 1)
          seq.reference.push_back(std::move(f.color));
        else
          seq.ssaa[pass - 2].second[size_t(t)] = std::move(f.color);
      },
      &stats);
  progress(fmt::format("{}: rendering G-buffer + references", scene), s.frames, s.frames);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  fmt::print(stderr, "{}: rendered in {:.1f} s, {:.2f} Mrays/s\n", scene, secs,
             stats.rays() / std::max(secs, 1e-9) / 1e6);
  io::write_text(stamp.string(), want.dump(2) + "\n");
  return seq;
}

LowResSequence render_low_res(const std::string& scene, int width, int height, int frames,
                              float scale, const Exec& ex) {
  const render::Scene sc = render::make_builtin_scene(scene, false);
  render::RenderSettings rs;
  std::tie(rs.width, rs.height) = render::scaled_render_size(width, height, scale);
  rs.jitter.length = render::jitter_length_for_scale(scale);
  LowResSequence low;
  low.scale = scale;
  render::render_sequence(sc, frames, {{"gbuffer", 0}, {"no-AA", 1}}, rs, ex,
                          [&](int, size_t pass, Frame&& f) {
                            if (pass == 0)
                              low.gbuffer.push_back(std::move(f));
                            else
                              low.noaa.push_back(std::move(f.color));
                          });
  return low;
}

LowResSequence load_or_render_low_res(const std::string& scene, const DemoSettings& s,
                                      const Exec& ex) {
  const fs::path dir = fs::path(s.out_dir) / "cache" /
                       fmt::format("{}-{}x{}-{}f", scene, s.width, s.height, s.frames) /
                       fmt::format("taau-{:.3f}", s.taau_scale);
  const fs::path stamp = dir / "stamp.json";
  nlohmann::json want = cache_stamp(scene, s);
  want["taau_scale"] = s.taau_scale;
  if (fs::exists(stamp)) {
    try {
      if (nlohmann::json::parse(std::ifstream(stamp)) == want) {
        LowResSequence low;
        low.scale = s.taau_scale;
        for (int t = 0; t < s.frames; ++t) {
          low.gbuffer.push_back(
              io::read_frame(io::frame_path(dir.string(), t), core_channels(), "the demo"));
          low.noaa.push_back(io::read_frame(io::frame_path((dir / "noaa").string(), t)).color);
        }
        fmt::print(stderr, "{}: using cached low-resolution renders in {}\n", scene, dir.string());
        return low;
      }
    } catch (const std::exception& e) {
      fmt::print(stderr, "{}: low-resolution cache unusable ({}); rendering again\n", scene,
                 e.what());
    }
  }
  create_output_directory(dir.string());
  std::error_code ec;
  fs::remove(stamp, ec);
  const auto t0 = std::chrono::steady_clock::now();
  LowResSequence low = render_low_res(scene, s.width, s.height, s.frames, s.taau_scale, ex);
  for (int t = 0; t < s.frames; ++t) {
    io::write_frame(io::frame_path(dir.string(), t), low.gbuffer[size_t(t)]);
    Frame f = low.gbuffer[size_t(t)].header_only();
    f.color = low.noaa[size_t(t)];
    io::write_frame(io::frame_path((dir / "noaa").string(), t), f);
  }
  fmt::print(stderr, "{}: low-resolution renders ({}x{}) in {:.1f} s\n", scene,
             low.gbuffer.front().width, low.gbuffer.front().height,
             std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  io::write_text(stamp.string(), want.dump(2) + "\n");
  return low;
}

std::vector<MethodEvaluation> evaluate_upscaling(
    const LowResSequence& low, const std::vector<Frame>& native_gbuffer,
    const std::vector<ImageF>& reference, const std::vector<std::string>& taau_specs,
    const std::string& taa_spec, const metrics::MetricsSettings& ms, const Exec& ex) {
  const size_t n = reference.size();
  AI_CHECK(low.gbuffer.size() == n && low.noaa.size() == n);
  const int W = reference.front().width(), H = reference.front().height();
  const bool native = !native_gbuffer.empty();
  // The rows in table order, fed frame by frame (the methods in lock step) so each reference
  // frame is prepared for scoring once: the four upscaled ones, native TAA, then each TAAU.
  struct Row {
    Row(MethodEvaluator e, std::string c, std::unique_ptr<SequenceMethod> m = nullptr,
        const std::vector<Frame>* in = nullptr)
        : ev(std::move(e)), command(std::move(c)), method(std::move(m)), input(in) {}
    MethodEvaluator ev;
    std::string command;
    std::unique_ptr<SequenceMethod> method;  // timed rows (native TAA, TAAU) and their input
    const std::vector<Frame>* input;
    double seconds = 0.0;
    ImageF last;
  };
  std::vector<Row> rows;
  const std::string scale = fmt::format("{:g}", low.scale);
  const std::pair<const char*, taau::ResampleFilter> filters[2] = {
      {"bicubic", taau::ResampleFilter::CatmullRom}, {"Lanczos-3", taau::ResampleFilter::Lanczos3}};
  for (const std::string src : {"no-AA", "TAA"})
    for (const auto& [name, filter] : filters)
      rows.emplace_back(MethodEvaluator(fmt::format("{} 1/{} + {}", src, scale, name), ms, ex),
                        fmt::format("{} at 1/{} per axis, {} upscaled",
                                    src == "TAA" ? method_label(taa_spec) : src, scale, name));
  if (native)
    rows.emplace_back(MethodEvaluator(method_label(taa_spec) + " native", ms, ex),
                      method_command(taa_spec), make_method(taa_spec, ex), &native_gbuffer);
  for (const auto& spec : taau_specs)
    rows.emplace_back(MethodEvaluator(method_label(spec), ms, ex), method_command(spec),
                      make_method(spec, ex), &low.gbuffer);
  const std::unique_ptr<SequenceMethod> taa_low = make_method(taa_spec, ex);
  for (size_t t = 0; t < n; ++t) {
    const Frame* g = native ? &native_gbuffer[t] : nullptr;
    const metrics::PreparedReference ref = metrics::prepare_reference(reference[t], ms, ex);
    const auto add = [&](Row& row, ImageF&& out) {
      row.ev.add(out, ref, g);
      if (t + 1 == n) row.last = std::move(out);
    };
    const ImageF taa = taa_low->process(low.gbuffer[t]).color;
    size_t r = 0;
    for (const ImageF* src : {&low.noaa[t], &taa})
      for (const auto& f : filters) add(rows[r++], taau::resample_image(*src, W, H, f.second, ex));
    for (; r < rows.size(); ++r) {
      const auto p0 = std::chrono::steady_clock::now();
      Frame out = rows[r].method->process((*rows[r].input)[t]);
      rows[r].seconds +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - p0).count();
      AI_CHECK(out.color.width() == W && out.color.height() == H);
      add(rows[r], std::move(out.color));
    }
  }
  std::vector<MethodEvaluation> evals;
  for (Row& row : rows)
    evals.push_back(
        row.ev.finish(row.last, row.command, row.method ? 1e3 * row.seconds / double(n) : -1.0));
  return evals;
}

std::vector<std::string> DemoSettings::scene_list() const {
  return scenes.empty() ? render::default_demo_scene_names() : scenes;
}

std::vector<std::string> DemoSettings::method_list() const {
  return methods.empty() ? default_demo_methods() : methods;
}

namespace {

// A table row's label as a directory name: lower case, runs of characters other than
// [a-z0-9._] as one '-' ("SSAA 4x" -> "ssaa-4x", "variance+variance_gamma=1.25" ->
// "variance-variance_gamma-1.25").
std::string file_name_slug(const std::string& label) {
  std::string out;
  for (unsigned char c : label) {
    const char l = char(std::tolower(c));
    if ((l >= 'a' && l <= 'z') || (l >= '0' && l <= '9') || l == '.' || l == '_')
      out += l;
    else if (!out.empty() && out.back() != '-')
      out += '-';
  }
  while (!out.empty() && (out.back() == '-' || out.back() == '.')) out.pop_back();
  return out.empty() ? "row" : out;
}

}  // namespace

std::string run_demo(const DemoSettings& s, const Exec& ex) {
  s.validate();
  create_output_directory(s.out_dir);
  const std::vector<std::string> methods = s.method_list();
  // The clip shows the default TAA preset when it runs, else the first method.
  const std::string default_spec = "taa:" + default_variant("taa");
  const std::string video_spec =
      std::find(methods.begin(), methods.end(), default_spec) != methods.end() ? default_spec
                                                                               : methods.front();
  metrics::MetricsSettings ms = default_eval_metrics();
  ms.warmup = s.warmup;

  ReportData report;
  report.title = "Afterimage demo: TAA presets vs. supersampling on the built-in scenes";
  report.commands.push_back(s.command_line);
  report.notes.push_back(fmt::format(
      "{}x{}, {} frames at 30 fps; reference = {} stratified samples per pixel (box filter; "
      "{} in the first {} frames, which only the per-frame plots show); "
      "no-AA = 1 sample at the pixel center; SSAA rows start after the warm-up; TAA input = 1 "
      "jittered sample per pixel "
      "(Halton 2,3 x16). Means exclude the first {} frames. Display metrics after a per-channel "
      "Reinhard tonemap and sRGB encoding. ghosting = mean error 1-4 frames after "
      "disocclusion; sharpness = gradient energy relative to the reference (1 = as sharp).",
      s.width, s.height, s.frames, s.reference_spp, s.warmup_reference_spp, s.warmup, s.warmup));
  nlohmann::json all_json;

  // --out-format: the frames of a main-table row, out_dir/frames/SCENE/ROW/frame.NNNN.EXT.
  SequenceOutput frames_out;
  if (!s.frames_format.empty()) frames_out.format = parse_output_format(s.frames_format);
  auto save_frame = [&](const std::string& scene, const std::string& row, size_t t,
                        const ImageF& linear) {
    if (s.frames_format.empty() || linear.empty()) return;  // an SSAA row's warm-up frames
    const fs::path dir = fs::path(s.out_dir) / "frames" / scene / file_name_slug(row);
    if (!fs::is_directory(dir)) create_output_directory(dir.string());
    fs::path path = io::frame_path(dir.string(), int(t));
    path.replace_extension(extension(frames_out.format));
    write_color_output(path.string(), linear, frames_out, nullptr, ex);
  };

  std::vector<SplitScene> split_scenes;  // main tables of the tuning / validation scenes
  for (const auto& scene : s.scene_list()) {
    SceneSequence seq = load_or_render_scene(scene, s, ex);
    for (int t = 0; t < s.frames; ++t) save_frame(scene, "reference", size_t(t), seq.reference[t]);
    // Every row frame by frame (the methods in lock step), so each reference frame is prepared
    // for scoring once (its display image, FLIP's half, sharpness's energy) instead of once a
    // row.
    std::vector<MethodEvaluator> ssaa_evs, method_evs;
    for (const auto& [n, frames] : seq.ssaa)
      ssaa_evs.emplace_back(n == 1 ? "no-AA" : fmt::format("SSAA {}x", n), ms, ex);
    std::vector<std::unique_ptr<SequenceMethod>> runs;
    for (const auto& spec : methods) {
      runs.push_back(make_method(spec, ex));
      method_evs.emplace_back(method_label(spec), ms, ex);
    }
    std::vector<double> process_seconds(methods.size(), 0.0);
    std::vector<ImageF> last(methods.size());
    std::vector<ImageF> video_frames;  // output of video_spec
    for (int t = 0; t < s.frames; ++t) {
      const Frame* g = &seq.gbuffer[size_t(t)];
      const metrics::PreparedReference ref = metrics::prepare_reference(seq.reference[t], ms, ex);
      for (size_t i = 0; i < seq.ssaa.size(); ++i) {
        const ImageF& frame = seq.ssaa[i].second[size_t(t)];
        if (frame.empty())
          ssaa_evs[i].skip(g);
        else
          ssaa_evs[i].add(frame, ref, g);
        save_frame(scene, ssaa_evs[i].label(), size_t(t), frame);
      }
      for (size_t j = 0; j < methods.size(); ++j) {
        const auto p0 = std::chrono::steady_clock::now();
        Frame out = runs[j]->process(*g);
        process_seconds[j] +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - p0).count();
        method_evs[j].add(out.color, ref, g);
        save_frame(scene, method_evs[j].label(), size_t(t), out.color);
        if (methods[j] == video_spec) video_frames.push_back(out.color);
        if (t + 1 == s.frames) last[j] = std::move(out.color);
      }
      progress(fmt::format("{}: running and scoring", scene), t + 1, s.frames);
    }
    std::vector<MethodEvaluation> evals;
    for (size_t i = 0; i < seq.ssaa.size(); ++i)
      evals.push_back(ssaa_evs[i].finish(
          seq.ssaa[i].second.back(),
          fmt::format("afterimage render --scene {} --ssaa {}", scene, seq.ssaa[i].first)));
    for (size_t j = 0; j < methods.size(); ++j)
      evals.push_back(method_evs[j].finish(last[j], method_command(methods[j]),
                                           1e3 * process_seconds[j] / s.frames));
    fmt::print("\n== {} ({}x{}, {} frames, means after frame {}) ==\n{}", scene, s.width, s.height,
               s.frames, s.warmup, format_eval_table(evals));

    SceneSection sec;
    sec.name = scene;
    sec.description = scene_description(scene);
    for (const auto& e : evals) sec.methods.push_back(to_summary(e));
    if (const render::TaaSplit split = render::taa_split_of(scene); split != render::TaaSplit::None)
      split_scenes.push_back({scene, split == render::TaaSplit::Validation, sec.methods});
    sec.figures = make_figures(evals, seq.reference.back(), ms.display, 2, ex);
    report.scenes.push_back(std::move(sec));
    all_json[scene] = eval_to_json(evals, ms);

    if (s.taau_scale != 0.0f) {
      // TAAU section (issue 10): low-resolution input upsampled to this size, scored against
      // the same native references.
      const LowResSequence low = load_or_render_low_res(scene, s, ex);
      const std::string taa_spec = "taa:" + default_variant("taa");
      std::vector<MethodEvaluation> up = evaluate_upscaling(low, seq.gbuffer, seq.reference,
                                                            s.taau_method_list(), taa_spec, ms, ex);
      const std::string title =
          fmt::format("{} TAAU {:g}x ({}x{} -> {}x{})", scene, s.taau_scale,
                      low.gbuffer.front().width, low.gbuffer.front().height, s.width, s.height);
      fmt::print("\n== {} ==\n{}", title, format_eval_table(up));
      SceneSection usec;
      usec.name = title;
      usec.description =
          "Temporal upsampling: input rendered at 1/scale per axis (Halton ceil(8 scale^2) "
          "jitter), scored against the native reference; bicubic = Catmull-Rom.";
      for (const auto& e : up) usec.methods.push_back(to_summary(e));
      usec.figures = make_figures(up, seq.reference.back(), ms.display, 1, ex);
      report.scenes.push_back(std::move(usec));
      all_json[scene + "/taau"] = eval_to_json(up, ms);
    }

    if (s.video && io::have_program("ffmpeg") && !seq.ssaa.empty()) {
      const std::string mp4 = (fs::path(s.out_dir) / (scene + ".mp4")).string();
      const std::vector<ImageF>& noaa = seq.ssaa.front().second;
      io::write_mp4(mp4, seq.reference.size(), [&](size_t t) {
        const ImageF a = metrics::to_display(noaa[t], ms.display, ex),
                     b = metrics::to_display(video_frames[t], ms.display, ex),
                     c = metrics::to_display(seq.reference[t], ms.display, ex);
        return hstack({&a, &b, &c});
      });
      fmt::print("video (no-AA | {} | reference): {}\n", method_label(video_spec), mp4);
    }
  }
  {
    // The default TAA preset against the anchors on the tuning and the held-out scenes
    // (issue 10; apps/demo/demo_split.h). Anchors: the published presets the methods ran,
    // without overrides, other than the default and `none`.
    std::vector<std::string> anchors;
    for (const auto& spec : methods)
      if (spec.rfind("taa:", 0) == 0 && spec.find('+') == std::string::npos &&
          spec != default_spec && spec != "taa:none")
        anchors.push_back(method_label(spec));
    const SplitVerdict v = judge_taa_split(split_scenes, method_label(default_spec), anchors);
    nlohmann::json split_json;
    for (const SceneSection* sec : {&v.tuning, &v.validation}) {
      if (sec->methods.empty()) continue;
      fmt::print("\n== {} ==\n{}\n{:<36}{:>9}{:>11}{:>9}\n", sec->name, sec->description, "method",
                 "FLIP", "temporal", "PSNR");
      for (const auto& m : sec->methods) {
        if (m.label.rfind("TAA", 0) != 0) continue;  // the TAA rows only
        fmt::print("{:<36}{:>9.4f}{:>11.5f}{:>9.3f}\n", m.label, m.aggregate.at("flip"),
                   m.aggregate.at("temporal_error"), m.aggregate.at("psnr"));
        split_json[sec == &v.tuning ? "tuning" : "validation"][m.label] = m.aggregate;
      }
      SceneSection copy = *sec;
      if (sec == &v.validation && v.judged) copy.description += "\n" + v.text();
      report.scenes.push_back(std::move(copy));
    }
    if (v.judged) {
      fmt::print("{}", v.text());
      split_json["verdict"] = {{"best_anchor", v.best_anchor},
                               {"flip_gain", v.flip_gain},
                               {"best_temporal_anchor", v.best_temporal_anchor},
                               {"temporal_ratio", v.temporal_ratio},
                               {"losses", v.losses}};
    }
    if (!split_json.empty()) all_json["taa_split"] = split_json;
  }
  // A table-only section (no figures): printed, in the report and in metrics.json.
  auto add_section = [&](const std::string& title, const std::string& description,
                         const std::vector<MethodEvaluation>& rows, const std::string& key,
                         const metrics::MetricsSettings& sms) {
    fmt::print("{}", format_eval_table(rows));
    SceneSection sec;
    sec.name = title;
    sec.description = description;
    for (const auto& e : rows) sec.methods.push_back(to_summary(e));
    report.scenes.push_back(std::move(sec));
    all_json[key] = eval_to_json(rows, sms);
  };
  for (const auto& scene : s.cache_scenes) {
    metrics::MetricsSettings cms = ms;
    cms.warmup = std::min(ms.warmup, s.cache_frames / 2);
    const ShadingCacheDemo demo =
        evaluate_shading_cache(scene, s.width, s.height, s.cache_frames, cms, ex);
    const std::string title =
        fmt::format("{} shading cache ({}x{}, {} frames, means after frame {})", scene, s.width,
                    s.height, s.cache_frames, cms.warmup);
    fmt::print("\n== {} ==\nfull shading: {:.1f} ms/frame\n", title, demo.full_ms_per_frame);
    add_section(title, demo.description, demo.rows, scene + "/shading_cache", cms);
    all_json[scene + "/shading_cache"]["full_shading_ms_per_frame"] = demo.full_ms_per_frame;
  }

  for (const auto& scene : s.extrapolate_scenes) {
    metrics::MetricsSettings ems = ms;
    ems.warmup = 0;  // every synthesised frame counts
    const ExtrapolationDemo demo =
        evaluate_extrapolation(scene, s.width, s.height, s.cache_frames, ems, ex);
    const std::string title = fmt::format("{} extrapolation ({}x{}, {} synthesised frames)", scene,
                                          s.width, s.height, s.cache_frames / 2);
    fmt::print("\n== {} ==\n", title);
    add_section(title, demo.description, demo.rows, scene + "/extrapolation", ems);
  }

  for (const auto& section : s.effect_sections) {
    metrics::MetricsSettings pms = ms;
    pms.warmup = 0;
    const PostEffectDemo demo =
        evaluate_post_effect(section, s.width, s.height, s.effect_frames, s.effect_spp, pms, ex);
    const std::string title = fmt::format("{} vs ray-traced reference ({}x{}, {} frames)", section,
                                          s.width, s.height, s.effect_frames);
    fmt::print("\n== {} ==\n", title);
    add_section(title, demo.description, demo.rows, section, pms);
  }

  for (const auto& scene : s.light_scenes) {
    metrics::MetricsSettings lms = ms;
    lms.warmup = 0;
    const LightEffectsDemo demo =
        evaluate_light_effects(scene, s.width, s.height, s.light_frames, s.effect_spp, lms, ex);
    fmt::print("\n== {} ==\n{}", demo.section.name, demo.table);
    report.scenes.push_back(demo.section);
    all_json[scene + "/light_effects"] = demo.json;
  }

  for (const auto& scene : s.denoise_scenes) {
    metrics::MetricsSettings dms = ms;
    dms.warmup = 0;  // the lag after the lamp switches on is part of what is measured
    const DenoiseDemo demo = evaluate_denoise(scene, s.denoise_width, s.denoise_height,
                                              s.denoise_frames, s.denoise_spp, dms, ex);
    const std::string title =
        fmt::format("{} denoising ({}x{}, {} frames, 1 spp in, {} spp references)", scene,
                    s.denoise_width, s.denoise_height, s.denoise_frames, s.denoise_spp);
    fmt::print("\n== {} ==\n", title);
    add_section(title, demo.description, demo.rows, scene + "/denoise", dms);
    if (demo.lag_step >= 0)
      fmt::print("lag after the light switch at frame {}: svgf + TAA {} frames, A-SVGF + TAA {}\n",
                 demo.lag_step, demo.lag_svgf, demo.lag_asvgf);
  }

  const std::string json_path = (fs::path(s.out_dir) / "metrics.json").string();
  io::write_text(json_path, all_json.dump(2) + "\n");
  const std::string report_path = (fs::path(s.out_dir) / "report.html").string();
  io::write_text(report_path, render_report_html(report));
  fmt::print("\nmetrics: {}\nreport: {}\n", json_path, report_path);
  return report_path;
}

}  // namespace afterimage
