// The C++ API's methods, registries and extrapolation (include/afterimage/afterimage.hpp) over
// run/methods.h, run/post_pipeline.h and run/extrapolate.h.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "api/convert.h"
#include "core/error.h"
#include "core/simd_target.h"
#include "run/extrapolate.h"
#include "run/methods.h"
#include "run/post_pipeline.h"

namespace afterimage {
inline namespace v0 {

const char* version() {
  return AFTERIMAGE_VERSION_STRING;
}

std::string simd_target() {
  return simd_description();
}

namespace {

std::string channel_list(ChannelSet set) {
  std::vector<std::string> names;
  for (const ChannelInfo& r : kChannelTable)
    if (set.contains(r.key)) names.emplace_back(r.name);
  return fmt::format("{}", fmt::join(names, ", "));
}

}  // namespace

struct Method::Impl {
  std::unique_ptr<SequenceMethod> method;
  Exec exec;
  int width = 0, height = 0;  // of this sequence's frames (0: none yet)
  size_t frames = 0;          // since the last reset
};

Method::Method(const std::string& spec, const std::vector<std::string>& settings,
               const ExecOptions& exec)
    : impl_(std::make_unique<Impl>()) {
  impl_->exec = api::to_exec(exec);
  impl_->method = api::make_method_or_chain(spec, settings, impl_->exec);
}
Method::~Method() = default;
Method::Method(Method&&) noexcept = default;
Method& Method::operator=(Method&&) noexcept = default;

std::string Method::name() const {
  return impl_->method->name();
}

std::vector<std::string> Method::required_channels() const {
  std::vector<std::string> names;
  const ChannelSet set = impl_->method->required_channels();
  for (const ChannelInfo& r : kChannelTable)
    if (set.contains(r.key)) names.emplace_back(r.name);
  return names;
}

std::pair<int, int> Method::output_size(int width, int height) const {
  if (width <= 0 || height <= 0)
    throw InputError(fmt::format("{}: input size {}x{} is not positive", name(), width, height));
  return impl_->method->output_size(width, height);
}

void Method::process(const FrameInput& frame, const BufferView& out) {
  Impl& m = *impl_;
  const std::string what = fmt::format("{}: frame {}", m.method->name(), m.frames);
  Frame f = api::to_frame(frame, what);
  const ChannelSet required = m.method->required_channels();
  for (const ChannelInfo& r : kChannelTable)
    if (required.contains(r.key) && !f.has(r.key))
      throw InputError(fmt::format("{}: no {} channel (the method needs {})", what, r.name,
                                   channel_list(required)));
  if (m.width && (f.width != m.width || f.height != m.height))
    throw InputError(
        fmt::format("{}: size {}x{}, the sequence's frames are {}x{} (reset() starts "
                    "a new sequence)",
                    what, f.width, f.height, m.width, m.height));
  const auto [ow, oh] = m.method->output_size(f.width, f.height);
  api::check_view(out, what + ": output", 3, 4, ow, oh);
  if (out.type == DataType::u32)
    throw InputError(fmt::format("{}: output: u32 is not a color type (f32 or f16)", what));
  m.method->check_header(f, {});
  Frame result = m.method->process(f);
  m.width = f.width;
  m.height = f.height;
  ++m.frames;
  api::write_image(result.color, out);
  if (out.channels == 4 && !result.alpha.empty())
    api::write_image(result.alpha, api::channel_view(out, 3));
}

void Method::reset() {
  impl_->method->reset();
  impl_->width = impl_->height = 0;
  impl_->frames = 0;
}

void Method::save_state(const std::string& path) const {
  impl_->method->save_state(path);
}

void Method::load_state(const std::string& path) {
  impl_->method->load_state(path);
}

std::string Method::settings_json() const {
  return impl_->method->settings_json();
}

std::string Method::describe_settings() const {
  return impl_->method->describe_settings();
}

void Method::set_exec(const ExecOptions& exec) {
  impl_->exec = api::to_exec(exec);
  impl_->method->set_exec(impl_->exec);
}

std::vector<std::string> method_names() {
  return registered_method_names();
}

std::vector<std::string> post_stage_names() {
  std::vector<std::string> names;
  for (const PostStageInfo& s : post_stages()) names.push_back(s.name);
  return names;
}

std::vector<std::string> channel_names() {
  std::vector<std::string> names;
  for (const ChannelInfo& r : kChannelTable) names.emplace_back(r.name);
  return names;
}

std::string describe_settings(const std::string& spec) {
  return api::make_method_or_chain(spec, {}, {})->describe_settings();
}

// ---- Extrapolator ------------------------------------------------------------------------

struct Extrapolator::Impl {
  ExtrapolateSettings settings;
  Exec exec;
  Frame source;
};

Extrapolator::Extrapolator(const std::vector<std::string>& settings, const ExecOptions& exec)
    : impl_(std::make_unique<Impl>()) {
  impl_->exec = api::to_exec(exec);
  const std::vector<std::string> fills = reproject::hole_fill_names();
  for (const std::string& s : settings) {
    const size_t eq = s.find('=');
    if (s.substr(0, eq) != "fill" || eq == std::string::npos)
      throw SettingsError(fmt::format("extrapolate: unknown setting '{}' (settings: fill={})", s,
                                      fmt::join(fills, "|")));
    const std::string value = s.substr(eq + 1);
    if (std::find(fills.begin(), fills.end(), value) == fills.end())
      throw SettingsError(
          fmt::format("extrapolate: fill '{}': expected one of {}", value, fmt::join(fills, ", ")));
    impl_->settings.fill.fill = reproject::parse_hole_fill(value);
  }
}
Extrapolator::~Extrapolator() = default;
Extrapolator::Extrapolator(Extrapolator&&) noexcept = default;
Extrapolator& Extrapolator::operator=(Extrapolator&&) noexcept = default;

void Extrapolator::set_source(const FrameInput& rendered) {
  Frame f = api::to_frame(rendered, "extrapolate: source");
  if (!f.has_depth()) throw InputError("extrapolate: source: no depth channel (it moves pixels)");
  if (!f.camera_known)
    throw InputError("extrapolate: source: no camera (FrameCamera::known is false)");
  impl_->source = std::move(f);
}

double Extrapolator::synthesize(const FrameCamera& target, const BufferView& out,
                                int frames_after) {
  const Frame& src = impl_->source;
  if (src.color.empty()) throw InputError("extrapolate: no source frame (call set_source first)");
  if (frames_after < 1)
    throw SettingsError(fmt::format("extrapolate: frames_after {} is below 1", frames_after));
  if (!target.known)
    throw InputError("extrapolate: target: no camera (FrameCamera::known is false)");
  FrameHeader th = src.header_only();
  api::apply_camera(target, th);
  validate_header(th, "extrapolate: target");
  api::check_view(out, "extrapolate: output", 3, 4, src.width, src.height);
  if (out.type == DataType::u32)
    throw InputError("extrapolate: output: u32 is not a color type (f32 or f16)");
  SourceFrame a;
  a.frame = &src;
  a.position = 0;
  a.same_shot = !target.cut;
  SynthesisReport report;
  const ImageF color =
      synthesize_frame(a, nullptr, th, size_t(frames_after), impl_->settings, impl_->exec, &report);
  api::write_image(color, out);
  return report.hole_fraction;
}

}  // namespace v0
}  // namespace afterimage

namespace afterimage::api {

bool is_chain(const std::string& spec) {
  if (spec.find(',') != std::string::npos) return true;
  const std::string head = spec.substr(0, spec.find_first_of(":+"));
  for (const PostStageInfo& s : post_stages())
    if (s.name == head) return true;
  return false;
}

std::unique_ptr<SequenceMethod> make_method_or_chain(const std::string& spec,
                                                     const std::vector<std::string>& settings,
                                                     const Exec& ex, bool display_output) {
  if (spec.empty()) throw SettingsError("method: empty spec (see afterimage::method_names())");
  if (is_chain(spec))
    return make_pipeline_method(parse_pipeline(spec, settings), ex, display_output);
  // A technique alone ("taa") is its default variant, as in `afterimage run --pipeline taa`.
  std::string full = spec;
  for (const MethodFamily& f : method_families())
    if (spec == f.technique) full = spec + ":" + default_variant(spec);
  for (const std::string& s : settings) {
    if (s.find('=') == std::string::npos)
      throw SettingsError(fmt::format("{}: setting '{}' is not key=value", spec, s));
    full += "+" + s;
  }
  return make_method(full, ex);
}

}  // namespace afterimage::api
