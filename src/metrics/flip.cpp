// LDR-FLIP and HDR-FLIP (see flip.h for the papers). The image pipeline of [FLIP Fig. 2]:
//
//   colour:  linear RGB -> YCxCz -> CSF filter (separable) -> linear RGB, clamp -> CIELab
//            -> Hunt -> HyAB -> ^0.7 -> remap to [0,1]                              = dE_c
//   feature: Y of YCxCz, normalised to [0,1] -> 1st / 2nd Gaussian derivatives (edges,
//            points) -> |difference of magnitudes| -> (max / sqrt 2)^0.5            = dE_f
//   FLIP = dE_c ^ (1 - dE_f)                                                     [FLIP eq. 8]
//
// Both filters are separable and run as a horizontal pass into intermediate planes and a
// vertical pass that also evaluates the per-pixel formulas. Borders clamp to the edge.
// Every pixel's sums are accumulated in tap order -r..r in float32, so row-parallel
// execution is bit-identical to serial execution.
#include "metrics/flip.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include <hwy/contrib/math/math-inl.h>

#include "core/error.h"
#include "core/lanes.h"

namespace afterimage::metrics {

namespace {

// pi as the reference implementation rounds it (float), so filter taps agree bit-for-bit.
constexpr float kPi = 3.14159265358979f;

// Constants of [FLIP §4]: colour-difference exponent qc, the knee of the colour remap
// (pc of cmax maps to pt), feature filter width w (degrees), feature exponent qf.
constexpr float kQc = 0.7f;
constexpr float kPc = 0.4f;
constexpr float kPt = 0.95f;
constexpr float kFeatureWidth = 0.082f;
constexpr float kQf = 0.5f;

// CSF parameters [FLIP Table 1]: per opponent channel (Y, Cx, Cz) a sum of two Gaussians
// a1 sqrt(pi/b1) exp(-pi^2 x^2/b1) + a2 sqrt(pi/b2) exp(-pi^2 x^2/b2).
constexpr float kA1[3] = {1.0f, 1.0f, 34.1f};
constexpr float kB1[3] = {0.0047f, 0.0053f, 0.04f};
constexpr float kA2[3] = {0.0f, 0.0f, 13.5f};
constexpr float kB2[3] = {1.0e-5f, 1.0e-5f, 0.025f};

// D65 reference white in XYZ (Y = 1) and its reciprocal.
constexpr Vec3f kWhite{0.950428545f, 1.000000000f, 1.088900371f};
constexpr Vec3f kInvWhite{1.052156925f, 1.000000000f, 0.918357670f};

float clamp01(float v) {
  return std::min(std::max(v, 0.0f), 1.0f);
}
Vec3f clamp01(Vec3f v) {
  return {clamp01(v.x), clamp01(v.y), clamp01(v.z)};
}

// CSF Gaussian in the "alternative form" of [FLIP eq. 1]; x2 = x^2 in degrees^2.
float csf_gaussian(float x2, float a, float b) {
  const float pi_sq = kPi * kPi;
  return a * std::sqrt(kPi / b) * std::exp(-pi_sq * x2 / b);
}
// The same Gaussian with sqrt of its amplitude: the outer product of two such 1-D filters is
// the 2-D Gaussian, which lets the two-Gaussian Cz kernel be applied as two separable passes.
float csf_gaussian_sqrt_amplitude(float x2, float a, float b) {
  const float pi_sq = kPi * kPi;
  return std::sqrt(a * std::sqrt(kPi / b)) * std::exp(-pi_sq * x2 / b);
}

// ACES coefficients (a, b, c, d, e, f) of (a x^2 + b x + c) / (d x^2 + e x + f).
constexpr float kAces[6] = {0.6f * 0.6f * 2.51f, 0.6f * 0.03f, 0.0f,
                            0.6f * 0.6f * 2.43f, 0.6f * 0.59f, 0.14f};

// Edge-replicated copy of one row, padded by r on both sides, so the tap loops below are
// branch-free and vectorise.
void pad_row(const float* src, int w, int r, std::vector<float>& out) {
  out.resize(size_t(w + 2 * r));
  for (int i = 0; i < r; ++i) out[size_t(i)] = src[0];
  std::copy(src, src + w, out.begin() + r);
  for (int i = 0; i < r; ++i) out[size_t(w + r + i)] = src[w - 1];
}

// acc[x] = sum_k taps[k] * padded[x + k], accumulated in k order (the order of the scalar
// reference loop), for x in [0, w).
void convolve_padded_row(const std::vector<float>& padded, const std::vector<float>& taps, int w,
                         float* acc) {
  std::fill(acc, acc + w, 0.0f);
  for (size_t k = 0; k < taps.size(); ++k) {
    const float t = taps[k];
    const float* p = padded.data() + k;
    for (int x = 0; x < w; ++x) acc[x] += t * p[x];
  }
}

// acc[x] = sum_k taps[k] * plane[clamp(y + k - r)][x], in k order.
void convolve_column(const float* plane, int w, int h, int y, const std::vector<float>& taps,
                     float* acc) {
  const int r = int(taps.size() / 2);
  std::fill(acc, acc + w, 0.0f);
  for (int k = 0; k < int(taps.size()); ++k) {
    const int yy = std::min(std::max(0, y + k - r), h - 1);
    const float t = taps[size_t(k)];
    const float* p = plane + size_t(yy) * w;
    for (int x = 0; x < w; ++x) acc[x] += t * p[x];
  }
}

// x^y on lanes as exp(y log x) for x >= 0, with std::pow's values where the logarithm has none
// (x = 0: 0 for y > 0, 1 for y = 0, +inf for y < 0). The cube roots come within 1.9e-7
// relative of the power law (FlipBasics.CielabCubeRootsOnLanesMatchThePowerLaw), and the FLIP
// tests hold the maps to the official implementation; the scalar powf calls (nine a pixel)
// had been ~15% of a warm demo's CPU.
template <class D>
HWY_INLINE V<D> pow_lanes(D d, V<D> x, V<D> y) {
  const V<D> zero = hn::Zero(d);
  const V<D> safe = hn::Max(x, hn::Set(d, std::numeric_limits<float>::min()));
  const V<D> p = hn::Exp(d, hn::Mul(y, hn::Log(d, safe)));
  const V<D> at_zero =
      hn::IfThenElse(hn::Gt(y, zero), zero,
                     hn::IfThenElse(hn::Eq(y, zero), hn::Set(d, 1.0f),
                                    hn::Set(d, std::numeric_limits<float>::infinity())));
  return hn::IfThenElse(hn::Gt(x, zero), p, at_zero);
}
// v[i] = pow(v[i], y) for i in [0, n).
void pow_in_place(float* v, float y, int n, const Exec& ex) {
  for_each_lane_block(ex, n, [&](auto d, int i) {
    hn::StoreU(pow_lanes(d, hn::LoadU(d, v + i), hn::Set(d, y)), d, v + i);
  });
}
// v[i] = pow(v[i], y[i]) for i in [0, n).
void pow_in_place(float* v, const float* y, int n, const Exec& ex) {
  for_each_lane_block(ex, n, [&](auto d, int i) {
    hn::StoreU(pow_lanes(d, hn::LoadU(d, v + i), hn::LoadU(d, y + i)), d, v + i);
  });
}

// One image's check (flip_image, and the test image against a prepared reference).
void check_rgb(const ImageF& img, const char* what) {
  if (img.channels() != 3)
    throw InputError(
        fmt::format("{}: expected a 3-channel RGB image, got {} channels", what, img.channels()));
  if (img.empty()) throw InputError(fmt::format("{}: empty image", what));
}

void check_pair(const ImageF& reference, const ImageF& test, const char* what) {
  if (reference.channels() != 3 || test.channels() != 3)
    throw InputError(fmt::format("{}: expected 3-channel RGB images, got {} and {} channels", what,
                                 reference.channels(), test.channels()));
  if (!reference.same_shape(test))
    throw InputError(fmt::format("{}: image sizes differ ({}x{} vs {}x{})", what, reference.width(),
                                 reference.height(), test.width(), test.height()));
  if (reference.empty()) throw InputError(fmt::format("{}: empty image", what));
}

// Linear RGB clamped to [0,1] -> YCxCz planes.
ImageF to_ycxcz(const ImageF& rgb, const Exec& ex) {
  const int w = rgb.width(), h = rgb.height();
  ImageF out(w, h, 3);
  parallel_rows(ex, h, [&](int y) {
    const float *r = rgb.row(0, y), *g = rgb.row(1, y), *b = rgb.row(2, y);
    float *o0 = out.row(0, y), *o1 = out.row(1, y), *o2 = out.row(2, y);
    for (int x = 0; x < w; ++x) {
      const Vec3f c = flip::xyz_to_ycxcz(flip::linear_rgb_to_xyz(clamp01(Vec3f{r[x], g[x], b[x]})));
      o0[x] = c.x;
      o1[x] = c.y;
      o2[x] = c.z;
    }
  });
  return out;
}

// The colour pipeline's per-image half [FLIP §4.1]: the image CSF-filtered in YCxCz, back to
// linear RGB clamped to [0,1], then Hunt-adjusted CIELab (3 planes). Horizontal pass -> 4
// planes (Y, Cx, Cz * g1, Cz * g2); vertical pass + the conversions a row at a time (the
// cube roots on lanes).
ImageF hunt_lab(const ImageF& ycc, float ppd, const Exec& ex) {
  const int w = ycc.width(), h = ycc.height();
  const auto taps = flip::spatial_filter_taps(ppd);
  const int r = int(taps[0].size() / 2);
  ImageF mid(w, h, 4);
  parallel_rows(ex, h, [&](int y) {
    std::vector<float> pad;
    pad_row(ycc.row(0, y), w, r, pad);
    convolve_padded_row(pad, taps[0], w, mid.row(0, y));
    pad_row(ycc.row(1, y), w, r, pad);
    convolve_padded_row(pad, taps[1], w, mid.row(1, y));
    pad_row(ycc.row(2, y), w, r, pad);
    convolve_padded_row(pad, taps[2], w, mid.row(2, y));
    convolve_padded_row(pad, taps[3], w, mid.row(3, y));
  });
  ImageF lab = ImageF::uninitialized(w, h, 3);
  parallel_rows(ex, h, [&](int y) {
    std::vector<float> f(size_t(w) * 4);
    for (int c = 0; c < 4; ++c)
      convolve_column(mid.plane(c), w, h, y, taps[size_t(c)], f.data() + size_t(c) * w);
    // CIELab's f(t) of XYZ / white (cube roots on lanes), then Lab and Hunt per pixel.
    std::vector<float> t(size_t(w) * 3);
    for (int x = 0; x < w; ++x) {
      const Vec3f c{f[size_t(x)], f[size_t(w + x)], f[size_t(2 * w + x)] + f[size_t(3 * w + x)]};
      const Vec3f rgb = clamp01(flip::xyz_to_linear_rgb(flip::ycxcz_to_xyz(c)));
      const Vec3f xyz = flip::linear_rgb_to_xyz(rgb) * kInvWhite;
      for (int k = 0; k < 3; ++k) t[size_t(k) * size_t(w) + size_t(x)] = xyz[k];
    }
    flip::cielab_f_in_place(t.data(), 3 * w, ex);
    float* o[3] = {lab.row(0, y), lab.row(1, y), lab.row(2, y)};
    for (int x = 0; x < w; ++x) {
      const auto at = [&](int k) { return t[size_t(k) * size_t(w) + size_t(x)]; };
      const Vec3f v = flip::hunt_adjust(flip::cielab_from_f(at(0), at(1), at(2)));
      for (int k = 0; k < 3; ++k) o[k][x] = v[k];
    }
  });
  return lab;
}

// The feature pipeline's per-image half [FLIP §4.2]: edge and point magnitudes of the
// normalised luminance (2 planes). Horizontal pass -> (d/dx G, d2/dx2 G, G); the vertical
// pass applies G to the first two and d/dy G, d2/dy2 G to the third.
ImageF feature_magnitudes(const ImageF& ycc, float ppd, const Exec& ex) {
  const int w = ycc.width(), h = ycc.height();
  const auto taps = flip::feature_filter_taps(ppd);  // 0: G, 1: G', 2: G''
  const int r = int(taps[0].size() / 2);
  ImageF mid(w, h, 3);
  parallel_rows(ex, h, [&](int y) {
    // Y of YCxCz back to [0,1] luminance: (Y + 16) / 116, as (Y / 116 + 16 / 116).
    const float one_over_116 = 1.0f / 116.0f, sixteen_over_116 = 16.0f / 116.0f;
    std::vector<float> lum(static_cast<size_t>(w)), pad;
    const float* src = ycc.row(0, y);
    for (int x = 0; x < w; ++x) lum[size_t(x)] = src[x] * one_over_116 + sixteen_over_116;
    pad_row(lum.data(), w, r, pad);
    convolve_padded_row(pad, taps[1], w, mid.row(0, y));
    convolve_padded_row(pad, taps[2], w, mid.row(1, y));
    convolve_padded_row(pad, taps[0], w, mid.row(2, y));
  });
  ImageF out = ImageF::uninitialized(w, h, 2);
  parallel_rows(ex, h, [&](int y) {
    // Planes: 0 = dx, 1 = ddx, 2 = dy, 3 = ddy.
    std::vector<float> f(size_t(w) * 4);
    convolve_column(mid.plane(0), w, h, y, taps[0], f.data());
    convolve_column(mid.plane(1), w, h, y, taps[0], f.data() + w);
    convolve_column(mid.plane(2), w, h, y, taps[1], f.data() + 2 * size_t(w));
    convolve_column(mid.plane(2), w, h, y, taps[2], f.data() + 3 * size_t(w));
    float *edge = out.row(0, y), *point = out.row(1, y);
    for (int x = 0; x < w; ++x) {
      const auto magnitude = [&](int a, int b) {
        const float u = f[size_t(a * w + x)], v = f[size_t(b * w + x)];
        return std::sqrt(u * u + v * v);
      };
      edge[x] = magnitude(0, 2);
      point[x] = magnitude(1, 3);
    }
  });
  return out;
}

// LDR-FLIP's error map from both images' halves: dE_c per pixel [FLIP §4.1] (HyAB of the Lab,
// ^qc on lanes, remap), dE_f [FLIP §4.2] (the larger magnitude difference), then the FLIP
// error dE_c ^ (1 - dE_f) [FLIP eq. 8].
ImageF flip_error(const FlipImage& ref, const FlipImage& test, const Exec& ex) {
  const int w = ref.lab.width(), h = ref.lab.height();
  const float cmax = flip::max_color_distance();
  const float norm = 1.0f / std::sqrt(2.0f);
  ImageF out = ImageF::uninitialized(w, h, 1);
  parallel_rows(ex, h, [&](int y) {
    float* o = out.row(0, y);
    const auto lab = [&](const ImageF& img, int x) {
      return Vec3f{img.row(0, y)[x], img.row(1, y)[x], img.row(2, y)[x]};
    };
    for (int x = 0; x < w; ++x) o[x] = flip::hyab(lab(ref.lab, x), lab(test.lab, x));
    pow_in_place(o, kQc, w, ex);
    for (int x = 0; x < w; ++x) o[x] = flip::remap_color_difference(o[x], cmax);
    const float *re = ref.features.row(0, y), *rp = ref.features.row(1, y);
    const float *te = test.features.row(0, y), *tp = test.features.row(1, y);
    std::vector<float> exponent(static_cast<size_t>(w));
    for (int x = 0; x < w; ++x) {
      const float edge = std::abs(re[x] - te[x]);
      const float point = std::abs(rp[x] - tp[x]);
      static_assert(kQf == 0.5f, "the feature's power is a square root");
      const float feature = std::sqrt(norm * std::max(edge, point));
      exponent[size_t(x)] = 1.0f - feature;
    }
    pow_in_place(o, exponent.data(), w, ex);  // FLIP = dE_c ^ (1 - dE_f)
  });
  return out;
}

// LDR-FLIP on images already clamped to [0,1] (or that will be clamped by to_ycxcz).
ImageF ldr_flip_map(const ImageF& reference, const ImageF& test, float ppd, const Exec& ex) {
  return flip_error(flip_image(reference, ppd, ex), flip_image(test, ppd, ex), ex);
}

double plane_mean(const ImageF& img, const Exec& ex) {
  const int w = img.width();
  const double sum = parallel_sum_rows(ex, img.height(), [&](int y) {
    const float* p = img.row(0, y);
    double s = 0.0;
    for (int x = 0; x < w; ++x) s += p[x];
    return s;
  });
  return sum / double(img.plane_size());
}

void check_ppd(float ppd) {
  // Filter radii grow linearly with ppd (about 3.6 px per 67 ppd for the CSF); the bound keeps
  // them small enough to fit int and to run in seconds, and covers any real display: a 4K
  // monitor at 0.7 m is 67 ppd, a phone at 30 cm about 100.
  if (!(ppd >= kMinPpd && ppd <= kMaxPpd))
    throw SettingsError(
        fmt::format("flip: ppd must be in [{}, {}] pixels per degree "
                    "(default {:.2f}), got {}",
                    kMinPpd, kMaxPpd, flip_default_ppd(), ppd));
}

}  // namespace

float flip_ppd(float distance_m, float resolution_x, float monitor_width_m) {
  return distance_m * (resolution_x / monitor_width_m) * (kPi / 180.0f);
}
float flip_default_ppd() {
  return flip_ppd(0.7f, 3840.0f, 0.7f);
}

void FlipSettings::validate() const {
  check_ppd(ppd);
  if (num_exposures < 0)
    throw SettingsError(
        fmt::format("flip: num_exposures must be >= 0 (0 = automatic), got {}", num_exposures));
  const bool has_start = !std::isnan(start_exposure), has_stop = !std::isnan(stop_exposure);
  if ((has_start && !std::isfinite(start_exposure)) || (has_stop && !std::isfinite(stop_exposure)))
    throw SettingsError("flip: exposures must be finite (or NaN for automatic)");
  if (has_start && has_stop && start_exposure > stop_exposure)
    throw SettingsError(fmt::format("flip: start exposure {} is larger than stop exposure {}",
                                    start_exposure, stop_exposure));
}

namespace flip {

Vec3f linear_rgb_to_xyz(Vec3f c) {
  // sRGB primaries, D65 white, as exact rationals.
  const float a11 = 10135552.0f / 24577794.0f, a12 = 8788810.0f / 24577794.0f,
              a13 = 4435075.0f / 24577794.0f;
  const float a21 = 2613072.0f / 12288897.0f, a22 = 8788810.0f / 12288897.0f,
              a23 = 887015.0f / 12288897.0f;
  const float a31 = 1425312.0f / 73733382.0f, a32 = 8788810.0f / 73733382.0f,
              a33 = 70074185.0f / 73733382.0f;
  return {a11 * c.x + a12 * c.y + a13 * c.z, a21 * c.x + a22 * c.y + a23 * c.z,
          a31 * c.x + a32 * c.y + a33 * c.z};
}

Vec3f xyz_to_linear_rgb(Vec3f c) {
  return {3.241003275f * c.x + -1.537398934f * c.y + -0.498615861f * c.z,
          -0.969224334f * c.x + 1.875930071f * c.y + 0.041554224f * c.z,
          0.055639423f * c.x + -0.204011202f * c.y + 1.057148933f * c.z};
}

Vec3f xyz_to_ycxcz(Vec3f xyz) {
  const Vec3f n = xyz * kInvWhite;
  return {116.0f * n.y - 16.0f, 500.0f * (n.x - n.y), 200.0f * (n.y - n.z)};
}

Vec3f ycxcz_to_xyz(Vec3f c) {
  const float y = (c.x + 16.0f) / 116.0f;
  const float cx = c.y / 500.0f, cz = c.z / 200.0f;
  return Vec3f{y + cx, y, y - cz} * kWhite;
}

// CIELab's f(t): t^(1/3) above delta^3, else the linear segment t / (3 delta^2) + 4/29
// (delta = 6/29), in float as the reference implementation evaluates it.
struct CielabF {
  static constexpr float kDelta = 6.0f / 29.0f;
  static constexpr float kDeltaSq = kDelta * kDelta;
  static constexpr float kDeltaCube = kDelta * kDeltaSq;
  static constexpr float kFactor = 1.0f / (3.0f * kDeltaSq);
  static constexpr float kTerm = 4.0f / 29.0f;
  static float scalar(float t) {
    return t > kDeltaCube ? std::pow(t, 1.0f / 3.0f) : kFactor * t + kTerm;
  }
};

void cielab_f_in_place(float* t, int n, const Exec& ex) {
  for_each_lane_block(ex, n, [&](auto d, int i) {
    const auto v = hn::LoadU(d, t + i);
    const auto cube_root = pow_lanes(d, v, hn::Set(d, 1.0f / 3.0f));
    const auto linear =
        hn::Add(hn::Mul(hn::Set(d, CielabF::kFactor), v), hn::Set(d, CielabF::kTerm));
    hn::StoreU(hn::IfThenElse(hn::Gt(v, hn::Set(d, CielabF::kDeltaCube)), cube_root, linear), d,
               t + i);
  });
}

Vec3f cielab_from_f(float fx, float fy, float fz) {
  return {116.0f * fy - 16.0f, 500.0f * (fx - fy), 200.0f * (fy - fz)};
}

Vec3f xyz_to_cielab(Vec3f xyz) {
  const Vec3f n = xyz * kInvWhite;
  return cielab_from_f(CielabF::scalar(n.x), CielabF::scalar(n.y), CielabF::scalar(n.z));
}

Vec3f hunt_adjust(Vec3f lab) {
  return {lab.x, 0.01f * lab.x * lab.y, 0.01f * lab.x * lab.z};
}

float hyab(Vec3f a, Vec3f b) {
  const float da = a.y - b.y, db = a.z - b.z;
  return std::abs(a.x - b.x) + std::sqrt(da * da + db * db);
}

float max_color_distance() {
  const Vec3f green = hunt_adjust(xyz_to_cielab(linear_rgb_to_xyz({0, 1, 0})));
  const Vec3f blue = hunt_adjust(xyz_to_cielab(linear_rgb_to_xyz({0, 0, 1})));
  return std::pow(hyab(green, blue), kQc);
}

float remap_color_difference(float d, float cmax) {
  const float pccmax = kPc * cmax;
  if (d < pccmax) return d * (kPt / pccmax);
  return kPt + ((d - pccmax) / (cmax - pccmax)) * (1.0f - kPt);
}

float aces_tonemap(float x) {
  const float x2 = x * x;
  return (x2 * kAces[0] + x * kAces[1] + kAces[2]) / (x2 * kAces[3] + x * kAces[4] + kAces[5]);
}

int spatial_filter_radius(float ppd) {
  check_ppd(ppd);
  // 3 standard deviations of the widest CSF Gaussian: sigma = sqrt(b / (2 pi^2)) degrees.
  float max_b = 0.0f;
  for (int c = 0; c < 3; ++c) max_b = std::max({max_b, kB1[c], kB2[c]});
  return int(std::ceil(3.0f * std::sqrt(max_b / (2.0f * (kPi * kPi))) * ppd));
}

int feature_filter_radius(float ppd) {
  check_ppd(ppd);
  const float sigma = 0.5f * kFeatureWidth * ppd;
  return int(std::ceil(3.0f * sigma));
}

std::vector<std::vector<float>> spatial_filter_taps(float ppd) {
  check_ppd(ppd);
  const int r = spatial_filter_radius(ppd), n = 2 * r + 1;
  const float dx = 1.0f / ppd;  // degrees per pixel
  std::vector<std::vector<float>> t(4, std::vector<float>(size_t(n)));
  float sum[4] = {0, 0, 0, 0};
  for (int i = 0; i < n; ++i) {
    const float x = float(i - r) * dx;
    const float x2 = x * x;
    t[0][size_t(i)] = csf_gaussian(x2, kA1[0], kB1[0]);
    t[1][size_t(i)] = csf_gaussian(x2, kA1[1], kB1[1]);
    t[2][size_t(i)] = csf_gaussian_sqrt_amplitude(x2, kA1[2], kB1[2]);
    t[3][size_t(i)] = csf_gaussian_sqrt_amplitude(x2, kA2[2], kB2[2]);
    for (int c = 0; c < 4; ++c) sum[c] += t[size_t(c)][size_t(i)];
  }
  // Y and Cx (a2 = 0: one Gaussian each): 1-D taps sum to 1, so the 2-D kernel does too.
  // Cz: the 2-D kernel is g1(x)g1(y) + g2(x)g2(y) with sum S1^2 + S2^2; one common factor
  // 1/sqrt(S1^2 + S2^2) on both 1-D filters normalises it to 1.
  const float norm_y = 1.0f / sum[0], norm_cx = 1.0f / sum[1];
  const float norm_cz = 1.0f / std::sqrt(sum[2] * sum[2] + sum[3] * sum[3]);
  for (int i = 0; i < n; ++i) {
    t[0][size_t(i)] *= norm_y;
    t[1][size_t(i)] *= norm_cx;
    t[2][size_t(i)] *= norm_cz;
    t[3][size_t(i)] *= norm_cz;
  }
  return t;
}

std::vector<std::vector<float>> feature_filter_taps(float ppd) {
  check_ppd(ppd);
  const float sigma = 0.5f * kFeatureWidth * ppd;
  const int r = feature_filter_radius(ppd), n = 2 * r + 1;
  std::vector<std::vector<float>> t(3, std::vector<float>(size_t(n)));
  float g_sum = 0, dg_pos = 0, dg_neg = 0, ddg_pos = 0, ddg_neg = 0;
  for (int i = 0; i < n; ++i) {
    const float x = float(i - r);
    const float g = std::exp(-(x * x) / (2.0f * sigma * sigma));
    const float dg = -x * g;                                 // d/dx, up to a scale
    const float ddg = (x * x / (sigma * sigma) - 1.0f) * g;  // d2/dx2, up to a scale
    g_sum += g;
    if (dg > 0.0f)
      dg_pos += dg;
    else
      dg_neg -= dg;
    if (ddg > 0.0f)
      ddg_pos += ddg;
    else
      ddg_neg -= ddg;
    t[0][size_t(i)] = g;
    t[1][size_t(i)] = dg;
    t[2][size_t(i)] = ddg;
  }
  // A unit step gives edge response 1 and a unit impulse point response 1 [FLIP §4.2].
  for (int i = 0; i < n; ++i) {
    float& g = t[0][size_t(i)];
    float& dg = t[1][size_t(i)];
    float& ddg = t[2][size_t(i)];
    g = g / g_sum;
    dg = dg / (dg > 0.0f ? dg_pos : dg_neg);
    ddg = ddg / (ddg > 0.0f ? ddg_pos : ddg_neg);
  }
  return t;
}

}  // namespace flip

FlipResult ldr_flip(const ImageF& reference, const ImageF& test, float ppd, const Exec& ex) {
  check_pair(reference, test, "ldr_flip");
  check_ppd(ppd);
  FlipResult res;
  res.error = ldr_flip_map(reference, test, ppd, ex);
  res.mean = plane_mean(res.error, ex);
  return res;
}

FlipImage flip_image(const ImageF& linear, float ppd, const Exec& ex) {
  check_rgb(linear, "flip_image");
  check_ppd(ppd);
  const ImageF ycc = to_ycxcz(linear, ex);
  return {hunt_lab(ycc, ppd, ex), feature_magnitudes(ycc, ppd, ex), ppd};
}

FlipResult ldr_flip(const FlipImage& reference, const ImageF& test, const Exec& ex) {
  if (reference.lab.channels() != 3 || reference.features.channels() != 2)
    throw InputError("ldr_flip: the reference was not prepared by flip_image");
  check_rgb(test, "ldr_flip");
  if (test.width() != reference.lab.width() || test.height() != reference.lab.height())
    throw InputError(fmt::format("ldr_flip: image sizes differ ({}x{} vs {}x{})",
                                 reference.lab.width(), reference.lab.height(), test.width(),
                                 test.height()));
  FlipResult res;
  res.error = flip_error(reference, flip_image(test, reference.ppd, ex), ex);
  res.mean = plane_mean(res.error, ex);
  return res;
}

ExposureRange hdr_flip_exposure_range(const ImageF& reference) {
  AI_CHECK(reference.channels() == 3 && !reference.empty());
  // x*: the input where the tone curve reaches 0.85, root of (a - t d) x^2 + (b - t e) x +
  // (c - t f) = 0 (larger root).
  const float t = 0.85f;
  const float a = kAces[0] - t * kAces[3], b = kAces[1] - t * kAces[4], c = kAces[2] - t * kAces[5];
  const float d1 = -0.5f * (b / a);
  const float x_star = d1 + std::sqrt(d1 * d1 - c / a);
  const size_t n = reference.plane_size();
  std::vector<float> lum(n);
  float y_max = -1e30f;
  const float *r = reference.plane(0), *g = reference.plane(1), *bl = reference.plane(2);
  for (size_t i = 0; i < n; ++i) {
    lum[i] = 0.2126f * r[i] + 0.7152f * g[i] + 0.0722f * bl[i];
    y_max = std::max(y_max, lum[i]);
  }
  // Median: the element at index floor(N/2) of the sorted luminances (upper middle).
  std::nth_element(lum.begin(), lum.begin() + ptrdiff_t(n / 2), lum.end());
  const float y_median = lum[n / 2];
  ExposureRange e;
  // [HDR-FLIP]: the brightest pixel lands at 0.85 after tonemapping at the first exposure,
  // the median pixel at the last.
  e.start = float(std::log2(double(x_star / y_max)));
  e.stop = float(std::log2(double(x_star / y_median)));
  e.count = int(std::max(2.0f, std::ceil(e.stop - e.start)));
  return e;
}

FlipResult hdr_flip(const ImageF& reference, const ImageF& test, const FlipSettings& s,
                    const Exec& ex) {
  check_pair(reference, test, "hdr_flip");
  s.validate();
  FlipResult res;
  if (std::isnan(s.start_exposure) || std::isnan(s.stop_exposure)) {
    const ExposureRange auto_range = hdr_flip_exposure_range(reference);
    res.start_exposure = std::isnan(s.start_exposure) ? auto_range.start : s.start_exposure;
    res.stop_exposure = std::isnan(s.stop_exposure) ? auto_range.stop : s.stop_exposure;
  } else {
    res.start_exposure = s.start_exposure;
    res.stop_exposure = s.stop_exposure;
  }
  if (res.start_exposure > res.stop_exposure)
    throw SettingsError(fmt::format("hdr_flip: start exposure {} is larger than stop exposure {}",
                                    res.start_exposure, res.stop_exposure));
  res.num_exposures = s.num_exposures > 0
                          ? s.num_exposures
                          : int(std::max(2.0f, std::ceil(res.stop_exposure - res.start_exposure)));

  const int w = reference.width(), h = reference.height();
  res.error = ImageF(w, h, 1, 0.0f);
  res.exposure = ImageF(w, h, 1, 0.0f);
  const int n = res.num_exposures;
  const float step = n > 1 ? (res.stop_exposure - res.start_exposure) / float(n - 1) : 0.0f;
  ImageF ref_ldr(w, h, 3), test_ldr(w, h, 3);
  for (int i = 0; i < n; ++i) {
    const float exposure = res.start_exposure + float(i) * step;
    const float scale = std::pow(2.0f, exposure);
    // Expose, tonemap, clamp; the result is treated as linear (no sRGB step) [HDR-FLIP].
    auto expose_tonemap = [&](const ImageF& src, ImageF& dst) {
      parallel_rows(ex, h, [&](int y) {
        for (int c = 0; c < 3; ++c) {
          const float* s_row = src.row(c, y);
          float* d_row = dst.row(c, y);
          for (int x = 0; x < w; ++x) d_row[x] = clamp01(flip::aces_tonemap(s_row[x] * scale));
        }
      });
    };
    expose_tonemap(reference, ref_ldr);
    expose_tonemap(test, test_ldr);
    const ImageF e = ldr_flip_map(ref_ldr, test_ldr, s.ppd, ex);
    const float exposure_index = n > 1 ? float(i) / float(n - 1) : 0.0f;
    // Per-pixel max over exposures; ties keep the first exposure.
    parallel_rows(ex, h, [&](int y) {
      const float* src = e.row(0, y);
      float* dst = res.error.row(0, y);
      float* exp_map = res.exposure.row(0, y);
      for (int x = 0; x < w; ++x)
        if (src[x] > dst[x]) {
          dst[x] = src[x];
          exp_map[x] = exposure_index;
        }
    });
  }
  res.mean = plane_mean(res.error, ex);
  return res;
}

}  // namespace afterimage::metrics
