#include "metrics/metrics.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "core/error.h"
#include "metrics/psnr.h"

namespace afterimage::metrics {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Display-side metrics shared by sequences and pairs.
struct DisplayScores {
  double psnr, psnr_luma, ssim, ssim_luma;
};
DisplayScores display_scores(const ImageF& ref_display, const ImageF& test_display,
                             const SsimSettings& ssim_settings, const Exec& ex) {
  const ImageF ref_luma = luma(ref_display, ex), test_luma = luma(test_display, ex);
  DisplayScores d;
  d.psnr = psnr(ref_display, test_display, 1.0, ex);
  d.psnr_luma = psnr(ref_luma, test_luma, 1.0, ex);
  d.ssim = ssim_channels(ref_display, test_display, ssim_settings, ex);
  d.ssim_luma = ssim(view(ref_luma, 0), view(test_luma, 0), ssim_settings, ex);
  return d;
}

// The scores FrameMetrics and PairMetrics share: display PSNR / SSIM (RGB and luma) and the
// linear-HDR PSNR of the original images.
template <class Scores>
void set_image_scores(Scores& m, const ImageF& ref_display, const ImageF& test_display,
                      const ImageF& ref_linear, const ImageF& test_linear,
                      const SsimSettings& ssim_settings, const Exec& ex) {
  const DisplayScores d = display_scores(ref_display, test_display, ssim_settings, ex);
  m.psnr = d.psnr;
  m.psnr_luma = d.psnr_luma;
  m.ssim = d.ssim;
  m.ssim_luma = d.ssim_luma;
  const LinearPsnr lin = psnr_linear_hdr(ref_linear, test_linear, ex);
  m.psnr_linear = lin.psnr;
  m.psnr_linear_peak = lin.peak;
}

// Mean of field(f) over frames with index >= first; NaN if none.
template <class Field>
double mean_from(const std::vector<FrameMetrics>& frames, int first, Field field) {
  double sum = 0.0;
  int n = 0;
  for (const auto& f : frames)
    if (f.frame >= first) {
      sum += field(f);
      ++n;
    }
  return n > 0 ? sum / n : kNaN;
}

std::string db(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return fmt::format("{:.4f} dB", v);
}

}  // namespace

void require_finite(const ImageF& img, const std::string& what) {
  for (int c = 0; c < img.channels(); ++c)
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x)
        if (!std::isfinite(img.at(x, y, c)))
          throw InputError(fmt::format("{}: non-finite color at pixel ({}, {})", what, x, y));
}

void MetricsSettings::validate() const {
  display.validate();
  ssim.validate();
  flip.validate();
  if (warmup < 0) throw SettingsError(fmt::format("metrics: warmup must be >= 0, got {}", warmup));
  if (ghost_max_age < 1 || ghost_max_age > 254)
    throw SettingsError(
        fmt::format("metrics: ghost_max_age must be in [1, 254], got {}", ghost_max_age));
}

SequenceEvaluator::SequenceEvaluator(const MetricsSettings& s, const Exec& ex)
    : s_(s), ex_(ex), age_(s.ghost_max_age), ghosting_(s.ghost_max_age) {
  s_.validate();
}

PreparedReference prepare_reference(const ImageF& reference, const MetricsSettings& s,
                                    const Exec& ex) {
  if (reference.empty()) throw InputError("metrics: empty reference");
  if (reference.channels() != 3) throw InputError("metrics: frames must have 3 channels (RGB)");
  PreparedReference r;
  r.linear = &reference;
  r.display_settings = s.display;
  r.display = to_display(reference, s.display, ex);
  if (s.compute_flip)
    r.flip = flip_image(to_tonemapped_linear(reference, s.display, ex), s.flip.ppd, ex);
  r.gradient_energy = luma_gradient_energy(r.display, ex);
  return r;
}

