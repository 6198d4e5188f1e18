#include "run/extrapolate.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <optional>
#include <utility>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/sanitize.h"
#include "run/alpha.h"

namespace afterimage {

namespace fs = std::filesystem;
using reproject::DisplacementKind;

void ExtrapolateSettings::validate() const {
  if (skip < 1)
    throw SettingsError(fmt::format(
        "--skip {}: must be >= 1 (the number of synthesised frames after each rendered one)",
        skip));
}

bool is_rendered_frame(size_t k, int skip) {
  return k % size_t(skip + 1) == 0;
}

size_t previous_rendered_frame(size_t k, int skip) {
  return k - k % size_t(skip + 1);
}

std::string SynthesisReport::describe() const {
  std::string from;
  if (used_a) from = fmt::format("{} ({})", a, reproject::displacement_kind_name(kind_a));
  if (b)
    from += fmt::format("{}{} ({})", from.empty() ? "" : " + ", *b,
                        reproject::displacement_kind_name(kind_b));
  return fmt::format("{} from {}, holes {:.2f}%", b ? "interpolated" : "extrapolated", from,
                     100.0 * hole_fraction);
}

DisplacementKind choose_displacement(const SourceFrame& s, size_t target_position) {
  if (s.same_shot && target_position == s.position + 1 && s.frame->has(Channel::motion_next))
    return DisplacementKind::motion_next;
  if (s.same_shot && s.position == target_position + 1 && s.frame->has(Channel::motion) &&
      !s.frame->camera_cut)
    return DisplacementKind::motion;
  return DisplacementKind::camera;
}

ImageF synthesize_frame(const SourceFrame& a, const SourceFrame* b, const FrameHeader& target,
                        size_t target_position, const ExtrapolateSettings& settings, const Exec& ex,
                        SynthesisReport* report, reproject::ForwardSplat* splat) {
  const bool use_b = settings.interpolate && b && b->frame && b->same_shot;
  // A source in another shot is dropped when the other one is in the target's shot.
  const bool use_a = a.same_shot || !use_b;
  reproject::ForwardSplat s = reproject::ForwardSplat::empty(target.width, target.height);
  SynthesisReport r;
  r.a = a.position;
  r.used_a = use_a;
  // a first: among equal target depths (the sky), the earlier frame's sample is kept.
  if (use_a) {
    r.kind_a = choose_displacement(a, target_position);
    const auto field = reproject::displacement_field(*a.frame, target, r.kind_a, ex);
    reproject::splat_frame(*a.frame, field, target.jitter, s);
  }
  if (use_b) {
    r.b = b->position;
    r.kind_b = choose_displacement(*b, target_position);
    const auto field = reproject::displacement_field(*b->frame, target, r.kind_b, ex);
    reproject::splat_frame(*b->frame, field, target.jitter, s);
  }
  r.hole_fraction = s.hole_fraction();
  ImageF out = reproject::fill_holes(s, settings.fill, ex);
  if (report) *report = r;
  if (splat) *splat = std::move(s);
  return out;
}

namespace {

// No camera cut in (min(i, j), max(i, j)]: frames i and j belong to one shot.
bool same_shot(const std::vector<bool>& cut, size_t i, size_t j) {
  for (size_t m = std::min(i, j) + 1; m <= std::max(i, j); ++m)
    if (cut[m]) return false;
  return true;
}

// Non-finite or negative source color must not be splatted into an output (issue 9).
void sanitize_source_color(Frame& f, const Exec& ex) {
  ImageF clean, invalid;
  if (sanitize_color(f.color, clean, invalid, ex)) f.color = std::move(clean);
}

// The coverage alpha of a synthesised frame (run/alpha.h): the same splat and fill fed
// the sources' alpha as their color (a source without alpha is opaque), so the alpha lands where
// its color does; empty where neither source has alpha, 1 where both are opaque.
ImageF synthesize_alpha(const SourceFrame& a, const SourceFrame* b, const FrameHeader& target,
                        size_t target_position, const ExtrapolateSettings& settings,
                        const Exec& ex) {
  const auto has = [](const SourceFrame* s) { return s && s->frame->has(Channel::alpha); };
  if (!has(&a) && !has(b)) return {};
  const auto opaque = [&](const SourceFrame* s) {
    return !s || !has(s) || fully_opaque(s->frame->alpha, ex);
  };
  if (opaque(&a) && opaque(b)) return ImageF(target.width, target.height, 1, 1.0f);
  const auto alpha_source = [&](const SourceFrame& s, Frame& f) {
    f = alpha_frame(*s.frame, {Channel::depth, Channel::motion, Channel::motion_next}, ex);
    SourceFrame r = s;
    r.frame = &f;
    return r;
  };
  Frame fa, fb;
  const SourceFrame sa = alpha_source(a, fa);
  std::optional<SourceFrame> sb;
  if (b) sb = alpha_source(*b, fb);
  return alpha_of_color(
      synthesize_frame(sa, sb ? &*sb : nullptr, target, target_position, settings, ex), ex);
}

}  // namespace

ExtrapolationResult extrapolate_sequence(const std::vector<Frame>& frames,
                                         const ExtrapolateSettings& settings, const Exec& ex) {
  settings.validate();
  const size_t n = frames.size();
  ExtrapolationResult res;
  if (n == 0) return res;
  std::vector<bool> cut(n, false);
  std::vector<Frame> clean(n);  // sanitised copies of rendered frames that need it
  for (size_t k = 0; k < n; ++k) {
    const Frame& f = frames[k];
    const std::string what = fmt::format("frame {}", k);
    validate_header(f, what);
    if (f.width != frames[0].width || f.height != frames[0].height)
      throw InputError(fmt::format("{}: size {}x{} differs from frame 0's {}x{}", what, f.width,
                                   f.height, frames[0].width, frames[0].height));
    cut[k] = f.camera_cut;
    if (!is_rendered_frame(k, settings.skip)) continue;
    validate_frame(f, what);
    if (!f.has_depth())
      throw InputError(fmt::format("{}: no depth (extrapolation splats through depth)", what));
    if (needs_sanitize(f.color, ex)) {
      clean[k] = f;
      sanitize_source_color(clean[k], ex);
    }
  }
  auto source = [&](size_t i, size_t k) {
    return SourceFrame{clean[i].width ? &clean[i] : &frames[i], i, same_shot(cut, i, k)};
  };
  res.color.resize(n);
  res.synthesized.assign(n, false);
  res.reports.resize(n);
  for (size_t k = 0; k < n; ++k) {
    if (is_rendered_frame(k, settings.skip)) {
      res.color[k] = source(k, k).frame->color;
      continue;
    }
    const size_t a = previous_rendered_frame(k, settings.skip), b = a + size_t(settings.skip) + 1;
    const SourceFrame sa = source(a, k);
    std::optional<SourceFrame> sb;
    if (b < n) sb = source(b, k);
    res.color[k] =
        synthesize_frame(sa, sb ? &*sb : nullptr, frames[k], k, settings, ex, &res.reports[k]);
    res.synthesized[k] = true;
  }
  return res;
}

ExtrapolateRunStats extrapolate_files(const ExtrapolateFiles& io_files,
                                      const ExtrapolateSettings& settings, const Exec& ex,
                                      const ExtrapolateProgressFn& progress, const WarnFn& note) {
  const auto t0 = std::chrono::steady_clock::now();
  settings.validate();
  const io::SequenceReader reader(io_files.in, note);
  const std::vector<io::SequenceFile>& files = reader.files();
  const size_t n = files.size();
  const char* who = "extrapolate";
  const ChannelSet source_channels{Channel::color, Channel::depth};
  const ChannelSet source_load{Channel::color, Channel::depth, Channel::motion,
                               Channel::motion_next, Channel::alpha};

  // Everything is checked before the first byte is written (issue 9).
  if (!reader.camera_known())
    throw InputError(
        fmt::format("{}: the frames carry no camera (view and projection), nor does a "
                    "--jitter-file or a {} beside them: extrapolation reprojects through each "
                    "frame's camera",
                    files[0].path, io::kCameraSidecarName));
  io::InputRegistry inputs;
  for (const auto& f : files) inputs.add(f.path);
  std::vector<std::string> out_paths;
  for (const auto& f : files) {
    const std::string name = io::sequence_output_name(f, io_files.out_name, ".exr");
    out_paths.push_back((fs::path(io_files.out_dir) / name).string());
    inputs.check_writable(out_paths.back());
  }
  io::check_exr_compression(io_files.exr.compression);
  const auto checked = reader.check_all(
      [&](size_t i) {
        return is_rendered_frame(i, settings.skip) ? source_channels : ChannelSet{Channel::color};
      },
      who);
  // Motion refers to a frame that is not there: a gap is treated as a camera cut.
  const std::vector<bool>& gap = checked.gap;
  if (note)
    for (const std::string& line : io::describe_gaps(files, gap, "it is treated as a camera cut"))
      note(line);
  create_output_directory(io_files.out_dir);
  if (const int removed = remove_stale_temporaries(io_files.out_dir); removed > 0 && note)
    note(fmt::format("warning: {}: removed {} temporary file(s) left by an interrupted run",
                     io_files.out_dir, removed));

  auto read_source = [&](size_t i) {
    Frame f = reader.read(i, source_channels, who, nullptr, false, source_load);
    if (gap[i]) f.camera_cut = true;
    sanitize_source_color(f, ex);
    return f;
  };
  auto write = [&](size_t k, const FrameHeader& h, ImageF color, ImageF alpha,
                   const SynthesisReport* r) {
    Frame out;
    static_cast<FrameHeader&>(out) = h;
    out.color = std::move(color);
    out.alpha = std::move(alpha);
    io::write_frame(out_paths[k], out, &inputs, io_files.exr);
    if (progress) progress(k, n, out_paths[k], r);
  };

  ExtrapolateRunStats st;
  st.layout = reader.layout_choice();
  std::vector<bool> cut(n, false);
  Frame a = read_source(0);
  cut[0] = a.camera_cut;
  write(0, a, a.color, a.alpha, nullptr);
  const size_t group = size_t(settings.skip) + 1;
  for (size_t ia = 0; ia + 1 < n; ia += group) {
    const size_t ib = ia + group;
    // Headers of the frames to synthesise (their pixels are never used).
    std::vector<FrameHeader> targets;
    for (size_t k = ia + 1; k < std::min(ib, n); ++k) {
      Frame h = reader.read(k, {Channel::color}, who, nullptr, false, {Channel::color});
      if (gap[k]) h.camera_cut = true;
      cut[k] = h.camera_cut;
      targets.push_back(static_cast<const FrameHeader&>(h));
    }
    std::optional<Frame> b;
    if (ib < n) {
      b = read_source(ib);
      cut[ib] = b->camera_cut;
    }
    for (size_t k = ia + 1; k < std::min(ib, n); ++k) {
      const SourceFrame sa{&a, ia, same_shot(cut, ia, k)};
      std::optional<SourceFrame> sb;
      if (b) sb = SourceFrame{&*b, ib, same_shot(cut, ib, k)};
      SynthesisReport r;
      ImageF color =
          synthesize_frame(sa, sb ? &*sb : nullptr, targets[k - ia - 1], k, settings, ex, &r);
      ++st.synthesized;
      st.mean_hole_fraction += r.hole_fraction;
      st.max_hole_fraction = std::max(st.max_hole_fraction, r.hole_fraction);
      write(k, targets[k - ia - 1], std::move(color),
            synthesize_alpha(sa, sb ? &*sb : nullptr, targets[k - ia - 1], k, settings, ex), &r);
    }
    if (!b) break;
    write(ib, *b, b->color, b->alpha, nullptr);
    a = std::move(*b);
  }
  st.frames = n;
  if (st.synthesized) st.mean_hole_fraction /= double(st.synthesized);
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace afterimage
