// Bloom (issue 12; seed 004: "a very bright region bleeding into neighbouring pixels"): light
// scattered in the lens and sensor, approximated by a blur over a mip chain (Jimenez, "Next
// Generation Post Processing in Call of Duty: Advanced Warfare", SIGGRAPH 2014 course):
//
//   source P   = the light that scatters: the whole HDR image (threshold 0, the default), or a
//                soft-knee bright pass of it (Unity / UE "threshold" + "soft knee")
//   mips       = P downsampled by 2 per level with the 13-tap filter (Karis average on the
//                first downsample only, optional: it suppresses fireflies)
//   light  L   = sum over levels k = 1..N of (1/N) * mip_k brought back to full resolution by
//                the 3x3 tent upsample, accumulated smallest to largest (acc_k = mip_k / N +
//                up(acc_{k+1}); L = up(acc_1))
//   output     = hdr - intensity * P + intensity * scale * L
//
// Every filter's weights sum to 1, so the chain is normalised: sum(L) = sum(P). With
// threshold 0 (P = hdr) and scale 1 the output is (1 - intensity) hdr + intensity L and
// conserves energy: the light that blooms is taken from where it came from.
//
// Edge policy ("conserve"): taps outside the image read 0, and every texel of a level is
// pre-scaled by (its share in the interior) / (its share in the in-bounds outputs), i.e. each
// texel distributes exactly its energy over the in-bounds pixels of the next level. Light that
// a lens would scatter out of the frame is folded back into it near the border, and nothing
// comes in from outside: sum(L) = sum(P) up to float rounding (clamp-to-edge would instead
// gain or lose energy at every border in proportion to the border pixels' values).
//
// Non-finite pixels (any channel) and negative values scatter no light (0 in P); the pixel keeps
// its value (a NaN stays a NaN at that pixel only: repair is core/sanitize.h's job earlier in
// the pipeline). Stateless; bit-identical for any thread count.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "core/image.h"
#include "core/parallel.h"
#include "core/params.h"
#include "post/row_pass.h"

namespace afterimage::post {

struct BloomSettings {
  // Mix weight of the scattered light: out = hdr - intensity P + intensity scale L. 0 = off.
  float intensity = 0.05f;
  // Mip levels below full resolution (level k is 2^k times smaller); the blur is a mixture of
  // widths ~2^k pixels, k = 1..levels, each weighted 1/levels.
  int levels = 6;
  // Bright-pass threshold on max(R, G, B); 0 = threshold-less (the whole image scatters).
  float threshold = 0.0f;
  // Soft-knee width as a fraction of the threshold (k = knee * threshold).
  float knee = 0.5f;
  // Gain on the scattered light; 1 conserves energy, > 1 adds glow.
  float scale = 1.0f;
  // Karis average (1 / (1 + luma) weights per 2x2 block group) on the first downsample only:
  // suppresses fireflies, and therefore does not conserve their energy (off by default).
  bool karis = false;