const FrameMetrics& SequenceEvaluator::add_frame(const ImageF& output, const ImageF& reference,
                                                 const Mask* disoccluded, const ImageF* motion) {
  check_same_shape(output, reference, "metrics");
  if (output.channels() != 3) throw InputError("metrics: frames must have 3 channels (RGB)");
  return add_frame(output, prepare_reference(reference, s_, ex_), disoccluded, motion);
}

const FrameMetrics& SequenceEvaluator::add_frame(const ImageF& output,
                                                 const PreparedReference& prepared,
                                                 const Mask* disoccluded, const ImageF* motion) {
  AI_CHECK(prepared.linear != nullptr);
  const ImageF& reference = *prepared.linear;
  check_same_shape(output, reference, "metrics");
  if (output.channels() != 3) throw InputError("metrics: frames must have 3 channels (RGB)");
  // Prepared with other settings, it would score against another display transform.
  AI_CHECK(prepared.display_settings.exposure == s_.display.exposure &&
           prepared.display_settings.tonemap == s_.display.tonemap);
  AI_CHECK(!s_.compute_flip || (!prepared.flip.lab.empty() && prepared.flip.ppd == s_.flip.ppd));
  if (!prev_output_display_.empty() && !output.same_shape(prev_output_display_))
    throw InputError(fmt::format("metrics: frame {} is {}x{}, earlier frames {}x{}", frames_.size(),
                                 output.width(), output.height(), prev_output_display_.width(),
                                 prev_output_display_.height()));
  FrameMetrics f;
  f.frame = int(frames_.size());
  DisplaySettings out_display = s_.display;
  if (s_.output_display_referred) out_display.tonemap = false;  // only the sRGB step is left
  const ImageF out_d = to_display(output, out_display, ex_);
  const ImageF& ref_d = prepared.display;
  set_image_scores(f, ref_d, out_d, reference, output, s_.ssim, ex_);
  if (s_.output_display_referred) f.psnr_linear = f.psnr_linear_peak = kNaN;
  f.flip = s_.compute_flip
               ? ldr_flip(prepared.flip, to_tonemapped_linear(output, out_display, ex_), ex_).mean
               : kNaN;
  f.sharpness = sharpness_ratio(out_d, prepared.gradient_energy, ex_);
  f.temporal_error =
      prev_output_display_.empty()
          ? kNaN
          : temporal_error_frame(prev_output_display_, out_d, prev_reference_display_, ref_d, ex_);
  update_ages(f.frame, disoccluded, motion);
  if (disoccluded && f.frame >= s_.warmup) ghosting_.add(out_d, ref_d, age_.age(), ex_);
  prev_output_display_ = out_d;
  prev_reference_display_ = ref_d;
  frames_.push_back(f);
  return frames_.back();
}

void SequenceEvaluator::update_ages(int frame, const Mask* disoccluded, const ImageF* motion) {
  if (disoccluded) {
    has_masks_ = true;
    age_.update(*disoccluded, motion, ex_);
  } else if (has_masks_) {
    throw InputError(
        fmt::format("metrics: frame {} has no disocclusion mask, earlier ones did", frame));
  }
}

const FrameMetrics& SequenceEvaluator::skip_frame(const Mask* disoccluded, const ImageF* motion) {
  FrameMetrics f;
  f.frame = int(frames_.size());
  if (f.frame >= s_.warmup)
    throw InputError(
        fmt::format("metrics: frame {} has no output, but it is past the warm-up ({} frames)",
                    f.frame, s_.warmup));
  f.psnr = f.psnr_luma = f.psnr_linear = f.psnr_linear_peak = f.ssim = f.ssim_luma = f.flip =
      f.sharpness = f.temporal_error = kNaN;
  update_ages(f.frame, disoccluded, motion);
  prev_output_display_ = ImageF();
  prev_reference_display_ = ImageF();
  frames_.push_back(f);
  return frames_.back();
}

