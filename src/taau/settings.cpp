#include "taau/settings.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <string>

#include "core/error.h"

namespace afterimage::taau {

namespace {

constexpr EnumNames<SplatKernel, 2> kKernelNames{
    {{SplatKernel::Lanczos2, "lanczos2"}, {SplatKernel::Gaussian, "gaussian"}}};

// The TAA enums keep the names taa/settings.cpp spells (read through taa::to_string).
template <class E, std::size_t N>
EnumNames<E, N> taa_names(const E (&values)[N]) {
  EnumNames<E, N> names{};
  for (std::size_t i = 0; i < N; ++i) names[i] = {values[i], taa::to_string(values[i])};
  return names;
}

ParamTable<TaauSettings> make_table() {
  using S = TaauSettings;
  using namespace taa;
  ParamTable<S> t("taau");
  t.add_float("scale", &S::scale, 1.0f, 4.0f,
              "output size per axis = round(input * scale) (FSR2: 1.5 / 1.7 / 2)");
  t.add_int("output_width", &S::output_width, 0, 8192, "explicit output width (0: from scale)");
  t.add_int("output_height", &S::output_height, 0, 8192, "explicit output height (0: from scale)");
  t.add_enum("kernel", &S::kernel, kKernelNames,
             "weight of a sample by its distance to the output pixel center");
  t.add_float("lanczos_width", &S::lanczos_width, 0.25f, 4.0f,
              "Lanczos-2 distance unit in output pixels (support 2 units)");
  t.add_float("gaussian_sigma", &S::gaussian_sigma, 0.1f, 4.0f, "Gaussian sigma in output pixels");
  t.add_bool("deringing", &S::deringing,
             "clamp the splatted color to its 3x3 low-resolution min/max (FSR2)");
  t.add_float("max_weight", &S::max_weight, 1.0f, 1024.0f,
              "cap of the accumulated sample weight (alpha floor w / (cap + w))");
  t.add_bool("confidence", &S::confidence,
             "history confidence: relax the box and raise the weight cap where history is trusted");
  t.add_float("confident_max_weight", &S::confident_max_weight, 1.0f, 1024.0f,
              "weight cap of fully trusted pixels (confidence)");
  t.add_float("confidence_motion_px", &S::confidence_motion_px, 0.01f, 1e4f,
              "motion (output px/frame) at which confidence reaches 0");
  t.add_float("confidence_box_sigma", &S::confidence_box_sigma, 0.0f, 100.0f,
              "box widened by this many temporal sigmas of the input samples x confidence");
  static const HistorySampler kHistory[] = {HistorySampler::Bilinear, HistorySampler::CatmullRom5,
                                            HistorySampler::CatmullRom9, HistorySampler::Bicubic16};
  t.add_enum("history", &S::history, taa_names(kHistory),
             "history resampling filter (output resolution)");
  t.add_bool("anti_ringing", &S::anti_ringing,
             "clamp bicubic history to its 2x2 bilinear footprint min/max");
  static const VelocityDilation kDilation[] = {
      VelocityDilation::None, VelocityDilation::ClosestDepthCross5,
      VelocityDilation::ClosestDepthBox9, VelocityDilation::LargestMotion};
  t.add_enum("dilation", &S::dilation, taa_names(kDilation),
             "velocity dilation over the low-resolution 3x3 (seed 002/003)");
  static const Rectify kRectify[] = {Rectify::None, Rectify::Clamp, Rectify::ClipCenter,
                                     Rectify::ClipFiltered, Rectify::ConvexHull};
  t.add_enum("rectify", &S::rectify, taa_names(kRectify),
             "history rectification against the low-resolution 3x3");
  static const BoxShape kBox[] = {BoxShape::MinMax, BoxShape::Variance};
  t.add_enum("box", &S::box, taa_names(kBox), "neighbourhood box: min/max or mu+-gamma*sigma");
  t.add_float("variance_gamma", &S::variance_gamma, 0.1f, 4.0f,
              "gamma of the variance box mu +- gamma sigma (Salvi 2016)");
  t.add_bool("variance_intersect_minmax", &S::variance_intersect_minmax,
             "intersect the variance box with the min/max box (Salvi)");
  t.add_bool("variance_include_filtered", &S::variance_include_filtered,
             "grow the variance box to contain the splatted color (UE4)");
  static const ColorSpace kSpace[] = {ColorSpace::Rgb, ColorSpace::YCoCg};
  t.add_enum("color_space", &S::color_space, taa_names(kSpace),
             "color space of rectification (YCoCg: Karis 2014)");
  t.check([](const S& s) {
    return (s.output_width == 0) != (s.output_height == 0)
               ? fmt::format("output_width ({}) and output_height ({}) are set together",
                             s.output_width, s.output_height)
               : std::string();
  });
  return t;
}

TaauSettings with_scale(float scale) {
  TaauSettings s;
  s.scale = scale;
  return s;
}
// FSR2's quality modes (FidelityFX FSR2 README, "Quality modes"): per-axis scale factors.
TaauSettings preset_quality() {
  return with_scale(1.5f);
}
TaauSettings preset_balanced() {
  return with_scale(1.7f);
}
TaauSettings preset_performance() {
  return with_scale(2.0f);
}

}  // namespace

const ParamTable<TaauSettings>& TaauSettings::params() {
  // Immutable once built, so one shared copy is not state.
  static const ParamTable<TaauSettings> kTable = make_table();
  return kTable;
}

const char* to_string(SplatKernel k) {
  return enum_name(kKernelNames, k);
}

void TaauSettings::set(const std::string& key, const std::string& value) {
  params().set(*this, key, value);
}
void TaauSettings::set_assignment(const std::string& assignment) {
  params().set_assignment(*this, assignment);
}
std::string TaauSettings::get(const std::string& key) const {
  return params().get(*this, key);
}
void TaauSettings::validate() const {
  params().validate(*this);
}
std::string TaauSettings::to_json() const {
  return params().to_json(*this);
}
std::string TaauSettings::describe() const {
  return params().describe(*this);
}

taa::TaaSettings TaauSettings::rectification() const {
  taa::TaaSettings t;
  t.rectify = rectify;
  t.box = box;
  t.variance_gamma = variance_gamma;
  t.variance_intersect_minmax = variance_intersect_minmax;
  t.variance_include_filtered = variance_include_filtered;
  t.neighborhood = taa::Neighborhood::Box9;
  t.color_space = color_space;
  t.confidence = confidence;  // the other confidence_* keep TAA's defaults
  t.confidence_box_sigma = confidence_box_sigma;
  return t;
}

std::pair<int, int> TaauSettings::output_size(int in_w, int in_h) const {
  if (in_w < 1 || in_h < 1) throw InputError(fmt::format("taau: empty input {}x{}", in_w, in_h));
  const int w = output_width > 0 ? output_width : int(std::lround(double(in_w) * scale));
  const int h = output_height > 0 ? output_height : int(std::lround(double(in_h) * scale));
  auto ok = [](int in, int out) { return out >= in && out <= 4 * in; };
  if (!ok(in_w, w) || !ok(in_h, h))
    throw InputError(
        fmt::format("taau: output {}x{} for input {}x{}: each axis must be 1 to 4 times the input",
                    w, h, in_w, in_h));
  return {w, h};
}

const std::vector<PresetInfo>& taau_presets() {
  static const std::vector<PresetInfo> kPresets{
      {"performance", "FSR2 performance mode: 2x per axis", preset_performance},
      {"balanced", "FSR2 balanced mode: 1.7x per axis", preset_balanced},
      {"quality", "FSR2 quality mode: 1.5x per axis", preset_quality},
  };
  return kPresets;
}

std::vector<std::string> preset_names() {
  std::vector<std::string> names;
  for (const auto& p : taau_presets()) names.emplace_back(p.name);
  return names;
}

TaauSettings make_preset(const std::string& name) {
  for (const auto& p : taau_presets())
    if (name == p.name) return p.make();
  throw SettingsError(fmt::format("unknown taau preset '{}'; valid presets: {}", name,
                                  fmt::join(preset_names(), ", ")));
}

std::string upscale_spec(const std::string& arg) {
  const std::string base = std::string("taau:") + taau_presets().front().name;
  for (const auto& p : taau_presets())
    if (arg == p.name) return "taau:" + arg;
  const auto x = arg.find('x');
  if (x != std::string::npos) {
    int w = 0, h = 0;
    const char* e = arg.data() + arg.size();
    const auto r1 = std::from_chars(arg.data(), arg.data() + x, w);
    const auto r2 = std::from_chars(arg.data() + x + 1, e, h);
    if (r1.ec != std::errc() || r1.ptr != arg.data() + x || r2.ec != std::errc() || r2.ptr != e ||
        w < 1 || h < 1 || w > 8192 || h > 8192)
      throw SettingsError(
          fmt::format("--upscale '{}': expected WIDTHxHEIGHT with sides in [1, 8192]", arg));
    return fmt::format("{}+output_width={}+output_height={}", base, w, h);
  }
  float s = 0;
  const char* e = arg.data() + arg.size();
  const auto r = std::from_chars(arg.data(), e, s);
  if (r.ec != std::errc() || r.ptr != e)
    throw SettingsError(fmt::format("--upscale '{}': expected {}, a scale in [1, 4] or WxH", arg,
                                    fmt::join(preset_names(), ", ")));
  if (!(s >= 1.0f && s <= 4.0f))  // NaN fails too
    throw SettingsError(fmt::format("--upscale {}: the scale must be in [1, 4]", arg));
  return fmt::format("{}+scale={}", base, arg);
}

}  // namespace afterimage::taau
