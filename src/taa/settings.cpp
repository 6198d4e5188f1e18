#include "taa/settings.h"

#include <fmt/format.h>

#include <string>

namespace afterimage::taa {

namespace {

// Names of enum values: the single table used by parsing, printing and JSON.
constexpr EnumNames<HistorySampler, 4> kHistoryNames{
    {{HistorySampler::Bilinear, "bilinear"},
     {HistorySampler::CatmullRom5, "catmull_rom_5"},
     {HistorySampler::CatmullRom9, "catmull_rom_9"},
     {HistorySampler::Bicubic16, "bicubic_16"}}};
constexpr EnumNames<VelocityDilation, 4> kDilationNames{
    {{VelocityDilation::None, "none"},
     {VelocityDilation::ClosestDepthCross5, "closest_depth_cross5"},
     {VelocityDilation::ClosestDepthBox9, "closest_depth_box9"},
     {VelocityDilation::LargestMotion, "largest_motion"}}};
constexpr EnumNames<Rectify, 5> kRectifyNames{{{Rectify::None, "none"},
                                               {Rectify::Clamp, "clamp"},
                                               {Rectify::ClipCenter, "clip_center"},
                                               {Rectify::ClipFiltered, "clip_filtered"},
                                               {Rectify::ConvexHull, "convex_hull"}}};
constexpr EnumNames<BoxShape, 2> kBoxNames{
    {{BoxShape::MinMax, "minmax"}, {BoxShape::Variance, "variance"}}};
constexpr EnumNames<Neighborhood, 3> kNeighborhoodNames{{{Neighborhood::Cross5, "cross5"},
                                                         {Neighborhood::Box9, "box9"},
                                                         {Neighborhood::Rounded, "rounded"}}};
constexpr EnumNames<ColorSpace, 2> kColorSpaceNames{
    {{ColorSpace::Rgb, "rgb"}, {ColorSpace::YCoCg, "ycocg"}}};
constexpr EnumNames<CurrentFilter, 4> kFilterNames{
    {{CurrentFilter::None, "none"},
     {CurrentFilter::Gaussian, "gaussian"},
     {CurrentFilter::BlackmanHarris, "blackman_harris"},
     {CurrentFilter::MitchellNetravali, "mitchell_netravali"}}};
constexpr EnumNames<Rejection, 3> kRejectionNames{
    {{Rejection::Off, "off"}, {Rejection::Reset, "reset"}, {Rejection::Reduce, "reduce"}}};

ParamTable<TaaSettings> make_table() {
  using S = TaaSettings;
  ParamTable<S> t("taa");
  t.add_float("alpha", &S::alpha, 0.001f, 1.0f,
              "blend factor of the current frame (seed 000 Eq.2)");
  t.add_float("alpha_min", &S::alpha_min, 0.001f, 1.0f,
              "floor of alpha = max(alpha_min, 1/N) with sample_count (Eq.1/3)");
  t.add_bool("sample_count", &S::sample_count,
             "per-pixel sample count: box average for fresh pixels (Eq.1)");
  t.add_bool("static_mode", &S::static_mode,
             "point-sampled history (Load) for static scenes (seed 000)");
  t.add_enum("history", &S::history, kHistoryNames, "history resampling filter");
  t.add_bool("anti_ringing", &S::anti_ringing,
             "clamp bicubic history to its 2x2 bilinear footprint min/max");
  t.add_enum("dilation", &S::dilation, kDilationNames, "velocity dilation (seed 002/003)");
  t.add_enum("rectify", &S::rectify, kRectifyNames,
             "history rectification against the neighbourhood");
  t.add_enum("box", &S::box, kBoxNames, "neighbourhood box: min/max or mu+-gamma*sigma");
  t.add_float("variance_gamma", &S::variance_gamma, 0.1f, 4.0f,
              "gamma of the variance box mu +- gamma sigma (Salvi 2016)");
  t.add_bool("variance_intersect_minmax", &S::variance_intersect_minmax,
             "intersect the variance box with the min/max box (Salvi)");
  t.add_bool("variance_include_filtered", &S::variance_include_filtered,
             "grow the variance box to contain the filtered color (UE4)");
  t.add_float("box_floor", &S::box_floor, 0.0f, 1.0f,
              "smallest half-extent of the box in chroma, relative to the filtered luma");
  t.add_enum("neighborhood", &S::neighborhood, kNeighborhoodNames,
             "neighbourhood of the box (rounded = INSIDE average of cross5/box9)");
  t.add_enum("color_space", &S::color_space, kColorSpaceNames,
             "color space of rectification (YCoCg: Karis 2014)");
  t.add_enum("depth_reject", &S::depth_reject, kRejectionNames,
             "reject history whose previous depth differs");
  t.add_float("depth_tolerance", &S::depth_tolerance, 0.0001f, 10.0f,
              "relative depth tolerance |d_prev - d| <= tol * d");
  t.add_enum("id_reject", &S::id_reject, kRejectionNames,
             "reject history whose previous object id differs");
  t.add_enum("velocity_reject", &S::velocity_reject, kRejectionNames,
             "reject history whose previous motion differs");
  t.add_float("velocity_tolerance", &S::velocity_tolerance, 0.01f, 1e4f,
              "motion difference (px) that fails the velocity test");
  t.add_float("reject_keep", &S::reject_keep, 0.0f, 1.0f,
              "history weight kept by a 'reduce' rejection");
  t.add_bool("luma_weight", &S::luma_weight,
             "Karis 1/(1+L) weighting of current and history in the blend");
  t.add_enum("current_filter", &S::current_filter, kFilterNames,
             "3x3 filter of the current frame at the jittered sample positions");
  t.add_float("filter_sigma", &S::filter_sigma, 0.1f, 3.0f,
              "sigma (px) of the gaussian current filter");
  t.add_bool("filter_luma_weight", &S::filter_luma_weight,
             "weight current-filter samples by 1/(1+L)");
  t.add_float("fresh_filter_sigma", &S::fresh_filter_sigma, 0.0f, 3.0f,
              "sigma (px) of the gaussian in the shown color where the history is fresh (with "
              "sample_count; 0: off)");
  t.add_float("fresh_filter_frames", &S::fresh_filter_frames, 1.0f, 64.0f,
              "frames of history at which the fresh filter has handed over to the current filter");
  t.add_bool("blend_filtered", &S::blend_filtered,
             "blend the filtered current color (else the raw sample)");
  t.add_bool("adaptive_velocity", &S::adaptive_velocity, "raise alpha with motion length");
  t.add_float("velocity_alpha_max", &S::velocity_alpha_max, 0.001f, 1.0f,
              "alpha reached at velocity_alpha_px");
  t.add_float("velocity_alpha_px", &S::velocity_alpha_px, 0.01f, 1e4f,
              "motion (px/frame) at which alpha reaches velocity_alpha_max");
  t.add_bool("adaptive_depth", &S::adaptive_depth, "lower alpha with depth");
  t.add_float("depth_alpha_far", &S::depth_alpha_far, 0.001f, 1.0f, "alpha approached far away");
  t.add_float("depth_alpha_distance", &S::depth_alpha_distance, 1e-4f, 1e9f,
              "depth up to which alpha is unchanged");
  t.add_bool("adaptive_clamp_distance", &S::adaptive_clamp_distance,
             "lower alpha when history is near the clamp box (Karis 2014)");
  t.add_float("clamp_alpha_scale", &S::clamp_alpha_scale, 0.0f, 1.0f,
              "alpha scale when history touches the box surface");
  t.add_bool("adaptive_luma_difference", &S::adaptive_luma_difference,
             "INSIDE feedback from the unbiased luma difference");
  t.add_float("luma_feedback_min", &S::luma_feedback_min, 0.0f, 1.0f,
              "history feedback at large luma difference (INSIDE 0.88)");
  t.add_float("luma_feedback_max", &S::luma_feedback_max, 0.0f, 1.0f,
              "history feedback at equal luma (INSIDE 0.97)");
  t.add_bool("confidence", &S::confidence,
             "per-pixel history confidence relaxes rectification (issue 10)");
  t.add_float("confident_alpha_min", &S::confident_alpha_min, 0.001f, 1.0f,
              "alpha floor where the history is fully trusted");
  t.add_float("confidence_z_lo", &S::confidence_z_lo, 0.0f, 100.0f,
              "z score (sample vs temporal luma) below which history is trusted");
  t.add_float("confidence_z_hi", &S::confidence_z_hi, 0.01f, 100.0f,
              "z score above which history is not trusted at all");
  t.add_float("confidence_motion_px", &S::confidence_motion_px, 0.01f, 1e4f,
              "motion (px/frame) at which confidence reaches 0");
  t.add_float("moments_alpha_min", &S::moments_alpha_min, 0.001f, 1.0f,
              "floor of the weight of new samples in the luma moments");
  t.add_float("confidence_spatial", &S::confidence_spatial, 0.0f, 100.0f,
              "weight of the 3x3 spatial luma sigma in the z score's spread");
  t.add_float("confidence_box_sigma", &S::confidence_box_sigma, 0.0f, 1000.0f,
              "box widened by this many temporal luma sigmas times confidence");
  t.add_float("confidence_rel_floor", &S::confidence_rel_floor, 0.0f, 10.0f,
              "floor of the temporal luma spread, relative to its mean");
  t.add_float("confidence_abs_floor", &S::confidence_abs_floor, 1e-8f, 1e4f,
              "floor of the temporal luma spread, absolute");
  t.add_float("confidence_geometry_px", &S::confidence_geometry_px, 1e-4f, 1e4f,
              "motion (px/frame) below which confidence overrides failed depth/id tests");
  t.add_float("confidence_white_lo", &S::confidence_white_lo, 0.0f, 100.0f,
              "von Neumann ratio of the luma below which variation is a change (no confidence)");
  t.add_float("confidence_white_hi", &S::confidence_white_hi, 0.0f, 100.0f,
              "von Neumann ratio above which variation is aliasing (full confidence)");
  t.add_float("confidence_motion_memory", &S::confidence_motion_memory, 0.0f, 1.0f,
              "per-frame decay of the largest 3x3 speed a pixel remembers (confidence)");
  t.add_float("confidence_neighbor_z", &S::confidence_neighbor_z, 0.0f, 1000.0f,
              "largest neighbour change z score that keeps full confidence (none at 2x; 0: off)");
  t.add_float("confidence_drift_z", &S::confidence_drift_z, 0.0f, 1000.0f,
              "drift z score (running mean of sample minus mean, in successive-difference sigmas) "
              "at which trust starts to fall, 0 at twice it; 0: off");
  t.add_float("confidence_drift_alpha", &S::confidence_drift_alpha, 0.001f, 1.0f,
              "weight of the newest deviation in the drift's running mean");
  t.add_float("temporal_change", &S::temporal_change, 0.0f, 16.0f,
              "scale of the input's temporal_change (A-SVGF lambda) raising alpha; 0 = ignore");

  // INSIDE's feedback interpolates from min (large luma difference) to max (equal luma).
  t.check([](const S& s) {
    return s.luma_feedback_min > s.luma_feedback_max
               ? fmt::format("luma_feedback_min ({}) must not exceed luma_feedback_max ({})",
                             s.luma_feedback_min, s.luma_feedback_max)
               : std::string();
  });
  t.check([](const S& s) {
    return s.confidence_z_lo >= s.confidence_z_hi
               ? fmt::format("confidence_z_lo ({}) must be below confidence_z_hi ({})",
                             s.confidence_z_lo, s.confidence_z_hi)
               : std::string();
  });
  t.check([](const S& s) {
    return s.confidence_white_lo >= s.confidence_white_hi
               ? fmt::format("confidence_white_lo ({}) must be below confidence_white_hi ({})",
                             s.confidence_white_lo, s.confidence_white_hi)
               : std::string();
  });
  return t;
}

}  // namespace

const ParamTable<TaaSettings>& TaaSettings::params() {
  // Immutable once built, so one shared copy is not state.
  static const ParamTable<TaaSettings> kTable = make_table();
  return kTable;
}

const char* to_string(HistorySampler v) {
  return enum_name(kHistoryNames, v);
}
const char* to_string(VelocityDilation v) {
  return enum_name(kDilationNames, v);
}
const char* to_string(Rectify v) {
  return enum_name(kRectifyNames, v);
}
const char* to_string(BoxShape v) {
  return enum_name(kBoxNames, v);
}
const char* to_string(Neighborhood v) {
  return enum_name(kNeighborhoodNames, v);
}
const char* to_string(ColorSpace v) {
  return enum_name(kColorSpaceNames, v);
}
const char* to_string(CurrentFilter v) {
  return enum_name(kFilterNames, v);
}
const char* to_string(Rejection v) {
  return enum_name(kRejectionNames, v);
}

std::vector<std::string> setting_keys() {
  return TaaSettings::params().keys();
}

void TaaSettings::set(const std::string& key, const std::string& value) {
  params().set(*this, key, value);
}

void TaaSettings::set_assignment(const std::string& assignment) {
  params().set_assignment(*this, assignment);
}

std::string TaaSettings::get(const std::string& key) const {
  return params().get(*this, key);
}

void TaaSettings::validate() const {
  params().validate(*this);
}

std::string TaaSettings::to_json() const {
  return params().to_json(*this);
}

std::string TaaSettings::describe() const {
  return params().describe(*this);
}

}  // namespace afterimage::taa