SequenceMetrics SequenceEvaluator::result() const {
  SequenceMetrics r;
  r.frames = frames_;
  SequenceSummary& s = r.summary;
  const int w = s_.warmup;
  s.frames = int(frames_.size());
  s.frames_measured = std::max(0, s.frames - w);
  s.psnr = mean_from(frames_, w, [](const FrameMetrics& f) { return f.psnr; });
  s.psnr_luma = mean_from(frames_, w, [](const FrameMetrics& f) { return f.psnr_luma; });
  s.psnr_linear = mean_from(frames_, w, [](const FrameMetrics& f) { return f.psnr_linear; });
  s.ssim = mean_from(frames_, w, [](const FrameMetrics& f) { return f.ssim; });
  s.ssim_luma = mean_from(frames_, w, [](const FrameMetrics& f) { return f.ssim_luma; });
  s.flip = mean_from(frames_, w, [](const FrameMetrics& f) { return f.flip; });
  s.sharpness = mean_from(frames_, w, [](const FrameMetrics& f) { return f.sharpness; });
  // e(t) compares frames t-1 and t: both measured only for t > warmup.
  s.temporal_error = mean_from(frames_, std::max(w + 1, 1),
                               [](const FrameMetrics& f) { return f.temporal_error; });
  if (has_masks_) s.ghosting = ghosting_.curve();
  return r;
}

SequenceMetrics evaluate_sequence(const std::vector<ImageF>& output,
                                  const std::vector<ImageF>& reference,
                                  const std::vector<Mask>& masks,
                                  const std::vector<ImageF>& motions, const MetricsSettings& s,
                                  const Exec& ex) {
  if (output.size() != reference.size())
    throw InputError(fmt::format("metrics: output has {} frames, reference {}", output.size(),
                                 reference.size()));
  if (!masks.empty() && masks.size() != output.size())
    throw InputError(fmt::format("metrics: {} masks for {} frames", masks.size(), output.size()));
  if (!motions.empty() && motions.size() != output.size())
    throw InputError(
        fmt::format("metrics: {} motion images for {} frames", motions.size(), output.size()));
  SequenceEvaluator ev(s, ex);
  for (size_t t = 0; t < output.size(); ++t)
    ev.add_frame(output[t], reference[t], masks.empty() ? nullptr : &masks[t],
                 motions.empty() ? nullptr : &motions[t]);
  return ev.result();
}

PairMetrics compare_images(const ImageF& reference, const ImageF& test, DynamicRange range,
                           const MetricsSettings& s, const Exec& ex) {
  s.validate();
  check_same_shape(reference, test, "compare");
  if (reference.channels() != 3) throw InputError("compare: images must have 3 channels (RGB)");
  PairMetrics m;
  m.width = reference.width();
  m.height = reference.height();
  m.range = range;
  m.ppd = s.flip.ppd;
  DisplaySettings display = s.display;
  if (range == DynamicRange::kLdr) display.tonemap = false;  // already display-referred
  set_image_scores(m, to_display(reference, display, ex), to_display(test, display, ex), reference,
                   test, s.ssim, ex);
  m.flip = range == DynamicRange::kHdr ? hdr_flip(reference, test, s.flip, ex)
                                       : ldr_flip(reference, test, s.flip.ppd, ex);
  return m;
}

