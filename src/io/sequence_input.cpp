#include "io/sequence_input.h"

#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"
#include "frame/conventions.h"

namespace afterimage::io {

namespace {

Mat4 matrix_of(const nlohmann::json& a, const std::string& what) {
  const auto v = a.get<std::vector<double>>();
  if (v.size() != 16) throw InputError(fmt::format("{}: a matrix needs 16 numbers", what));
  Mat4 m;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) m.m[i][j] = v[size_t(i * 4 + j)];  // row-major
  return m;
}

}  // namespace

std::vector<CameraRecord> parse_camera_sidecar(const std::string& text, const std::string& what) {
  std::vector<CameraRecord> out;
  try {
    const nlohmann::json j = nlohmann::json::parse(text);
    for (const auto& f : j.at("frames")) {
      CameraRecord r;
      r.frame = f.value("frame", -1);
      const auto jit = f.at("jitter").get<std::vector<double>>();
      if (jit.size() != 2) throw InputError(fmt::format("{}: jitter needs 2 numbers", what));
      r.jitter = {jit[0], jit[1]};
      if (f.contains("view") && f.contains("projection")) {
        r.view = matrix_of(f.at("view"), what);
        r.projection = matrix_of(f.at("projection"), what);
        r.has_camera = true;
      }
      if (f.contains("lens")) {
        const nlohmann::json& l = f.at("lens");
        r.lens.f_number = l.at("f_number").get<double>();
        r.lens.focal_length_mm = l.at("focal_length_mm").get<double>();
        r.lens.focus_distance = l.at("focus_distance").get<double>();
        r.lens.sensor_width_mm = l.value("sensor_width_mm", r.lens.sensor_width_mm);
        r.lens.blades = l.value("blades", 0);
        r.lens.blade_rotation_deg = l.value("blade_rotation_deg", 0.0);
        try {
          validate_lens(r.lens);
        } catch (const SettingsError& e) {
          throw InputError(fmt::format("{}: frame entry {}: {}", what, out.size() + 1, e.what()));
        }
        r.has_lens = true;
      }
      out.push_back(r);
    }
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: bad camera sidecar: {}", what, e.what()));
  }
  return out;
}

std::vector<CameraRecord> read_camera_sidecar(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw InputError(fmt::format("{}: cannot read", path));
  std::stringstream ss;
  ss << f.rdbuf();
  return parse_camera_sidecar(ss.str(), path);
}

SequenceReader::SequenceReader(const SequenceInput& in, const NoteFn& note) : in_(in) {
  files_ = scan_sequence(in.dir, in.name);
  std::string chosen;
  layout_ = resolve_layout(in.layout, in.maps, files_.front().path, &chosen);
  if (note && !chosen.empty()) note(fmt::format("{}: {}", in.dir, chosen));
  // Our own files are recognised quietly (no stderr line); the summary still names the choice.
  const bool automatic = in.layout.empty() || in.layout == "auto";
  layout_choice_ = automatic ? layout_.name() + " (recognised)" : layout_.name();
  if (!in.maps.empty()) layout_choice_ += fmt::format(" with {} --map", in.maps.size());
  // A sidecar beside foreign files is theirs: without it the jitter and a moving camera's
  // background motion (zero in Blender's Vector pass) stay unknown to every temporal method.
  std::string sidecar = in.jitter_file, ignore_hint;
  if (sidecar.empty() && in.jitter.empty() && in.sidecar_beside && !layout_.camera_in_header()) {
    const std::filesystem::path beside = std::filesystem::path(in.dir) / kCameraSidecarName;
    std::error_code ec;
    if (std::filesystem::is_regular_file(beside, ec)) {
      sidecar = beside.string();
      ignore_hint = " (found beside the frames; --jitter none ignores it)";
    }
  }
  if (!sidecar.empty()) {
    try {
      sidecar_ = read_camera_sidecar(sidecar);
    } catch (const InputError& e) {
      throw InputError(e.what() + ignore_hint);
    }
    for (size_t i = 0; i < files_.size(); ++i)
      if (!record(i))
        throw InputError(
            fmt::format("{}: no entry for {}{}", sidecar, files_[i].path, ignore_hint));
    camera_known_ = record(0)->has_camera;
    if (note && !ignore_hint.empty())
      note(fmt::format("{}: {} from {}", in.dir, camera_known_ ? "camera and jitter" : "jitter",
                       kCameraSidecarName));
    jitter_override_ = true;
  } else if (!in.jitter.empty()) {
    // "haltonN[:start]": file i uses sample start + i of the sequence.
    const size_t colon = in.jitter.find(':');
    halton_ = parse_jitter(in.jitter.substr(0, colon));
    if (colon != std::string::npos) {
      try {
        halton_start_ = std::stol(in.jitter.substr(colon + 1));
      } catch (const std::exception&) {
        throw SettingsError(fmt::format("--jitter '{}': start must be a whole number", in.jitter));
      }
    }
    jitter_override_ = true;
  }
  if (layout_.camera_in_header()) camera_known_ = true;
  note_ = note;
}

const CameraRecord* SequenceReader::record(size_t i) const {
  if (sidecar_.empty()) return nullptr;
  if (sidecar_.front().frame < 0) return i < sidecar_.size() ? &sidecar_[i] : nullptr;
  for (const CameraRecord& r : sidecar_)
    if (r.frame == files_[i].number) return &r;
  return nullptr;
}

