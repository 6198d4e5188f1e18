#include "taa/settings.h"

#include <fmt/format.h>

#include <array>
#include <charconv>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <utility>

#include "core/error.h"

namespace afterimage::taa {

namespace {

// Names of enum values: the single table used by parsing, printing and JSON.
template <class E, size_t N>
using NameTable = std::array<std::pair<E, const char*>, N>;

constexpr NameTable<HistorySampler, 4> kHistoryNames{
    {{HistorySampler::Bilinear, "bilinear"},
     {HistorySampler::CatmullRom5, "catmull_rom_5"},
     {HistorySampler::CatmullRom9, "catmull_rom_9"},
     {HistorySampler::Bicubic16, "bicubic_16"}}};
constexpr NameTable<VelocityDilation, 4> kDilationNames{
    {{VelocityDilation::None, "none"},
     {VelocityDilation::ClosestDepthCross5, "closest_depth_cross5"},
     {VelocityDilation::ClosestDepthBox9, "closest_depth_box9"},
     {VelocityDilation::LargestMotion, "largest_motion"}}};
constexpr NameTable<Rectify, 5> kRectifyNames{{{Rectify::None, "none"},
                                               {Rectify::Clamp, "clamp"},
                                               {Rectify::ClipCenter, "clip_center"},
                                               {Rectify::ClipFiltered, "clip_filtered"},
                                               {Rectify::ConvexHull, "convex_hull"}}};
constexpr NameTable<BoxShape, 2> kBoxNames{
    {{BoxShape::MinMax, "minmax"}, {BoxShape::Variance, "variance"}}};
constexpr NameTable<Neighborhood, 3> kNeighborhoodNames{{{Neighborhood::Cross5, "cross5"},
                                                         {Neighborhood::Box9, "box9"},
                                                         {Neighborhood::Rounded, "rounded"}}};
constexpr NameTable<ColorSpace, 2> kColorSpaceNames{
    {{ColorSpace::Rgb, "rgb"}, {ColorSpace::YCoCg, "ycocg"}}};
constexpr NameTable<CurrentFilter, 3> kFilterNames{
    {{CurrentFilter::None, "none"},
     {CurrentFilter::Gaussian, "gaussian"},
     {CurrentFilter::BlackmanHarris, "blackman_harris"}}};
constexpr NameTable<Rejection, 3> kRejectionNames{
    {{Rejection::Off, "off"}, {Rejection::Reset, "reset"}, {Rejection::Reduce, "reduce"}}};

template <class E, size_t N>
const char* name_of(const NameTable<E, N>& t, E v) {
  for (const auto& [e, n] : t)
    if (e == v) return n;
  return "?";
}
template <class E, size_t N>
std::string names_joined(const NameTable<E, N>& t) {
  std::string s;
  for (const auto& [e, n] : t) {
    if (!s.empty()) s += '|';
    s += n;
  }
  return s;
}

std::string format_float(float v) {
  return fmt::format("{}", v);
}

// One settable field: how to read, write and check it. Built once per call of fields()
// from member pointers, so the table is the only place a key is spelled.
struct Field {
  std::string key;
  std::string doc;
  std::string range;  // for listings and error messages
  std::function<std::string(const TaaSettings&)> get;
  std::function<void(TaaSettings&, const std::string&)> parse_set;  // throws SettingsError
  std::function<bool(const TaaSettings&)> in_range;
  std::function<nlohmann::json(const TaaSettings&)> json;
};

Field float_field(const char* key, float TaaSettings::*m, float lo, float hi, const char* doc) {
  Field f;
  f.key = key;
  f.doc = doc;
  f.range = fmt::format("[{}, {}]", lo, hi);
  f.get = [m](const TaaSettings& s) { return format_float(s.*m); };
  f.in_range = [m, lo, hi](const TaaSettings& s) { return s.*m >= lo && s.*m <= hi; };
  f.parse_set = [m, lo, hi, key](TaaSettings& s, const std::string& v) {
    float x = 0.0f;
    const char* b = v.data();
    const char* e = v.data() + v.size();
    auto r = std::from_chars(b, e, x);
    if (r.ec != std::errc() || r.ptr != e)
      throw SettingsError(fmt::format("taa setting {}: '{}' is not a number", key, v));
    if (!(x >= lo && x <= hi))
      throw SettingsError(
          fmt::format("taa setting {}: {} is out of range [{}, {}]", key, v, lo, hi));
    s.*m = x;
  };
  f.json = [m](const TaaSettings& s) { return nlohmann::json(s.*m); };
  return f;
}

Field bool_field(const char* key, bool TaaSettings::*m, const char* doc) {
  Field f;
  f.key = key;
  f.doc = doc;
  f.range = "true|false";
  f.get = [m](const TaaSettings& s) { return std::string(s.*m ? "true" : "false"); };
  f.in_range = [](const TaaSettings&) { return true; };
  f.parse_set = [m, key](TaaSettings& s, const std::string& v) {
    if (v == "true" || v == "1" || v == "on" || v == "yes")
      s.*m = true;
    else if (v == "false" || v == "0" || v == "off" || v == "no")
      s.*m = false;
    else
      throw SettingsError(
          fmt::format("taa setting {}: '{}' is not a boolean (true|false|on|off|1|0)", key, v));
  };
  f.json = [m](const TaaSettings& s) { return nlohmann::json(s.*m); };
  return f;
}

template <class E, size_t N>
Field enum_field(const char* key, E TaaSettings::*m, const NameTable<E, N>& table,
                 const char* doc) {
  Field f;
  f.key = key;
  f.doc = doc;
  f.range = names_joined(table);
  f.get = [m, &table](const TaaSettings& s) { return std::string(name_of(table, s.*m)); };
  f.in_range = [m, &table](const TaaSettings& s) {
    for (const auto& [e, n] : table)
      if (e == s.*m) return true;
    return false;
  };
  f.parse_set = [m, &table, key](TaaSettings& s, const std::string& v) {
    for (const auto& [e, n] : table)
      if (v == n) {
        s.*m = e;
        return;
      }
    throw SettingsError(
        fmt::format("taa setting {}: '{}' is not one of {}", key, v, names_joined(table)));
  };
  f.json = [m, &table](const TaaSettings& s) { return nlohmann::json(name_of(table, s.*m)); };
  return f;
}

std::vector<Field> make_fields() {
  using S = TaaSettings;
  std::vector<Field> f;
  f.push_back(float_field("alpha", &S::alpha, 0.001f, 1.0f,
                          "blend factor of the current frame (seed 000 Eq.2)"));
  f.push_back(float_field("alpha_min", &S::alpha_min, 0.001f, 1.0f,
                          "floor of alpha = max(alpha_min, 1/N) with sample_count (Eq.1/3)"));
  f.push_back(bool_field("sample_count", &S::sample_count,
                         "per-pixel sample count: box average for fresh pixels (Eq.1)"));
  f.push_back(bool_field("static_mode", &S::static_mode,
                         "point-sampled history (Load) for static scenes (seed 000)"));
  f.push_back(enum_field("history", &S::history, kHistoryNames, "history resampling filter"));
  f.push_back(bool_field("anti_ringing", &S::anti_ringing,
                         "clamp bicubic history to its 2x2 bilinear footprint min/max"));
  f.push_back(
      enum_field("dilation", &S::dilation, kDilationNames, "velocity dilation (seed 002/003)"));
  f.push_back(enum_field("rectify", &S::rectify, kRectifyNames,
                         "history rectification against the neighbourhood"));
  f.push_back(
      enum_field("box", &S::box, kBoxNames, "neighbourhood box: min/max or mu+-gamma*sigma"));
  f.push_back(float_field("variance_gamma", &S::variance_gamma, 0.1f, 4.0f,
                          "gamma of the variance box mu +- gamma sigma (Salvi 2016)"));
  f.push_back(bool_field("variance_intersect_minmax", &S::variance_intersect_minmax,
                         "intersect the variance box with the min/max box (Salvi)"));
  f.push_back(bool_field("variance_include_filtered", &S::variance_include_filtered,
                         "grow the variance box to contain the filtered color (UE4)"));
  f.push_back(enum_field("neighborhood", &S::neighborhood, kNeighborhoodNames,
                         "neighbourhood of the box (rounded = INSIDE average of cross5/box9)"));
  f.push_back(enum_field("color_space", &S::color_space, kColorSpaceNames,
                         "color space of rectification (YCoCg: Karis 2014)"));
  f.push_back(enum_field("depth_reject", &S::depth_reject, kRejectionNames,
                         "reject history whose previous depth differs"));
  f.push_back(float_field("depth_tolerance", &S::depth_tolerance, 0.0001f, 10.0f,
                          "relative depth tolerance |d_prev - d| <= tol * d"));
  f.push_back(enum_field("id_reject", &S::id_reject, kRejectionNames,
                         "reject history whose previous object id differs"));
  f.push_back(enum_field("velocity_reject", &S::velocity_reject, kRejectionNames,
                         "reject history whose previous motion differs"));
  f.push_back(float_field("velocity_tolerance", &S::velocity_tolerance, 0.01f, 1e4f,
                          "motion difference (px) that fails the velocity test"));
  f.push_back(float_field("reject_keep", &S::reject_keep, 0.0f, 1.0f,
                          "history weight kept by a 'reduce' rejection"));
  f.push_back(bool_field("luma_weight", &S::luma_weight,
                         "Karis 1/(1+L) weighting of current and history in the blend"));
  f.push_back(enum_field("current_filter", &S::current_filter, kFilterNames,
                         "3x3 filter of the current frame at the jittered sample positions"));
  f.push_back(float_field("filter_sigma", &S::filter_sigma, 0.1f, 3.0f,
                          "sigma (px) of the gaussian current filter"));
  f.push_back(bool_field("filter_luma_weight", &S::filter_luma_weight,
                         "weight current-filter samples by 1/(1+L)"));
  f.push_back(bool_field("blend_filtered", &S::blend_filtered,
                         "blend the filtered current color (else the raw sample)"));
  f.push_back(
      bool_field("adaptive_velocity", &S::adaptive_velocity, "raise alpha with motion length"));
  f.push_back(float_field("velocity_alpha_max", &S::velocity_alpha_max, 0.001f, 1.0f,
                          "alpha reached at velocity_alpha_px"));
  f.push_back(float_field("velocity_alpha_px", &S::velocity_alpha_px, 0.01f, 1e4f,
                          "motion (px/frame) at which alpha reaches velocity_alpha_max"));
  f.push_back(bool_field("adaptive_depth", &S::adaptive_depth, "lower alpha with depth"));
  f.push_back(float_field("depth_alpha_far", &S::depth_alpha_far, 0.001f, 1.0f,
                          "alpha approached far away"));
  f.push_back(float_field("depth_alpha_distance", &S::depth_alpha_distance, 1e-4f, 1e9f,
                          "depth up to which alpha is unchanged"));
  f.push_back(bool_field("adaptive_clamp_distance", &S::adaptive_clamp_distance,
                         "lower alpha when history is near the clamp box (Karis 2014)"));
  f.push_back(float_field("clamp_alpha_scale", &S::clamp_alpha_scale, 0.0f, 1.0f,
                          "alpha scale when history touches the box surface"));
  f.push_back(bool_field("adaptive_luma_difference", &S::adaptive_luma_difference,
                         "INSIDE feedback from the unbiased luma difference"));
  f.push_back(float_field("luma_feedback_min", &S::luma_feedback_min, 0.0f, 1.0f,
                          "history feedback at large luma difference (INSIDE 0.88)"));
  f.push_back(float_field("luma_feedback_max", &S::luma_feedback_max, 0.0f, 1.0f,
                          "history feedback at equal luma (INSIDE 0.97)"));
  f.push_back(float_field("sharpen", &S::sharpen, 0.0f, 4.0f,
                          "Laplacian sharpen strength after resolve (seed 000 Eq.5), 0 = off"));
  return f;
}

// The field table is immutable, so one shared copy is not state.
const std::vector<Field>& fields() {
  static const std::vector<Field> kFields = make_fields();
  return kFields;
}

const Field& find_field(const std::string& key) {
  for (const auto& f : fields())
    if (f.key == key) return f;
  std::string valid;
  for (const auto& f : fields()) {
    if (!valid.empty()) valid += ", ";
    valid += f.key;
  }
  throw SettingsError(fmt::format("unknown taa setting '{}'; valid keys: {}", key, valid));
}

}  // namespace

const char* to_string(HistorySampler v) {
  return name_of(kHistoryNames, v);
}
const char* to_string(VelocityDilation v) {
  return name_of(kDilationNames, v);
}
const char* to_string(Rectify v) {
  return name_of(kRectifyNames, v);
}
const char* to_string(BoxShape v) {
  return name_of(kBoxNames, v);
}
const char* to_string(Neighborhood v) {
  return name_of(kNeighborhoodNames, v);
}
const char* to_string(ColorSpace v) {
  return name_of(kColorSpaceNames, v);
}
const char* to_string(CurrentFilter v) {
  return name_of(kFilterNames, v);
}
const char* to_string(Rejection v) {
  return name_of(kRejectionNames, v);
}

std::vector<std::string> setting_keys() {
  std::vector<std::string> k;
  for (const auto& f : fields()) k.push_back(f.key);
  return k;
}

void TaaSettings::set(const std::string& key, const std::string& value) {
  find_field(key).parse_set(*this, value);
}

void TaaSettings::set_assignment(const std::string& assignment) {
  auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw SettingsError(fmt::format("taa setting '{}' is not of the form key=value", assignment));
  set(assignment.substr(0, eq), assignment.substr(eq + 1));
}

std::string TaaSettings::get(const std::string& key) const {
  return find_field(key).get(*this);
}

void TaaSettings::validate() const {
  for (const auto& f : fields())
    if (!f.in_range(*this))
      throw SettingsError(
          fmt::format("taa setting {} = {} is out of range {}", f.key, f.get(*this), f.range));
  if (luma_feedback_min > luma_feedback_max)
    throw SettingsError(
        fmt::format("taa settings: luma_feedback_min ({}) must not exceed luma_feedback_max ({})",
                    luma_feedback_min, luma_feedback_max));
}

std::string TaaSettings::to_json() const {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& f : fields()) j[f.key] = f.json(*this);
  return j.dump(2);
}

std::string TaaSettings::describe() const {
  const TaaSettings defaults;
  std::string out;
  for (const auto& f : fields())
    out += fmt::format("{:<26} = {:<14} default {}, range {} -- {}\n", f.key, f.get(*this),
                       f.get(defaults), f.range, f.doc);
  return out;
}

}  // namespace afterimage::taa
