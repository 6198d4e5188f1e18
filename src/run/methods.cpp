#include "run/methods.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "post/sharpen.h"
#include "run/alpha.h"
#include "svgf/denoiser.h"
#include "svgf/settings.h"
#include "taa/presets.h"
#include "taa/taa_method.h"
#include "taau/settings.h"
#include "taau/taau_method.h"

namespace afterimage {

namespace {

std::unique_ptr<SequenceMethod> make_taa(const std::string& label, const std::string& variant,
                                         const std::vector<std::string>& overrides,
                                         const Exec& exec) {
  taa::TaaSettings s = taa::make_preset(variant);
  for (const auto& kv : overrides) s.set_assignment(kv);
  s.validate();
  return std::make_unique<taa::TaaMethod>(label, s, exec);
}

std::unique_ptr<SequenceMethod> make_taau(const std::string& label, const std::string& variant,
                                          const std::vector<std::string>& overrides,
                                          const Exec& exec) {
  taau::TaauSettings s = taau::make_preset(variant);
  for (const auto& kv : overrides) s.set_assignment(kv);
  s.validate();
  return std::make_unique<taau::TaauMethod>(label, s, exec);
}

std::unique_ptr<SequenceMethod> make_svgf(const std::string& label, const std::string& variant,
                                          const std::vector<std::string>& overrides,
                                          const Exec& exec) {
  svgf::SvgfSettings s = svgf::make_preset(variant);
  for (const auto& kv : overrides) s.set_assignment(kv);
  s.validate();
  return std::make_unique<svgf::SvgfDenoiser>(s, exec, label);
}

std::string svgf_settings_markdown() {
  return svgf::SvgfSettings::params().markdown_table();
}

std::string taau_settings_markdown() {
  return taau::TaauSettings::params().markdown_table();
}

// A TAAU bench row of output size w x h reads frames of round(size / scale).
std::pair<int, int> taau_bench_input_size(const std::string& variant, int w, int h) {
  const float s = taau::make_preset(variant).scale;
  return {std::max(1, int(std::lround(w / s))), std::max(1, int(std::lround(h / s)))};
}

std::string taa_settings_markdown() {
  return taa::TaaSettings::params().markdown_table();
}

std::vector<std::string> taa_demo_variants() {
  // Every published preset; "none" (no rectification) is a reference for tests.
  std::vector<std::string> v;
  for (const auto& p : taa::preset_names())
    if (p != "none") v.push_back(p);
  return v;
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (true) {
    const size_t at = s.find(sep, start);
    parts.push_back(s.substr(start, at == std::string::npos ? at : at - start));
    if (at == std::string::npos) return parts;
    start = at + 1;
  }
}

// A temporal method followed by the stateless post passes of its spec (the pipeline appends
// them; techniques never call post/). History stays the method's own, unsharpened.
class WithPost final : public SequenceMethod {
 public:
  WithPost(std::unique_ptr<SequenceMethod> inner, post::SharpenSettings sharpen, Exec exec)
      : inner_(std::move(inner)), sharpen_(sharpen), exec_(exec) {}
  std::string name() const override { return inner_->name(); }
  ChannelSet required_channels() const override { return inner_->required_channels(); }
  Frame process(const Frame& frame) override {
    Frame out = inner_->process(frame);
    out.color = post::sharpen(out.color, sharpen_, exec_);
    return out;
  }
  void reset() override { inner_->reset(); }
  void save_state(const std::string& path) const override { inner_->save_state(path); }
  void load_state(const std::string& path) override { inner_->load_state(path); }
  std::string settings_json() const override { return inner_->settings_json(); }
  std::string describe_settings() const override {
    return inner_->describe_settings() + post::SharpenSettings::params().describe(sharpen_);
  }
  void set_exec(const Exec& exec) override {
    exec_ = exec;
    inner_->set_exec(exec);
  }

