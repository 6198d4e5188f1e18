// FLIP: a perceptual difference evaluator for alternating images.
//  * LDR-FLIP: Andersson, Nilsson, Akenine-Möller, Oskarsson, Åström, Fairchild,
//    "FLIP: A Difference Evaluator for Alternating Images", HPG 2020 (equations cited below as
//    [FLIP §n]).
//  * HDR-FLIP: Andersson, Nilsson, Shirley, Akenine-Möller, "Visualizing Errors in Rendered
//    High Dynamic Range Images", EG 2021, and Ray Tracing Gems II ch. 19 "Visualizing and
//    Communicating Errors in Rendered Images" ([HDR-FLIP]).
//
// Written from the papers. Where the papers leave a numerical choice open (filter radii, the
// separable form of the CSF filters, the normalisation of the feature filters, the exposure
// range and tone curve of HDR-FLIP) we follow the conventions of NVIDIA's reference
// implementation (FLIP v1.6), because the point of the metric is that numbers agree across
// tools; tests/metrics_flip_test.cpp checks every official test vector in
// tests/data/flip (means within 1e-4, every error-map pixel within 1e-3).
//
// Inputs are linear RGB (DESIGN.md §3). LDR-FLIP clamps its inputs to [0, 1]: feed it the
// *decoded* values of an sRGB image (io::read_rgb decodes PNGs), or a tonemapped image.
// HDR-FLIP takes unclamped linear radiance.
//
// All arithmetic of the per-pixel pipeline is float32 in a fixed order, compiled without FMA
// contraction (see CMakeLists.txt), so the error maps are bit-identical for any thread count.
#pragma once

#include <limits>
#include <vector>

#include "core/image.h"
#include "core/math.h"
#include "core/parallel.h"

namespace afterimage::metrics {

// Pixels per degree of visual angle for an observer at `distance_m` from a monitor
// `monitor_width_m` wide showing `resolution_x` pixels across [FLIP §4].
float flip_ppd(float distance_m, float resolution_x, float monitor_width_m);
// 0.7 m from a 0.7 m wide 4K monitor: 67.0206451 ppd, the default of the paper and tool.
float flip_default_ppd();
// Accepted viewing conditions (SettingsError outside): see check_ppd in flip.cpp.
inline constexpr float kMinPpd = 1.0f, kMaxPpd = 1000.0f;

struct FlipSettings {
  float ppd = flip_default_ppd();  // viewing condition; > 0
  // HDR-FLIP exposure range in stops. NaN / 0 = computed from the reference image
  // ([HDR-FLIP] §3: start = log2(x*/Ymax), stop = log2(x*/Ymedian), count = max(2,
  // ceil(stop - start))).
  float start_exposure = std::numeric_limits<float>::quiet_NaN();
  float stop_exposure = std::numeric_limits<float>::quiet_NaN();
  int num_exposures = 0;
  // Throws SettingsError on an impossible combination.
  void validate() const;
};

struct FlipResult {
  ImageF error;       // 1 plane, per-pixel FLIP error in [0, 1]
  double mean = 0.0;  // mean of `error` over every pixel (no border exclusion), summed in double
  // HDR-FLIP only (empty / zero for LDR-FLIP):
  ImageF exposure;  // 1 plane: i/(N-1) of the first exposure reaching the max; 0 if all zero
  float start_exposure = 0.0f, stop_exposure = 0.0f;
  int num_exposures = 0;
};

// LDR-FLIP of two linear-RGB images in [0, 1] (values outside are clamped).
FlipResult ldr_flip(const ImageF& reference, const ImageF& test, float ppd = flip_default_ppd(),
                    const Exec& ex = {});

// One image's half of LDR-FLIP at one ppd: the Hunt-adjusted CIELab of its CSF-filtered
// colour (3 planes) and its edge and point feature magnitudes (2 planes). A reference scored
// against many test images is prepared once: ldr_flip(flip_image(r, ppd), t) equals
// ldr_flip(r, t, ppd) bit for bit.
struct FlipImage {
  ImageF lab, features;
  float ppd = 0.0f;
};
// `linear`: linear RGB, clamped to [0, 1] here.
FlipImage flip_image(const ImageF& linear, float ppd = flip_default_ppd(), const Exec& ex = {});
FlipResult ldr_flip(const FlipImage& reference, const ImageF& test, const Exec& ex = {});

// HDR-FLIP of two linear-RGB HDR images: LDR-FLIP of ACES-tonemapped exposures, per-pixel max.
FlipResult hdr_flip(const ImageF& reference, const ImageF& test, const FlipSettings& s = {},
                    const Exec& ex = {});

struct ExposureRange {
  float start = 0.0f, stop = 0.0f;
  int count = 0;
};
// The automatic exposure range of HDR-FLIP, from the reference image only.
ExposureRange hdr_flip_exposure_range(const ImageF& reference);

// Per-pixel building blocks, exposed for unit tests. Float32, operation order fixed.
namespace flip {

// Linear Rec.709 RGB <-> CIE XYZ (D65).
Vec3f linear_rgb_to_xyz(Vec3f rgb);
Vec3f xyz_to_linear_rgb(Vec3f xyz);
// YCxCz: the linearised opponent space of CIELab, where the CSFs are applied [FLIP §4.1].
Vec3f xyz_to_ycxcz(Vec3f xyz);
Vec3f ycxcz_to_xyz(Vec3f ycxcz);
Vec3f xyz_to_cielab(Vec3f xyz);
// xyz_to_cielab in two steps for whole rows: CIELab's f(t) of XYZ / white in place on lanes
// (cube roots as exp(log(t) / 3), within 1.9e-7 relative of the power law), then Lab from f.
void cielab_f_in_place(float* t, int n, const Exec& ex);
Vec3f cielab_from_f(float fx, float fy, float fz);
// Hunt effect: chroma scales with lightness, a* b* multiplied by 0.01 L* [FLIP eq. 2].
Vec3f hunt_adjust(Vec3f lab);
// HyAB distance: city block in L, Euclidean in (a, b) [FLIP eq. 3].
float hyab(Vec3f a, Vec3f b);
// cmax of [FLIP eq. 4]: (HyAB distance between Hunt-adjusted green and blue)^0.7, the largest
// colour distance within the sRGB gamut.
float max_color_distance();
// The colour-error mapping of [FLIP eq. 4]: d = HyAB^0.7 compressed to [0, 1]; distances
// below 0.4 cmax take 95% of the range.
float remap_color_difference(float d, float cmax);
// The ACES filmic curve of HDR-FLIP (Narkowicz fit, 0.6 pre-exposure folded in).
float aces_tonemap(float x);

// 1-D filter taps (radius r => 2r + 1 taps).
int spatial_filter_radius(float ppd);
int feature_filter_radius(float ppd);
// CSF taps [FLIP eq. 1]: g(x) = a sqrt(pi/b) exp(-pi^2 x^2 / b), x in degrees. Channel 0: Y,
// 1: Cx, 2 and 3: the two Gaussians of Cz, in square-root form so that their separable
// products sum to the 2-D kernel. Each 2-D kernel sums to 1.
std::vector<std::vector<float>> spatial_filter_taps(float ppd);
// Feature taps [FLIP §4.2]: Gaussian (sum 1), first and second derivative (positive and
// negative parts normalised to +1 / -1), std dev 0.5 * 0.082 * ppd.
std::vector<std::vector<float>> feature_filter_taps(float ppd);

}  // namespace flip
}  // namespace afterimage::metrics