  static const ParamTable<BloomSettings>& params();
  void validate() const { params().validate(*this); }
  bool operator==(const BloomSettings&) const = default;
};

// ---------------------------------------------------------------------------------------
// Per-pixel math (pure; unit-tested on hand values).

// Soft-knee bright-pass response of a brightness x (Unity's post-processing "Prefilter", the
// UE4 bloom threshold): with k = knee * threshold,
//   x <= t - k          : 0
//   t - k < x < t + k   : (x - t + k)^2 / (4k)        (quadratic; C1 at both ends)
//   x >= t + k          : x - t
// k = 0 gives the hard threshold max(x - t, 0). The response is <= x for 0 <= knee <= 1.
inline float soft_knee_response(float x, float threshold, float knee) {
  const float k = knee * threshold;
  if (k <= 0.0f) return std::max(x - threshold, 0.0f);
  const float s = std::clamp(x - threshold + k, 0.0f, 2.0f * k);
  return std::max(s * s / (4.0f * k), x - threshold);
}

// The bright-pass factor applied to a whole pixel: response(max channel) / max channel, so the
// pixel's hue is kept (Unity). 0 for a pixel whose brightest channel is <= 0.
inline float soft_knee_bright_pass(float max_channel, float threshold, float knee) {
  if (!(max_channel > 0.0f)) return 0.0f;
  return soft_knee_response(max_channel, threshold, knee) / max_channel;
}

// Karis average weight (Karis, "Real Shading in Unreal Engine 4" / Jimenez 2014 slide
// "partial Karis average"): 1 / (1 + luma). Luma of a block average, >= 0.
inline float karis_weight(float luma) {
  return 1.0f / (1.0f + luma);
}

// The 13 bilinear taps of Jimenez's downsample, in texels of the source around the output
// texel's center c (an even texel corner, so each tap averages a 2x2 block):
//   A(-2,-2) B(0,-2) C(2,-2)
//        D(-1,-1) E(1,-1)
//   F(-2, 0) G(0, 0) H(2, 0)
//        I(-1, 1) J(1, 1)
//   K(-2, 2) L(0, 2) M(2, 2)
enum Tap13 { kA, kB, kC, kD, kE, kF, kG, kH, kI, kJ, kK, kL, kM };
inline constexpr int kTap13Offset[13][2] = {{-2, -2}, {0, -2}, {2, -2}, {-1, -1}, {1, -1},
                                            {-2, 0},  {0, 0},  {2, 0},  {-1, 1},  {1, 1},
                                            {-2, 2},  {0, 2},  {2, 2}};
// The five overlapping 2x2-tap groups of the 13 taps and their weights (Jimenez 2014): the
// inner group D E I J weighs 0.5, each of the four outer groups 0.125.
inline constexpr int kTap13Group[5][4] = {
    {kD, kE, kI, kJ}, {kA, kB, kF, kG}, {kB, kC, kG, kH}, {kF, kG, kK, kL}, {kG, kH, kL, kM}};
inline constexpr float kTap13GroupWeight[5] = {0.5f, 0.125f, 0.125f, 0.125f, 0.125f};

// Plain 13-tap downsample of one channel: sum over groups of weight * group mean, i.e.
// G 0.125, D E I J 0.125, B F H L 0.0625, A C K M 0.03125 (sum 1).
inline float downsample_13tap(const std::array<float, 13>& t) {
  float s = 0.0f;
  for (int g = 0; g < 5; ++g) {
    const auto& q = kTap13Group[g];
    s += kTap13GroupWeight[g] * (0.25f * ((t[q[0]] + t[q[1]]) + (t[q[2]] + t[q[3]])));
  }
  return s;
}

// The 13-tap downsample with the partial Karis average (Jimenez 2014, "first downsample
// only, on each 2x2 block group"): group weights are multiplied by karis_weight(luma of the
// group mean) and renormalised. `luma[i]` is the luma of tap i; the weights are shared by
// every channel. Returns the five normalised group weights (sum 1) to apply to group means.
inline std::array<float, 5> karis_group_weights(const std::array<float, 13>& luma) {
  std::array<float, 5> w{};
  float sum = 0.0f;
  for (int g = 0; g < 5; ++g) {
    const auto& q = kTap13Group[g];
    const float m = 0.25f * ((luma[q[0]] + luma[q[1]]) + (luma[q[2]] + luma[q[3]]));
    w[g] = kTap13GroupWeight[g] * karis_weight(std::max(m, 0.0f));
    sum += w[g];
  }
  for (float& v : w) v /= sum;
  return w;
}
inline float downsample_13tap_weighted(const std::array<float, 13>& t,
                                       const std::array<float, 5>& group_weight) {
  float s = 0.0f;
  for (int g = 0; g < 5; ++g) {
    const auto& q = kTap13Group[g];
    s += group_weight[g] * (0.25f * ((t[q[0]] + t[q[1]]) + (t[q[2]] + t[q[3]])));
  }
  return s;
}

// 3x3 tent upsample by 2 (Jimenez 2014): the tent (1 2 1)/4 per axis with a radius of one
// low-resolution texel, each of its 9 taps a bilinear fetch at the high-resolution pixel's
// center. Per axis the high pixel p has its center at low coordinate p/2 + 1/4, so the tent
// convolved with the bilinear weights (1/4, 3/4) gives 4 low texels with weights
//   p even (m = p/2):       texels m-2, m-1, m, m+1  weights (1, 5, 7, 3) / 16
//   p odd  (m = (p-1)/2):   texels m-1, m, m+1, m+2  weights (3, 7, 5, 1) / 16
// Each phase sums to 1 and every low texel gives 1 in total to each phase, so sums scale by
// exactly 2 per axis. The 2D filter is the product of the two axes' weights.
inline constexpr float kTentUpEven[4] = {1.0f / 16, 5.0f / 16, 7.0f / 16, 3.0f / 16};
inline constexpr float kTentUpOdd[4] = {3.0f / 16, 7.0f / 16, 5.0f / 16, 1.0f / 16};
// First low texel of high pixel p's 4 taps.
inline int tent_upsample_first_tap(int p) {
  return (p & 1) ? (p - 1) / 2 - 1 : p / 2 - 2;
}
inline const float* tent_upsample_weights(int p) {
  return (p & 1) ? kTentUpOdd : kTentUpEven;
}
// One axis: sum of the 4 low texels v[0..3] (from tent_upsample_first_tap) times the weights.
inline float tent_upsample_3x3(const float v[4], int p) {
  const float* w = tent_upsample_weights(p);
  return (w[0] * v[0] + w[1] * v[1]) + (w[2] * v[2] + w[3] * v[3]);
}

// ---------------------------------------------------------------------------------------
// The pass. All of them throw SettingsError for settings out of range and InputError for an
// empty image.

// The light that scatters, P: max(hdr, 0) per channel (threshold 0), else that times
// soft_knee_bright_pass(max channel); 0 for every channel of a pixel with a non-finite one.
ImageF bloom_source(const ImageF& hdr, const BloomSettings& s, const Exec& exec = {});

// The downsample chain of `source`: mips[0] = source, mips[k] = 13-tap downsample of
// mips[k-1] (Karis on k = 1 only, if s.karis), sizes ceil(previous / 2), k = 0..levels.
std::vector<ImageF> bloom_mips(const ImageF& source, const BloomSettings& s, const Exec& exec = {});

// The scattered light L of `source` (the "bloom image"): the normalised mip-chain blur above,
// sum(L) = sum(source). Linear in `source` unless s.karis.
ImageF bloom_blur(const ImageF& source, const BloomSettings& s, const Exec& exec = {});

// out = hdr - intensity P + intensity scale L (see the top of this file).
ImageF bloom_composite(const ImageF& hdr, const ImageF& source, const ImageF& light,
                       const BloomSettings& s, const Exec& exec = {});

// The whole pass: bloom_composite(hdr, P, bloom_blur(P)) with P = bloom_source(hdr). Returns a
// copy when intensity is 0.
ImageF bloom(const ImageF& hdr, const BloomSettings& s, const Exec& exec = {});
// bloom with `then` run on each output row once it is final (post/row_pass.h): the same values
// as `then` over every row of bloom(hdr), without a second pass over the frame.
ImageF bloom(const ImageF& hdr, const BloomSettings& s, const Exec& exec, const RowPass& then);
// The same values, written over hdr's planes: the caller gives up hdr (left empty or holding
// its old values; read it no more), and the composite reads and writes each row's lines once
// instead of reading them and filling a second frame (9a75778, `post.chain`). Each task
// makes its RowFn of `then` before it writes a row, and a RowPass reads its input no more once
// one is made (post/row_pass.h), so writing over hdr changes nothing it reads. `then` may be
// empty.
ImageF bloom(ImageF&& hdr, const BloomSettings& s, const Exec& exec, const RowPass& then);

// The pass written plainly, pixel by pixel (bloom_reference.cpp): the specification the entry
// points above compute bit for bit on their fast schedule, and what they run with
// Exec::simd false (--simd off). The same checks and errors. The whole pass is
// bloom_mip_chain_reference so that it does not read as a plain form of bloom_reference_fft.
ImageF bloom_source_reference(const ImageF& hdr, const BloomSettings& s, const Exec& exec = {});
std::vector<ImageF> bloom_mips_reference(const ImageF& source, const BloomSettings& s,
                                         const Exec& exec = {});
ImageF bloom_blur_reference(const ImageF& source, const BloomSettings& s, const Exec& exec = {});
ImageF bloom_composite_reference(const ImageF& hdr, const ImageF& source, const ImageF& light,
                                 const BloomSettings& s, const Exec& exec = {});
ImageF bloom_mip_chain_reference(const ImageF& hdr, const BloomSettings& s, const Exec& exec = {});
// With `then` on each finished row: its input_done is called first and no input rows are
// handed to it. The ImageF&& overload writes over hdr's planes, as bloom's does.
ImageF bloom_mip_chain_reference(const ImageF& hdr, const BloomSettings& s, const Exec& exec,
                                 const RowPass& then);
ImageF bloom_mip_chain_reference(ImageF&& hdr, const BloomSettings& s, const Exec& exec,
                                 const RowPass& then);

// A radius beyond which the chain's impulse response is exactly 0: 6 * 2^levels pixels.
int bloom_psf_radius(const BloomSettings& s);

// The chain's point-spread function: bloom_blur (without Karis, which is not linear) of a unit
// impulse at pixel (r, r) of a black (2r+1)^2 one-channel image, r = bloom_psf_radius. Sums to
// 1. The chain is shift-variant (its stride-2 grids), so this is its response at one phase.
ImageF bloom_psf(const BloomSettings& s, const Exec& exec = {});

// Reference blur by FFT convolution (FFTW, double precision, FFTW_ESTIMATE plans made under a
// mutex): every channel of `source` convolved with `psf` (one channel, odd square size, its
// center at the middle pixel), with the same edge policy as the chain applied once: each
// pixel's light is divided by the share of the PSF that falls inside the image, so
// sum(result) = sum(source). Comparing it with bloom_blur measures the chain's approximation
// error (shift variance, per-level edge folding) for the chain's own PSF, or how far the chain
// is from another PSF (a Gaussian, a measured lens).
ImageF bloom_reference_fft(const ImageF& source, const ImageF& psf, const Exec& exec = {});

}  // namespace afterimage::post