void SequenceReader::apply_sidecar(size_t i, FrameHeader& h) const {
  if (!layout_.camera_in_header()) h.index = files_[i].number;
  if (const CameraRecord* r = record(i)) {
    h.jitter = r->jitter;
    if (r->has_camera) {
      h.view = r->view;
      h.projection = r->projection;
      h.camera_known = true;
    }
    if (r->has_lens) {
      h.lens = r->lens;
      h.lens_known = true;
    }
  } else if (jitter_override_) {
    h.jitter = halton_.at(halton_start_ + long(i));
  }
}

std::vector<std::string> describe_gaps(const std::vector<SequenceFile>& files,
                                       const std::vector<bool>& gap, std::string_view consequence) {
  std::vector<size_t> at;
  for (size_t i = 1; i < files.size() && i < gap.size(); ++i)
    if (gap[i]) at.push_back(i);
  std::vector<std::string> lines;
  if (at.empty()) return lines;
  // Every frame after the first behind the same step: rendered every Nth frame.
  const int step = files[1].number - files[0].number;
  bool uniform = files.size() >= 3 && at.size() == files.size() - 1;
  for (size_t i = 1; uniform && i < files.size(); ++i)
    uniform = files[i].number - files[i - 1].number == step;
  if (uniform) {
    lines.push_back(fmt::format(
        "{}: the frames are numbered {}, {}, ... {}, one every {}: each one's motion vectors "
        "point one frame back, to a frame that is not there, so at every frame {} (render every "
        "frame for a temporal method)",
        files[0].path, files[0].number, files[1].number, files.back().number, step, consequence));
    return lines;
  }
  const auto missing = [&](size_t i) {
    const int a = files[i - 1].number + 1, b = files[i].number - 1;
    return a == b ? fmt::format("frame {}", a) : fmt::format("frames {}..{}", a, b);
  };
  constexpr size_t kShown = 3;
  for (size_t k = 0; k < at.size() && k < kShown; ++k)
    lines.push_back(fmt::format("{}: {} missing before it; {}", files[at[k]].path, missing(at[k]),
                                consequence));
  if (at.size() > kShown)
    lines.push_back(fmt::format("{}: {} more gap{} after {} (the last before {}); {} at each",
                                files[0].path, at.size() - kShown,
                                at.size() - kShown == 1 ? "" : "s", files[at[kShown - 1]].path,
                                files[at.back()].path, consequence));
  return lines;
}

FrameHeader SequenceReader::check(size_t i, ChannelSet required,
                                  std::string_view required_by) const {
  FrameHeader h = check_frame_header(files_[i].path, required, required_by, layout_);
  apply_sidecar(i, h);
  validate_header(h, files_[i].path);
  return h;
}

SequenceReader::SequenceShape SequenceReader::check_all(
    const std::function<ChannelSet(size_t)>& required_of, std::string_view required_by) const {
  SequenceShape r;
  r.gap.assign(files_.size(), false);
  for (size_t i = 0; i < files_.size(); ++i) {
    const FrameHeader& h = r.headers.emplace_back(check(i, required_of(i), required_by));
    const FrameHeader& first = r.headers.front();
    if (h.width != first.width || h.height != first.height)
      throw InputError(fmt::format("{}: size {}x{} differs from the sequence's {}x{} ({})",
                                   files_[i].path, h.width, h.height, first.width, first.height,
                                   files_[0].path));
    r.gap[i] = i > 0 && files_[i].number != files_[i - 1].number + 1;
  }
  return r;
}

Frame SequenceReader::read(size_t i, ChannelSet required, std::string_view required_by,
                           InputRegistry* inputs, bool refuse_non_finite_color,
                           ChannelSet load) const {
  const std::string& path = files_[i].path;
  // Said once, and only to readers that use motion.
  if (!camera_known_ && note_ && !camera_noted_ && required.contains(Channel::motion)) {
    camera_noted_ = true;
    note_(fmt::format(
        "{}: camera unknown (not in the files, no --jitter-file, no {} beside them): background "
        "motion stays as the files have it",
        in_.dir, kCameraSidecarName));
  }
  ReadPolicy policy;
  policy.refuse_non_finite_color = refuse_non_finite_color;
  policy.warn = note_;
  policy.load = load;
  Frame f = read_frame(path, required, required_by, inputs, layout_, policy);
  apply_sidecar(i, f);
  auto header_of = [&](const CameraRecord& r) {
    FrameHeader h;
    h.width = f.width;
    h.height = f.height;
    h.view = r.view;
    h.projection = r.projection;
    return h;
  };
  for (const ChannelSource& src : layout_.sources()) {
    if (src.convention.empty()) continue;
    if (src.key == Channel::depth)
      convert_depth(f, parse_depth_convention(src.convention), camera_known_, path);
    else if (src.key == Channel::motion && !f.motion.empty())
      convert_motion(f.motion, parse_motion_convention(src.convention));
    else if (src.key == Channel::motion_next && !f.motion_next.empty())
      convert_motion(f.motion_next, parse_motion_convention(src.convention));
  }
  // Foreign renderers (Blender) leave the sky's motion zero; ours is the camera rotation's.
  if (!layout_.camera_in_header() && camera_known_ && !f.depth.empty()) {
    const CameraRecord* prev = i > 0 ? record(i - 1) : nullptr;
    const CameraRecord* next = i + 1 < files_.size() ? record(i + 1) : nullptr;
    if (prev && prev->has_camera && !f.motion.empty())
      fill_background_motion(f, header_of(*prev), f.motion);
    if (next && next->has_camera && !f.motion_next.empty())
      fill_background_motion(f, header_of(*next), f.motion_next);
  }
  validate_frame(f, path);
  return f;
}

}  // namespace afterimage::io
