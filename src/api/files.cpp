// The C++ API's files (include/afterimage/afterimage.hpp): frames read through layouts and
// conventions (io/sequence_input.h), EXR writing, and the files-to-files runs of the CLI's
// resolve / denoise / run, extrapolate and eval (run/sequence.h, run/extrapolate.h,
// eval/evaluate.h).
#include <fmt/format.h>

#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "api/convert.h"
#include "core/error.h"
#include "eval/evaluate.h"
#include "io/io.h"
#include "io/sequence_input.h"
#include "run/extrapolate.h"
#include "run/methods.h"
#include "run/post_pipeline.h"
#include "run/sequence.h"

namespace afterimage {
inline namespace v0 {

namespace {

io::SequenceInput sequence_input(const std::string& dir, const SequenceOptions& o) {
  io::SequenceInput in;
  in.dir = dir;
  in.name = o.name;
  in.layout = o.layout;
  in.maps = o.maps;
  in.jitter = o.jitter;
  in.jitter_file = o.jitter_file;
  return in;
}

}  // namespace

// ---- FrameData ---------------------------------------------------------------------------

struct FrameData::Impl {
  Frame frame;
  FrameCamera camera;
};

FrameData::FrameData() : impl_(std::make_unique<Impl>()) {}
FrameData::~FrameData() = default;
FrameData::FrameData(FrameData&&) noexcept = default;
FrameData& FrameData::operator=(FrameData&&) noexcept = default;

int FrameData::width() const {
  return impl_->frame.width;
}
int FrameData::height() const {
  return impl_->frame.height;
}

std::vector<std::string> FrameData::channels() const {
  std::vector<std::string> names;
  for (const ChannelInfo& r : kChannelTable)
    if (impl_->frame.has(r.key)) names.emplace_back(r.name);
  return names;
}

bool FrameData::has(const std::string& channel) const {
  const ChannelInfo* r = find_channel(channel);
  return r && impl_->frame.has(r->key);
}

BufferView FrameData::channel(const std::string& channel) const {
  const ChannelInfo* r = find_channel(channel);
  if (!r) throw SettingsError(fmt::format("FrameData: unknown channel '{}'", channel));
  Frame& f = impl_->frame;
  if (!f.has(r->key)) return {};
  if (r->type == PixelType::U32)
    return BufferView::planar(f.plane_set_u32(r->key)->data().data(), f.width, f.height, 1,
                              DataType::u32);
  return BufferView::planar(f.plane_set(r->key)->data().data(), f.width, f.height, r->planes);
}

const FrameCamera& FrameData::camera() const {
  return impl_->camera;
}

FrameInput FrameData::input() const {
  FrameInput in;
  in.camera = impl_->camera;
  for (const ChannelInfo& r : kChannelTable) {
    if (!impl_->frame.has(r.key)) continue;
    const BufferView v = channel(r.name);
    switch (r.key) {
      case Channel::color:
        in.color = v;
        break;
      case Channel::depth:
        in.depth = v;
        break;
      case Channel::normal:
        in.normal = v;
        break;
      case Channel::albedo:
        in.albedo = v;
        break;
      case Channel::motion:
        in.motion = v;
        break;
      case Channel::id:
        in.id = v;
        break;
      case Channel::alpha:
        in.alpha = v;
        break;
      default:
        in.extra.emplace_back(r.name, v);
    }
  }
  return in;
}

// ---- FrameReader -------------------------------------------------------------------------

struct FrameReader::Impl {
  std::unique_ptr<io::SequenceReader> reader;
};

FrameReader::FrameReader(const std::string& dir, const SequenceOptions& options, const NoteFn& note)
    : impl_(std::make_unique<Impl>()) {
  impl_->reader = std::make_unique<io::SequenceReader>(sequence_input(dir, options), note);
}
FrameReader::~FrameReader() = default;
FrameReader::FrameReader(FrameReader&&) noexcept = default;
FrameReader& FrameReader::operator=(FrameReader&&) noexcept = default;

size_t FrameReader::size() const {
  return impl_->reader->size();
}

std::string FrameReader::path(size_t i) const {
  if (i >= size())
    throw InputError(fmt::format("FrameReader: frame {} of a sequence of {}", i, size()));
  return impl_->reader->files()[i].path;
}

std::string FrameReader::layout() const {
  return impl_->reader->layout_choice();
}

FrameData FrameReader::read(size_t i, const std::vector<std::string>& channels) const {
  ChannelSet load;
  for (const std::string& c : channels) {
    const ChannelInfo* r = find_channel(c);
    if (!r) throw SettingsError(fmt::format("FrameReader: unknown channel '{}'", c));
    load.insert(r->key);
  }
  if (!channels.empty()) load.insert(Channel::color);
  FrameData d;
  d.impl_->frame =
      impl_->reader->read(i, ChannelSet{Channel::color}, "FrameReader", nullptr, false, load);
  d.impl_->camera = api::camera_of(d.impl_->frame);
  return d;
}

// ---- Writing and files-to-files runs -----------------------------------------------------

void write_exr(const std::string& path, const BufferView& color, const FrameCamera& camera) {
  api::check_view(color, path + ": color", 3, 4);
  Frame f;
  f.width = color.width;
  f.height = color.height;
  api::apply_camera(camera, f);
  validate_header(f, path);
  f.color = api::to_image(color, 3);
  if (color.channels == 4) f.alpha = api::to_image(api::channel_view(color, 3), 1);
  io::write_frame(path, f);
}

RunSummary run_files(const std::string& spec, const std::vector<std::string>& settings,
                     const std::string& in_dir, const std::string& out_dir,
                     const RunOptions& options, const ProgressFn& progress, const NoteFn& note) {
  if (in_dir.empty()) throw SettingsError("run_files: no input folder");
  if (out_dir.empty()) throw SettingsError("run_files: no output folder");
  const Exec ex = api::to_exec(options.exec);
  SequenceFiles files;
  files.in = sequence_input(in_dir, options.input);
  files.out_dir = out_dir;
  files.out_name = options.out_name;
  files.out.format = parse_output_format(options.format);
  files.out.keep_gbuffer = options.keep_gbuffer;
  files.out.exr.compression = options.compression;
  files.out.exr.half_color = options.half;
  files.out.exposure = options.exposure;
  files.out.tonemap = parse_tonemap(options.tonemap);
  const bool display = files.out.format != OutputFormat::exr;
  // As `afterimage run`: after a tonemap stage the 8-bit writer only clamps and encodes.
  if (display && api::is_chain(spec))
    files.out.tonemap = display_transform(parse_pipeline(spec, settings));
  std::unique_ptr<SequenceMethod> method = api::make_method_or_chain(spec, settings, ex, display);
  files.out.validate();
  if (!options.load_state.empty()) method->load_state(options.load_state);
  // The state is replaced after the run; it must not be an input frame.
  if (!options.save_state.empty()) files.other_outputs.push_back(options.save_state);
  const SequenceRunStats st = run_sequence(*method, files, progress, note);
  if (!options.save_state.empty()) method->save_state(options.save_state);
  RunSummary s;
  s.frames = st.frames;
  s.seconds = st.seconds;
  s.process_seconds = st.process_seconds;
  s.layout = st.layout;
  return s;
}

ExtrapolateSummary extrapolate_files(const std::string& in_dir, const std::string& out_dir,
                                     const ExtrapolateOptions& options, const ProgressFn& progress,
                                     const NoteFn& note) {
  if (in_dir.empty()) throw SettingsError("extrapolate_files: no input folder");
  if (out_dir.empty()) throw SettingsError("extrapolate_files: no output folder");
  ExtrapolateFiles files;
  files.in = sequence_input(in_dir, options.input);
  files.out_dir = out_dir;
  files.out_name = options.out_name;
  files.exr.compression = options.compression;
  ExtrapolateSettings s;
  s.skip = options.skip;
  s.interpolate = options.interpolate;
  s.fill.fill = reproject::parse_hole_fill(options.fill);
  s.validate();
  ExtrapolateProgressFn each;
  if (progress)
    each = [&](size_t k, size_t total, const std::string& path, const SynthesisReport*) {
      progress(k + 1, total, path);
    };
  const ExtrapolateRunStats st =
      afterimage::extrapolate_files(files, s, api::to_exec(options.exec), each, note);
  ExtrapolateSummary r;
  r.frames = st.frames;
  r.synthesized = st.synthesized;
  r.mean_hole_fraction = st.mean_hole_fraction;
  r.max_hole_fraction = st.max_hole_fraction;
  r.seconds = st.seconds;
  return r;
}

std::vector<SequenceScores> evaluate(const std::vector<std::string>& output_dirs,
                                     const std::string& reference_dir,
                                     const EvaluateOptions& options, const NoteFn& note) {
  EvalOptions o;
  o.outputs = output_dirs;
  o.labels = options.labels;
  o.reference = reference_dir;
  o.gbuffer = options.gbuffer;
  o.layout = options.reference_input.layout;
  o.maps = options.reference_input.maps;
  o.jitter = options.reference_input.jitter;
  o.jitter_file = options.reference_input.jitter_file;
  o.note = note;
  o.metrics.warmup = options.warmup;
  o.every = options.every;
  o.every_offset = options.every_offset;
  o.json_path = options.json_path;
  o.report_path = options.report_path;
  o.command_line = "afterimage::evaluate";
  const EvalResult result = run_eval(o, api::to_exec(options.exec));
  std::vector<SequenceScores> scores;
  for (const MethodEvaluation& m : result.methods) {
    const metrics::SequenceSummary& s = m.metrics.summary;
    SequenceScores r;
    r.label = m.label;
    r.frames = s.frames;
    r.frames_measured = s.frames_measured;
    r.psnr = s.psnr;
    r.psnr_linear = s.psnr_linear;
    r.ssim = s.ssim;
    r.flip = s.flip;
    r.temporal_error = s.temporal_error;
    scores.push_back(std::move(r));
  }
  return scores;
}

}  // namespace v0
}  // namespace afterimage