std::string format_pair_metrics(const PairMetrics& m) {
  const bool hdr = m.range == DynamicRange::kHdr;
  std::string s;
  s += fmt::format("size                 {}x{}\n", m.width, m.height);
  s += fmt::format("values               {}\n",
                   hdr ? "linear HDR; display = Reinhard tonemap + sRGB encoding"
                       : "sRGB-encoded LDR; display = the sRGB values");
  s += fmt::format("PSNR display RGB     {}\n", db(m.psnr));
  s += fmt::format("PSNR display luma    {}\n", db(m.psnr_luma));
  s += fmt::format("PSNR linear          {} (peak {:.6g} = max of reference)\n", db(m.psnr_linear),
                   m.psnr_linear_peak);
  s += fmt::format("SSIM display RGB     {:.6f}\n", m.ssim);
  s += fmt::format("SSIM display luma    {:.6f}\n", m.ssim_luma);
  if (hdr)
    s += fmt::format("HDR-FLIP mean        {:.6f} (ppd {:.4f}, exposures {:.4f} to {:.4f}, {})\n",
                     m.flip.mean, m.ppd, m.flip.start_exposure, m.flip.stop_exposure,
                     m.flip.num_exposures);
  else
    s += fmt::format("LDR-FLIP mean        {:.6f} (ppd {:.4f})\n", m.flip.mean, m.ppd);
  return s;
}

nlohmann::json json_number(double v) {
  if (std::isnan(v)) return nullptr;
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

void to_json(nlohmann::json& j, const FrameMetrics& m) {
  j = nlohmann::json{{"frame", m.frame},
                     {"psnr", json_number(m.psnr)},
                     {"psnr_luma", json_number(m.psnr_luma)},
                     {"psnr_linear", json_number(m.psnr_linear)},
                     {"psnr_linear_peak", json_number(m.psnr_linear_peak)},
                     {"ssim", json_number(m.ssim)},
                     {"ssim_luma", json_number(m.ssim_luma)},
                     {"flip", json_number(m.flip)},
                     {"sharpness", json_number(m.sharpness)},
                     {"temporal_error", json_number(m.temporal_error)}};
}

void to_json(nlohmann::json& j, const GhostingCurve& c) {
  nlohmann::json err = nlohmann::json::array(), n = nlohmann::json::array();
  for (double e : c.error) err.push_back(json_number(e));
  for (uint64_t v : c.samples) n.push_back(v);
  j = nlohmann::json{{"error_by_age", err}, {"samples_by_age", n}};
}

void to_json(nlohmann::json& j, const SequenceSummary& s) {
  j = nlohmann::json{{"frames", s.frames},
                     {"frames_measured", s.frames_measured},
                     {"psnr", json_number(s.psnr)},
                     {"psnr_luma", json_number(s.psnr_luma)},
                     {"psnr_linear", json_number(s.psnr_linear)},
                     {"ssim", json_number(s.ssim)},
                     {"ssim_luma", json_number(s.ssim_luma)},
                     {"flip", json_number(s.flip)},
                     {"sharpness", json_number(s.sharpness)},
                     {"temporal_error", json_number(s.temporal_error)}};
  if (!s.ghosting.error.empty()) j["ghosting"] = s.ghosting;
}

void to_json(nlohmann::json& j, const SequenceMetrics& m) {
  j = nlohmann::json{{"summary", m.summary}, {"frames", m.frames}};
}

void to_json(nlohmann::json& j, const PairMetrics& m) {
  const bool hdr = m.range == DynamicRange::kHdr;
  j = nlohmann::json{{"width", m.width},
                     {"height", m.height},
                     {"range", hdr ? "hdr" : "ldr"},
                     {"psnr", json_number(m.psnr)},
                     {"psnr_luma", json_number(m.psnr_luma)},
                     {"psnr_linear", json_number(m.psnr_linear)},
                     {"psnr_linear_peak", json_number(m.psnr_linear_peak)},
                     {"ssim", json_number(m.ssim)},
                     {"ssim_luma", json_number(m.ssim_luma)},
                     {"flip_mode", hdr ? "HDR-FLIP" : "LDR-FLIP"},
                     {"flip", json_number(m.flip.mean)},
                     {"ppd", m.ppd}};
  if (hdr) {
    j["flip_start_exposure"] = m.flip.start_exposure;
    j["flip_stop_exposure"] = m.flip.stop_exposure;
    j["flip_num_exposures"] = m.flip.num_exposures;
  }
}

}  // namespace afterimage::metrics
