// Quality of an output sequence against its reference (DESIGN.md §4): per-frame metrics, their
// means after a warm-up, the ghosting curve; and the one-pair comparison of
// `afterimage compare`. Everything serialises to JSON (nlohmann::json) with +-infinity written
// as the strings "inf" / "-inf" and NaN (undefined, e.g. no frame measured) as null.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "core/image.h"
#include "core/parallel.h"
#include "metrics/display.h"
#include "metrics/flip.h"
#include "metrics/ssim.h"
#include "metrics/temporal.h"

namespace afterimage::metrics {

struct MetricsSettings {
  DisplaySettings display;  // tonemap + sRGB encoding before every LDR metric
  SsimSettings ssim;
  FlipSettings flip;         // ppd of LDR-FLIP (and exposures if HDR-FLIP is used)
  bool compute_flip = true;  // per-frame LDR-FLIP of the tonemapped frames (the costliest metric)
  // Frames 0..warmup-1 are excluded from the means (history still converging).
  int warmup = 8;
  int ghost_max_age = 8;  // k = 1..ghost_max_age of the ghosting curve
  // The outputs are display images already (PNG / JPEG decoded from sRGB: tonemapped linear
  // values in [0, 1], e.g. `resolve --out-format png`): only the reference goes through the
  // tonemap, so both are compared after the same display transform, assuming the output was
  // encoded with this one (Reinhard at display.exposure). Linear-HDR PSNR is then undefined.
  bool output_display_referred = false;
  void validate() const;  // throws SettingsError
};

// One frame. Display metrics use display.h; NaN = not computed / undefined.
struct FrameMetrics {
  int frame = 0;
  double psnr = 0;         // RGB display values, peak 1 (dB; +inf if identical)
  double psnr_luma = 0;    // Rec.709 luma of display values
  double psnr_linear = 0;  // linear HDR, peak = psnr_linear_peak (max of reference)
  double psnr_linear_peak = 1;
  double ssim = 0;  // mean over R, G, B of display values
  double ssim_luma = 0;
  double flip = 0;            // LDR-FLIP mean of the tonemapped (linear, [0,1]) frames
  double sharpness = 0;       // gradient-energy ratio output / reference
  double temporal_error = 0;  // e(t) vs frame t-1; NaN for frame 0
};

// The scoring rule of every command (eval, compare): metrics of non-finite pixels are
// meaningless, so such an image is refused with InputError "<what>: non-finite color at
// pixel (x, y)" naming the first one.
void require_finite(const ImageF& img, const std::string& what);

// Means of FrameMetrics fields over frames t >= warmup (temporal error: t > warmup).
struct SequenceSummary {
  int frames = 0;           // frames in the sequence
  int frames_measured = 0;  // frames t >= warmup
  double psnr = 0, psnr_luma = 0, psnr_linear = 0, ssim = 0, ssim_luma = 0, flip = 0, sharpness = 0,
         temporal_error = 0;
  GhostingCurve ghosting;  // empty if no disocclusion masks were given
};

struct SequenceMetrics {
  std::vector<FrameMetrics> frames;
  SequenceSummary summary;
};

// A reference frame prepared once for scoring any number of outputs against it: its display
// image, its half of LDR-FLIP and its luma gradient energy (sharpness). Scores against it
// equal those against the plain reference, bit for bit.
struct PreparedReference {
  const ImageF* linear = nullptr;    // the reference itself: not owned, it must outlive this
  DisplaySettings display_settings;  // what it was prepared with (checked by add_frame)
  ImageF display;
  FlipImage flip;  // empty without MetricsSettings::compute_flip
  double gradient_energy = 0.0;
};
PreparedReference prepare_reference(const ImageF& reference, const MetricsSettings& s,
                                    const Exec& ex = {});

// Streams a sequence frame by frame (only the previous frame is kept), so long sequences at
// full resolution need not be in memory.
class SequenceEvaluator {
 public:
  explicit SequenceEvaluator(const MetricsSettings& s = {}, const Exec& ex = {});
  // Adds the next frame (linear HDR output and reference, 3 planes). `disoccluded`: pixels
  // disoccluded at this frame (disocclusion_mask), `motion`: this frame's motion (2 planes),
  // both optional; ghosting is reported if any frame had a mask.
  const FrameMetrics& add_frame(const ImageF& output, const ImageF& reference,
                                const Mask* disoccluded = nullptr, const ImageF* motion = nullptr);
  // The same against a reference prepared with this evaluator's settings (prepare_reference).
  const FrameMetrics& add_frame(const ImageF& output, const PreparedReference& reference,
                                const Mask* disoccluded = nullptr, const ImageF* motion = nullptr);
  // A warm-up frame (index < MetricsSettings::warmup) with no output to score: its scores are
  // NaN (no mean reads them; plots leave a gap), while its mask and motion still age the
  // disocclusions as add_frame's would, so the ghosting measured after the warm-up is the
  // same. The next frame's temporal error, which needs this one, is NaN. InputError at or
  // after the warm-up, where a mean would read the frame.
  const FrameMetrics& skip_frame(const Mask* disoccluded = nullptr, const ImageF* motion = nullptr);
  SequenceMetrics result() const;

