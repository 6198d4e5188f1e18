#include "eval/evaluate.h"

#include "afterimage/version.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>

#include "core/error.h"
#include "io/io.h"

namespace afterimage {

namespace fs = std::filesystem;

MethodEvaluator::MethodEvaluator(std::string label, const metrics::MetricsSettings& s,
                                 const Exec& ex)
    : label_(std::move(label)),
      ex_(ex),
      eval_(s, ex),
      display_referred_(s.output_display_referred) {}

std::optional<metrics::Mask> MethodEvaluator::disocclusion(const Frame* g) {
  if (!(g && g->has_depth() && g->has_id() && g->has_motion())) return std::nullopt;
  metrics::Mask mask;
  if (!prev_depth_.empty() && prev_depth_.width() == g->width && prev_depth_.height() == g->height)
    mask = metrics::disocclusion_mask(g->depth, g->id, g->motion, prev_depth_, prev_id_, {}, ex_);
  else  // first frame: nothing is disoccluded yet
    mask = metrics::Mask(g->width, g->height, 1, 0);
  prev_depth_ = g->depth;
  prev_id_ = g->id;
  return mask;
}

void MethodEvaluator::add(const ImageF& output, const ImageF& reference, const Frame* g) {
  const std::optional<metrics::Mask> mask = disocclusion(g);
  eval_.add_frame(output, reference, mask ? &*mask : nullptr, mask ? &g->motion : nullptr);
}

void MethodEvaluator::add(const ImageF& output, const metrics::PreparedReference& reference,
                          const Frame* g) {
  const std::optional<metrics::Mask> mask = disocclusion(g);
  eval_.add_frame(output, reference, mask ? &*mask : nullptr, mask ? &g->motion : nullptr);
}

void MethodEvaluator::skip(const Frame* g) {
  const std::optional<metrics::Mask> mask = disocclusion(g);
  eval_.skip_frame(mask ? &*mask : nullptr, mask ? &g->motion : nullptr);
}

MethodEvaluation MethodEvaluator::finish(const ImageF& last_output, const std::string& command,
                                         double ms_per_frame) {
  MethodEvaluation e;
  e.label = label_;
  e.command = command;
  e.ms_per_frame = ms_per_frame;
  e.metrics = eval_.result();
  e.last_output = last_output;
  e.display_referred = display_referred_;
  return e;
}

MethodSummary to_summary(const MethodEvaluation& e) {
  MethodSummary m;
  m.label = e.label;
  m.command = e.command;
  m.ms_per_frame = e.ms_per_frame;
  const auto& s = e.metrics.summary;
  m.aggregate = {{"psnr", s.psnr},
                 {"ssim", s.ssim},
                 {"flip", s.flip},
                 {"temporal_error", s.temporal_error},
                 {"sharpness", s.sharpness}};
  // Ghosting: mean error over the first frames after disocclusion (k = 1..4).
  double g = 0;
  int n = 0;
  for (size_t k = 0; k < s.ghosting.error.size() && k < 4; ++k)
    if (std::isfinite(s.ghosting.error[k])) g += s.ghosting.error[k], ++n;
  m.aggregate["ghosting"] = n ? g / n : std::nan("");
  m.ghosting = s.ghosting.error;
  for (const auto& f : e.metrics.frames) {
    m.per_frame["PSNR (dB)"].push_back(f.psnr);
    m.per_frame["SSIM"].push_back(f.ssim);
    m.per_frame["FLIP"].push_back(f.flip);
    m.per_frame["temporal error"].push_back(f.temporal_error);
  }
  return m;
}

Vec3f magma(float t) {
  // Control points sampled from matplotlib's magma at t = 0, 1/8, ..., 1.
  static const float c[9][3] = {
      {0.001f, 0.000f, 0.016f}, {0.110f, 0.063f, 0.267f}, {0.310f, 0.071f, 0.482f},
      {0.506f, 0.145f, 0.506f}, {0.710f, 0.212f, 0.478f}, {0.898f, 0.314f, 0.392f},
      {0.984f, 0.529f, 0.380f}, {0.996f, 0.761f, 0.529f}, {0.988f, 0.992f, 0.749f}};
  t = std::clamp(std::isfinite(t) ? t : 0.0f, 0.0f, 1.0f) * 8.0f;
  int i = std::min(int(t), 7);
  float f = t - i;
  return {c[i][0] + (c[i + 1][0] - c[i][0]) * f, c[i][1] + (c[i + 1][1] - c[i][1]) * f,
          c[i][2] + (c[i + 1][2] - c[i][2]) * f};
}

namespace {

ImageF crop(const ImageF& img, int x0, int y0, int w, int h) {
  ImageF out(w, h, img.channels());
  for (int c = 0; c < img.channels(); ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) out.at(x, y, c) = img.at_clamped(x0 + x, y0 + y, c);
  return out;
}

ImageF heatmap(const ImageF& error) {
  ImageF out(error.width(), error.height(), 3);
  for (int y = 0; y < error.height(); ++y)
    for (int x = 0; x < error.width(); ++x) {
      Vec3f c = magma(error.at(x, y, 0));
      out.at(x, y, 0) = c.x, out.at(x, y, 1) = c.y, out.at(x, y, 2) = c.z;
    }
  return out;
}

// Top-left corners of `count` non-overlapping w x h windows with the largest summed error.
std::vector<std::pair<int, int>> worst_windows(const ImageF& err, int w, int h, int count) {
  const int W = err.width(), H = err.height();
  // Summed-area table for O(1) window sums.
  std::vector<double> sat(size_t(W + 1) * (H + 1), 0.0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      sat[size_t(y + 1) * (W + 1) + x + 1] = err.at(x, y, 0) + sat[size_t(y) * (W + 1) + x + 1] +
                                             sat[size_t(y + 1) * (W + 1) + x] -
                                             sat[size_t(y) * (W + 1) + x];
  auto sum = [&](int x, int y) {
    return sat[size_t(y + h) * (W + 1) + x + w] - sat[size_t(y) * (W + 1) + x + w] -
           sat[size_t(y + h) * (W + 1) + x] + sat[size_t(y) * (W + 1) + x];
  };
  std::vector<std::pair<int, int>> picked;
  const int step = std::max(1, std::min(w, h) / 4);
  for (int k = 0; k < count; ++k) {
    double best = -1;
    std::pair<int, int> at{-1, -1};
    for (int y = 0; y + h <= H; y += step)
      for (int x = 0; x + w <= W; x += step) {
        bool overlaps = false;
        for (auto [px, py] : picked)
          if (std::abs(px - x) < w && std::abs(py - y) < h) overlaps = true;
        double s = sum(x, y);
        if (!overlaps && s > best) best = s, at = {x, y};
      }
    if (at.first < 0) break;
    picked.push_back(at);
  }
  return picked;
}

}  // namespace

std::vector<Figure> make_figures(const std::vector<MethodEvaluation>& methods,
                                 const ImageF& last_reference,
                                 const metrics::DisplaySettings& display, int regions,
                                 const Exec& ex) {
  std::vector<Figure> figs;
  if (methods.empty() || last_reference.empty()) return figs;
  const ImageF ref_tm = metrics::to_tonemapped_linear(last_reference, display, ex);
  const ImageF ref_disp = metrics::to_display(last_reference, display, ex);
  ImageF total(last_reference.width(), last_reference.height(), 1);
  std::vector<ImageF> maps, displays;
  for (const auto& m : methods) {
    if (m.last_output.empty()) {
      maps.emplace_back();
      displays.emplace_back();
      continue;
    }
    metrics::DisplaySettings out_display = display;
    if (m.display_referred) out_display.tonemap = false;  // already tonemapped
    displays.push_back(metrics::to_display(m.last_output, out_display, ex));
    ImageF tm = metrics::to_tonemapped_linear(m.last_output, out_display, ex);
    metrics::FlipResult f = metrics::ldr_flip(ref_tm, tm, metrics::flip_default_ppd(), ex);
    for (size_t i = 0; i < total.data().size(); ++i) total.data()[i] += f.error.data()[i];
    maps.push_back(std::move(f.error));
  }
  const int cw = std::max(16, std::min(last_reference.width(), last_reference.height()) / 4);
  const auto windows = worst_windows(total, cw, cw, regions);
  int k = 0;
  for (auto [x0, y0] : windows) {
    Figure f;
    f.title =
        fmt::format("Worst region {} (last frame, {}x{} at x={}, y={}; summed FLIP of all methods)",
                    ++k, cw, cw, x0, y0);
    f.panels.push_back({"reference", crop(ref_disp, x0, y0, cw, cw)});
    for (size_t i = 0; i < methods.size(); ++i)
      if (!displays[i].empty())
        f.panels.push_back({methods[i].label, crop(displays[i], x0, y0, cw, cw)});
    figs.push_back(std::move(f));
  }
  Figure emap;
  emap.title = "LDR-FLIP error maps of the last frame (magma: black = 0, yellow = 1)";
  for (size_t i = 0; i < methods.size(); ++i)
    if (!maps[i].empty()) emap.panels.push_back({methods[i].label, heatmap(maps[i])});
  figs.push_back(std::move(emap));
  return figs;
}

EvalResult run_eval(const EvalOptions& o, const Exec& ex) {
  if (o.outputs.empty()) throw SettingsError("eval: give at least one --out DIR");
  if (!o.labels.empty() && o.labels.size() != o.outputs.size())
    throw SettingsError(fmt::format("eval: {} --label for {} --out; give one per output or none",
                                    o.labels.size(), o.outputs.size()));
  o.metrics.validate();
  if (o.gbuffer.empty() && !(o.jitter.empty() && o.jitter_file.empty()))
    throw SettingsError(
        "eval: --jitter / --jitter-file describe the --gbuffer frames; give --gbuffer DIR too");
  auto input = [&](const std::string& dir, bool outputs) {
    io::SequenceInput in;
    in.dir = dir;
    in.sidecar_beside = false;  // the --gbuffer frames' only (below)
    if (!outputs) {
      in.layout = o.layout;
      in.maps = o.maps;
    }
    return in;
  };
  auto paths = [](const io::SequenceReader& r) {
    std::vector<std::string> v;
    for (const auto& f : r.files()) v.push_back(f.path);
    return v;
  };
  const io::SequenceReader ref_reader(input(o.reference, false), o.note);
  const auto ref_files = paths(ref_reader);
  const size_t frames = ref_files.size();
  auto same_length = [&](const std::vector<std::string>& files, const std::string& dir) {
    if (files.size() != frames)
      throw InputError(fmt::format("{}: {} frames, but the reference {} has {}", dir, files.size(),
                                   o.reference, frames));
  };
  // An output directory holds linear EXR frames (read through a SequenceReader) or display
  // images (PNG / JPEG, scored as display-referred).
  std::vector<std::vector<std::string>> out_files;
  std::vector<std::optional<io::SequenceReader>> out_readers;
  std::vector<MethodEvaluator> evals;
  for (size_t m = 0; m < o.outputs.size(); ++m) {
    metrics::MetricsSettings ms = o.metrics;
    if (io::sequence_kind(o.outputs[m]) == io::SequenceKind::display) {
      out_readers.emplace_back();
      std::vector<std::string> files;
      for (auto& f : io::scan_sequence(o.outputs[m], "", io::SequenceKind::display))
        files.push_back(std::move(f.path));
      out_files.push_back(std::move(files));
      ms.output_display_referred = true;
      if (o.note)
        o.note(
            fmt::format("{}: display images (8-bit sRGB), scored as encoded with the metrics' "
                        "tonemap (Reinhard at exposure {:g}, resolve --out-format png's "
                        "default); linear PSNR is not measured",
                        o.outputs[m], o.metrics.display.exposure));
    } else {
      out_readers.emplace_back(std::in_place, input(o.outputs[m], true), o.note);
      out_files.push_back(paths(*out_readers.back()));
    }
    same_length(out_files.back(), o.outputs[m]);
    std::string label = m < o.labels.size()
                            ? o.labels[m]
                            : fs::path(o.outputs[m]).lexically_normal().filename().string();
    evals.emplace_back(label.empty() ? o.outputs[m] : label, ms, ex);
  }
  std::vector<std::string> g_files;
  std::optional<io::SequenceReader> g_reader;
  if (!o.gbuffer.empty()) {
    io::SequenceInput gi = input(o.gbuffer, false);
    gi.jitter = o.jitter;
    gi.jitter_file = o.jitter_file;
    gi.sidecar_beside = true;
    g_reader.emplace(gi, o.note);
    g_files = paths(*g_reader);
    same_length(g_files, o.gbuffer);
  }
  if (o.every < 1 || o.every_offset < 0 || o.every_offset >= o.every)
    throw SettingsError(fmt::format("eval: --every {}:{}: need N >= 1 and 0 <= OFFSET < N", o.every,
                                    o.every_offset));
  const size_t scored = frames > size_t(o.every_offset)
                            ? (frames - size_t(o.every_offset) + o.every - 1) / o.every
                            : 0;
  if (size_t(o.metrics.warmup) >= scored)
    throw SettingsError(fmt::format(
        "eval: --warmup {} leaves no frame to score ({} has {} frames, {} of them selected); "
        "pass a smaller --warmup",
        o.metrics.warmup, o.reference, frames, scored));
  // The json / report must never replace a file this evaluation reads: checked before the
  // (long) evaluation, and again by the writers.
  io::InputRegistry inputs;
  for (const auto& p : ref_files) inputs.add(p);
  for (const auto& p : g_files) inputs.add(p);
  for (const auto& list : out_files)
    for (const auto& p : list) inputs.add(p);
  for (const std::string* p : {&o.json_path, &o.report_path})
    if (!p->empty()) inputs.check_writable(*p);

  // Frame-major: each reference (and G-buffer) frame is read once for all methods.
  EvalResult result;
  result.reference_layout = ref_reader.layout_choice();
  std::vector<ImageF> last_outputs(o.outputs.size());
  int w = 0, h = 0;
  size_t last_scored = 0;
  for (size_t t = 0; t < frames; ++t)
    if (t % size_t(o.every) == size_t(o.every_offset)) last_scored = t;
  for (size_t t = size_t(o.every_offset); t < frames; t += size_t(o.every)) {
    // Scores of non-finite pixels are meaningless: refused (metrics::require_finite's rule).
    Frame ref = ref_reader.read(t, {Channel::color}, "eval", nullptr, true);
    if (w == 0) w = ref.width, h = ref.height;
    io::check_same_size(ref, w, h, ref_files[t]);
    Frame g;
    if (!g_files.empty()) {
      g = g_reader->read(t, {Channel::depth, Channel::id, Channel::motion}, "eval --gbuffer");
      io::check_same_size(g, w, h, g_files[t]);
    }
    // Prepared once for every output (the outputs' settings differ only on the output side).
    const metrics::PreparedReference prepared =
        metrics::prepare_reference(ref.color, o.metrics, ex);
    for (size_t m = 0; m < evals.size(); ++m) {
      Frame out;
      if (out_readers[m]) {
        out = out_readers[m]->read(t, {Channel::color}, "eval", nullptr, true);
      } else {
        out.color = io::read_rgb(out_files[m][t], /*decode_srgb=*/true);
        out.width = out.color.width();
        out.height = out.color.height();
      }
      io::check_same_size(out, w, h, out_files[m][t]);
      // Disocclusion masks: --gbuffer, else the output's own G-buffer (resolve
      // --keep-gbuffer, a raw input), else the reference's (our renderer stores the pixel
      // centers' depth, id and motion with every reference frame).
      const Frame* gb = &g;
      if (g_files.empty()) {
        auto has_g = [](const Frame& f) { return f.has_depth() && f.has_id() && f.has_motion(); };
        gb = has_g(out) ? &out : has_g(ref) ? &ref : nullptr;
        if (t == size_t(o.every_offset) && o.note && gb != &out)
          o.note(fmt::format("{}: no depth/id/motion in the output frames; ghosting {}",
                             o.outputs[m],
                             gb ? "uses the reference frames' G-buffer (choose one with --gbuffer)"
                                : "is not measured (give --gbuffer DIR)"));
      }
      evals[m].add(out.color, prepared, gb);
      if (t == last_scored) last_outputs[m] = std::move(out.color);
    }
    if (t == last_scored) result.last_reference = std::move(ref.color);
  }
  for (size_t m = 0; m < evals.size(); ++m)
    result.methods.push_back(evals[m].finish(last_outputs[m], o.command_line));
  if (!o.json_path.empty())
    io::write_text(o.json_path, eval_to_json(result.methods, o.metrics).dump(2) + "\n", &inputs);
  if (!o.report_path.empty()) {
    ReportData rd;
    rd.title = "Afterimage evaluation";
    rd.commands.push_back(o.command_line);
    SceneSection sc;
    sc.name = o.reference;
    for (const auto& m : result.methods) sc.methods.push_back(to_summary(m));
    sc.figures = make_figures(result.methods, result.last_reference, o.metrics.display, 2, ex);
    rd.scenes.push_back(std::move(sc));
    io::write_text(o.report_path, render_report_html(rd), &inputs);
  }
  return result;
}

nlohmann::json eval_to_json(const std::vector<MethodEvaluation>& methods,
                            const metrics::MetricsSettings& s) {
  nlohmann::json j;
  j["afterimage_version"] = AFTERIMAGE_VERSION_STRING;
  j["warmup"] = s.warmup;
  j["tonemap"] = "per-channel Reinhard x/(1+x) at exposure " + std::to_string(s.display.exposure) +
                 ", then sRGB encoding";
  j["methods"] = nlohmann::json::array();
  for (const auto& m : methods) {
    nlohmann::json mj;
    mj["label"] = m.label;
    if (!m.command.empty()) mj["command"] = m.command;
    if (m.ms_per_frame >= 0) mj["ms_per_frame"] = m.ms_per_frame;
    mj["summary"] = m.metrics.summary;
    mj["frames"] = m.metrics.frames;
    j["methods"].push_back(mj);
  }
  return j;
}

std::string format_eval_table(const std::vector<MethodEvaluation>& methods) {
  size_t lw = 6;
  for (const auto& m : methods) lw = std::max(lw, m.label.size());
  std::string s =
      fmt::format("{:<{}}  {:>8}  {:>7}  {:>7}  {:>9}  {:>8}  {:>9}  {:>9}\n", "method", lw, "PSNR",
                  "SSIM", "FLIP", "temporal", "ghosting", "sharpness", "ms/frame");
  for (const auto& e : methods) {
    MethodSummary m = to_summary(e);
    auto v = [&](const char* k) { return m.aggregate.count(k) ? m.aggregate.at(k) : std::nan(""); };
    s += fmt::format("{:<{}}  {:>8.3f}  {:>7.4f}  {:>7.4f}  {:>9.5f}  {:>8.4f}  {:>9.3f}  {:>9}\n",
                     m.label, lw, v("psnr"), v("ssim"), v("flip"), v("temporal_error"),
                     v("ghosting"), v("sharpness"),
                     m.ms_per_frame >= 0 ? fmt::format("{:.2f}", m.ms_per_frame) : "-");
  }
  return s;
}

}  // namespace afterimage