 private:
  std::unique_ptr<SequenceMethod> inner_;
  post::SharpenSettings sharpen_;
  Exec exec_;
};

const MethodFamily& family(const std::string& technique, const std::string& spec) {
  for (const MethodFamily& f : method_families())
    if (f.technique == technique) return f;
  std::vector<std::string> names;
  for (const MethodFamily& f : method_families()) names.push_back(f.technique);
  throw SettingsError(fmt::format("method '{}': unknown technique '{}' (valid: {})", spec,
                                  technique, fmt::join(names, ", ")));
}

}  // namespace

const std::vector<MethodFamily>& method_families() {
  // Immutable table: one entry per technique.
  static const std::vector<MethodFamily> kFamilies = {
      {"taa",
       "TAA",
       "afterimage resolve --preset",
       "temporal anti-aliasing (taa/); variants are the named presets",
       taa::preset_names(),
       taa_demo_variants(),
       // Reads color 3 + depth 1 + motion 2 + history 3 + sample count 1 planes, writes output
       // 3 + history 3 + sample count 1 (the minimum any preset must touch; the bench's floor
       // takes each preset's own planes, TemporalResolver::last_traffic).
       "taa.resolve",
       10,
       7,
       nullptr,
       &taa_settings_markdown,
       &make_taa,
       false,
       // The default without history confidence (the cost of its moment planes, neighbour
       // reads and rules).
       {"afterimage+confidence=false+blend_filtered=false"}},
      {"taau",
       "TAAU",
       "afterimage resolve --upscale",
       "temporal upsampling (taau/): low-resolution input, full-resolution history and output; "
       "variants are FSR2's modes",
       taau::preset_names(),
       {},  // the demo runs TAAU in its own section (low-res renders)
       // At output size: reads history 3 + weight 1 planes and the input's color 3 + depth 1 +
       // motion 2 at 1/scale^2 of the pixels (1.5 at 2x, rounded down), writes output 3 +
       // history 3 + weight 1.
       "taau.upscale",
       5,
       7,
       &taau_bench_input_size,
       &taau_settings_markdown,
       &make_taau,
       false},
      {"svgf",
       "SVGF",
       "afterimage denoise --preset",
       "spatiotemporal variance-guided filtering of path-traced frames (svgf/); variants are "
       "the named presets",
       svgf::preset_names(),
       {},  // the demo runs SVGF on path-traced scenes (issue 11), not on the G-buffer ones
       // Combined signal: reads color 3 + albedo 3 + depth 1 + normal 3 + motion 2 + history 3
       // + moments 2 + length 1 + previous depth 1, normal 3, id 1 planes; writes output 3 +
       // history 3 + moments 2 + length 1 + this frame's depth 1, normal 3, id 1 (the
       // à-trous iterations' own traffic comes on top).
       "svgf.filter",
       23,
       14,
       nullptr,
       &svgf_settings_markdown,
       &make_svgf,
       true,
       // The afterimage preset before its speed settings (5x5 à-trous kernel, 7x7 spatial
       // variance; settings.cpp).
       {"afterimage+atrous_kernel=5x5+sigma_l=2+spatial_radius=3"}},
  };
  return kFamilies;
}

MethodSpec parse_method_spec(const std::string& spec) {
  const std::vector<std::string> parts = split(spec, '+');
  const std::string& head = parts.front();
  const size_t colon = head.find(':');
  MethodSpec m;
  m.technique =
      colon == std::string::npos ? method_families().front().technique : head.substr(0, colon);
  m.variant = colon == std::string::npos ? head : head.substr(colon + 1);
  // An override is key=value; a part without '=' belongs to the previous value, whose '+'
  // was part of it (an exponent: alpha=1e+0).
  for (size_t i = 1; i < parts.size(); ++i) {
    if (parts[i].find('=') == std::string::npos && !m.overrides.empty())
      m.overrides.back() += "+" + parts[i];
    else
      m.overrides.push_back(parts[i]);
  }
  family(m.technique, spec);  // throws for unknown techniques
  return m;
}

std::unique_ptr<SequenceMethod> make_method(const std::string& spec, const Exec& exec) {
  const MethodSpec m = parse_method_spec(spec);
  const std::string label = spec.find(':') == std::string::npos ? m.technique + ":" + spec : spec;
  // Keys of the post passes go to them, the rest to the technique.
  const auto& post_table = post::SharpenSettings::params();
  const std::vector<std::string> post_keys = post_table.keys();
  post::SharpenSettings sharpen;
  std::vector<std::string> own;
  bool any_post = false;
  for (const auto& kv : m.overrides) {
    const std::string key = kv.substr(0, kv.find('='));
    if (std::find(post_keys.begin(), post_keys.end(), key) != post_keys.end()) {
      post_table.set_assignment(sharpen, kv);
      any_post = true;
    } else {
      own.push_back(kv);
    }
  }
  const MethodFamily& fam = family(m.technique, spec);
  // The frames' coverage alpha goes through a twin of the method (run/alpha.h).
  std::unique_ptr<SequenceMethod> method = carry_alpha(
      fam.make(label, m.variant, own, exec),
      [&fam, label, variant = m.variant, own, exec] { return fam.make(label, variant, own, exec); },
      exec);
  if (!any_post) return method;
  post_table.validate(sharpen);
  return std::make_unique<WithPost>(std::move(method), sharpen, exec);
}

std::string method_label(const std::string& spec) {
  const MethodSpec m = parse_method_spec(spec);
  std::string s = family(m.technique, spec).label + " " + m.variant;
  for (const auto& kv : m.overrides) s += "+" + kv;
  return s;
}

std::string method_command(const std::string& spec) {
  const MethodSpec m = parse_method_spec(spec);
  std::string s = family(m.technique, spec).command + " " + m.variant;
  for (const auto& kv : m.overrides) s += " --set " + kv;
  return s;
}

std::vector<std::string> registered_method_names() {
  std::vector<std::string> names;
  for (const MethodFamily& f : method_families())
    for (const auto& v : f.variants) names.push_back(f.technique + ":" + v);
  return names;
}

std::vector<std::string> default_demo_methods() {
  std::vector<std::string> names;
  for (const MethodFamily& f : method_families())
    for (const auto& v : f.demo_variants) names.push_back(f.technique + ":" + v);
  return names;
}

const std::vector<std::string>& method_variants(const std::string& technique) {
  return family(technique, technique).variants;
}

std::string upscale_method_spec(const std::string& arg) {
  return taau::upscale_spec(arg);
}

std::string settings_markdown(const std::string& technique) {
  return family(technique, technique).settings_markdown();
}

std::string default_variant(const std::string& technique) {
  return method_variants(technique).front();
}

}  // namespace afterimage