 private:
  // The disocclusion ages after `frame`'s mask (InputError if it has none while an earlier
  // frame had one).
  void update_ages(int frame, const Mask* disoccluded, const ImageF* motion);
  MetricsSettings s_;
  Exec ex_;
  std::vector<FrameMetrics> frames_;
  ImageF prev_output_display_, prev_reference_display_;
  DisocclusionAge age_;
  GhostingAccumulator ghosting_;
  bool has_masks_ = false;
};

// All frames at once. masks / motions may be empty (no ghosting / static ages).
SequenceMetrics evaluate_sequence(const std::vector<ImageF>& output,
                                  const std::vector<ImageF>& reference,
                                  const std::vector<Mask>& masks = {},
                                  const std::vector<ImageF>& motions = {},
                                  const MetricsSettings& s = {}, const Exec& ex = {});

// ---- One pair (`afterimage compare`) ---------------------------------------------------
// What the pixel values mean, as the official FLIP tool decides from the file type:
// kHdr: linear scene-referred radiance (EXR) -> tonemapped display metrics, HDR-FLIP;
// kLdr: decoded display-referred values in [0,1] (PNG, sRGB-decoded by io::read_rgb) ->
//       display metrics on the sRGB re-encoding (no tonemap), LDR-FLIP.
enum class DynamicRange { kLdr, kHdr };

struct PairMetrics {
  int width = 0, height = 0;
  DynamicRange range = DynamicRange::kLdr;
  double psnr = 0, psnr_luma = 0, psnr_linear = 0, psnr_linear_peak = 1;
  double ssim = 0, ssim_luma = 0;
  FlipResult flip;  // error map + mean; exposure range for HDR-FLIP
  float ppd = 0;
};

PairMetrics compare_images(const ImageF& reference, const ImageF& test, DynamicRange range,
                           const MetricsSettings& s = {}, const Exec& ex = {});
// Human-readable multi-line report of a pair (what `afterimage compare` prints).
std::string format_pair_metrics(const PairMetrics& m);

// JSON. Numbers: finite as is, +-inf as "inf"/"-inf", NaN as null.
nlohmann::json json_number(double v);
void to_json(nlohmann::json& j, const FrameMetrics& m);
void to_json(nlohmann::json& j, const GhostingCurve& c);
void to_json(nlohmann::json& j, const SequenceSummary& s);
void to_json(nlohmann::json& j, const SequenceMetrics& m);
void to_json(nlohmann::json& j, const PairMetrics& m);  // without the error map

}  // namespace afterimage::metrics
