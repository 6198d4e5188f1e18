// Tonemapping and display encoding (issue 12, "Tonemapping and output"): the last stage of a
// pipeline, mapping linear Rec.709 HDR radiance to display values in [0, 1]. A stateless
// per-pixel pass: exposure, one operator, then the sRGB transfer function (IEC 61966-2-1).
//
// Operators (each a pure function of one pixel, named after what it computes):
//  * reinhard: per channel x / (1 + x) (Reinhard et al. 2002, Eq. 3; the display transform of
//    the project's metrics, core/color.h).
//  * reinhard_extended: per channel x (1 + x / w^2) / (1 + x), which maps the white point w to
//    1 (Reinhard et al. 2002, Eq. 4), clipped above w.
//  * aces_fitted: Narkowicz's 2015 rational fit of the ACES RRT + sRGB ODT filmic curve,
//    (x (2.51 x + 0.03)) / (x (2.43 x + 0.59) + 0.14) per channel after his 0.6 pre-exposure
//    ("ACES Filmic Tone Mapping Curve", 2016 blog note), clipped to [0, 1].
//  * agx: AgX-like (after Sobotka's AgX, the Blender 4 default): the color is moved into an
//    "inset" RGB space whose primaries are pulled toward white (so very bright saturated
//    colors desaturate toward white instead of clipping per channel into hue shifts), encoded
//    as log2 exposure relative to middle grey 0.18 over [-10, +6.5] EV, shaped by a smooth
//    S-curve, and moved back (outset). Our own curve and inset amounts, not Blender's LUT.
//  * clamp: min(x, 1) (no tonemap: what a naive display does).
#pragma once

#include <hwy/contrib/math/math-inl.h>

#include <cmath>
#include <string>

#include "core/image.h"
#include "core/lanes.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/params.h"
#include "post/row_pass.h"

namespace afterimage::post {

enum class TonemapOperator : uint8_t { Reinhard, ReinhardExtended, AcesFitted, AgX, Clamp };

struct TonemapSettings {
  float exposure = 1.0f;  // multiplies linear radiance first
  TonemapOperator op = TonemapOperator::AcesFitted;
  float white = 4.0f;  // reinhard_extended: the radiance mapped to 1
  bool srgb = true;    // encode with the sRGB transfer function (false: linear display values)

  static const ParamTable<TonemapSettings>& params();
  void set_assignment(const std::string& assignment);
  void validate() const;
  bool operator==(const TonemapSettings&) const = default;
};

const char* to_string(TonemapOperator op);

// ---- Per-channel curves (x >= 0 after exposure) ------------------------------------------
// Written once on Highway lane vectors (core/lanes.h): the image pass runs them full-width and
// the scalar forms below run them at one lane, so both give the same bits (--simd off).

// The Reinhard ratios take radiance above 1e30 (where they are 1 in float) as 1e30: radiance the
// exposure took to infinity gave inf / inf, a NaN that the display clamp turned into black.
template <class D>
HWY_INLINE V<D> reinhard_curve(D d, V<D> x) {
  x = hn::Min(x, hn::Set(d, 1e30f));
  return hn::Div(x, hn::Add(hn::Set(d, 1.0f), x));
}
template <class D>
HWY_INLINE V<D> reinhard_extended_curve(D d, V<D> x, float white) {
  x = hn::Min(x, hn::Set(d, 1e30f));
  const V<D> one = hn::Set(d, 1.0f);
  const V<D> num = hn::Mul(x, hn::Add(one, hn::Div(x, hn::Set(d, white * white))));
  return hn::Min(one, hn::Div(num, hn::Add(one, x)));
}
// The 0.6 pre-exposure folded into the coefficients (u = 0.6 x: 2.51 u^2 = 0.9036 x^2, ...)
// and the polynomials as fused multiply-adds: 7 operations and the division a channel instead
// of 10 (tonemap is bound by its vector operations; the values move by float roundings).
// Radiance above 1e4 (where the curve is already above 1) is clamped first, so no square
// overflows into inf / inf.
template <class D>
HWY_INLINE V<D> aces_fitted_curve(D d, V<D> x) {
  x = hn::Min(x, hn::Set(d, 1e4f));
  const V<D> num = hn::Mul(x, hn::MulAdd(hn::Set(d, 2.51f * 0.36f), x, hn::Set(d, 0.03f * 0.6f)));
  const V<D> den = hn::MulAdd(x, hn::MulAdd(hn::Set(d, 2.43f * 0.36f), x, hn::Set(d, 0.59f * 0.6f)),
                              hn::Set(d, 0.14f));
  return saturate(d, hn::Div(num, den));
}

// AgX-like S-curve on the normalised log encoding t in [0, 1]: a logistic of slope k = 9
// around t0 = 0.606 (middle grey's position, 10 / 16.5), rescaled so that curve(0) = 0 and
// curve(1) = 1 exactly.
template <class D>
HWY_INLINE V<D> agx_curve(D d, V<D> t) {
  constexpr float k = 9.0f, t0 = 0.606f;
  // logistic(0) and logistic(1), the ends the curve is rescaled between.
  const float lo = 1.0f / (1.0f + std::exp(k * t0)), hi = 1.0f / (1.0f + std::exp(-k * (1 - t0)));
  const V<D> u = saturate(d, t);
  const V<D> s = hn::Div(
      hn::Set(d, 1.0f),
      hn::Add(hn::Set(d, 1.0f), hn::Exp(d, hn::Mul(hn::Set(d, -k), hn::Sub(u, hn::Set(d, t0))))));
  return hn::Div(hn::Sub(s, hn::Set(d, lo)), hn::Set(d, hi - lo));
}
// log2 exposure of v relative to middle grey, normalised from [-10, +6.5] EV to [0, 1].
template <class D>
HWY_INLINE V<D> agx_log_encode(D d, V<D> v) {
  constexpr float kMinEv = -10.0f, kMaxEv = 6.5f;
  const V<D> ev = hn::Log2(d, hn::Mul(hn::Max(v, hn::Set(d, 1e-10f)), hn::Set(d, 1.0f / 0.18f)));
  const V<D> c = hn::Min(hn::Max(ev, hn::Set(d, kMinEv)), hn::Set(d, kMaxEv));
  return hn::Mul(hn::Sub(c, hn::Set(d, kMinEv)), hn::Set(d, 1.0f / (kMaxEv - kMinEv)));
}
// sRGB power segment 1.055 v^(1/2.4) - 0.055 for v in [2^-9, 1] (the encode's range above
// 0.0031308) without a logarithm or an exponential: with v = 2^e m, m in [1, 2), it is (1.055
// 2^(5e/12)) m^(5/12), the first factor from a table over e in [-9, 0] and the second a polynomial
// p(y) = 1 + y q(y), y = m - 1 (exact), so v = 1 gives 1.055 exactly. q: degree 7, interpolated in
// long double at 8 Chebyshev nodes on [0, 1], coefficients rounded to float; p's float evaluation
// is within 7.6e-8 relative of m^(5/12) on every float m in [1, 2)
// (the whole encode: within 3.27 ulp of the power law in double on every float input, the
// exp/log form 9.02; PostTonemap.SrgbEncodeIsWithinFourUlpOfThePowerLaw). It replaced
// exp(log(v) / 2.4) through Highway's Exp and Log (a division each, ~40 operations against ~15):
// tonemap's CPU -31% on the 1080p bench frame; 8-bit output unchanged on the test scenes.
inline constexpr float kSrgbPowerOfExponent[16] = {
    0.0784133449f, 0.104669258f, 0.1397167f,   0.186499417f, 0.248946846f, 0.33230418f,
    0.443572849f,  0.592098713f, 0.790356994f, 1.05499995f,  0.0f,         0.0f,
    0.0f,          0.0f,         0.0f,         0.0f};  // 1.055 2^(5e/12), e = index - 9
template <class D>
HWY_INLINE V<D> srgb_power_segment(D d, V<D> v) {
  const hn::RebindToSigned<D> di;
  const VI<D> bits = hn::BitCast(di, v);
  const VI<D> index = hn::Sub(hn::ShiftRight<23>(bits), hn::Set(di, 127 - 9));  // e + 9
  V<D> scale;
  if constexpr (hn::MaxLanes(D()) >= 16) {  // the table in one register: a lane permute
    scale = hn::TableLookupLanes(hn::LoadU(d, kSrgbPowerOfExponent), hn::IndicesFromVec(d, index));
  } else if constexpr (hn::MaxLanes(D()) == 8) {
    // Two 8-entry lane permutes and a select: the same entries as the gather, which was ~15%
    // of tonemap's CPU on an AVX2 Zen 3 (AVX2's gather is microcoded).
    const VI<D> low3 = hn::And(index, hn::Set(di, 7));
    const V<D> lo =
        hn::TableLookupLanes(hn::LoadU(d, kSrgbPowerOfExponent), hn::IndicesFromVec(d, low3));
    const V<D> hi =
        hn::TableLookupLanes(hn::LoadU(d, kSrgbPowerOfExponent + 8), hn::IndicesFromVec(d, low3));
    scale = hn::IfThenElse(hn::RebindMask(d, hn::Gt(index, hn::Set(di, 7))), hi, lo);
  } else {
    scale = hn::GatherIndex(d, kSrgbPowerOfExponent, index);  // the same table entries
  }
  const V<D> m =
      hn::BitCast(d, hn::Or(hn::And(bits, hn::Set(di, 0x7FFFFF)), hn::Set(di, 0x3F800000)));
  const V<D> y = hn::Sub(m, hn::Set(d, 1.0f));
  V<D> q = hn::Set(d, -0.00113557465f);
  q = hn::MulAdd(q, y, hn::Set(d, 0.00601353124f));
  q = hn::MulAdd(q, y, hn::Set(d, -0.0152739454f));
  q = hn::MulAdd(q, y, hn::Set(d, 0.0267934706f));
  q = hn::MulAdd(q, y, hn::Set(d, -0.0407621227f));
  q = hn::MulAdd(q, y, hn::Set(d, 0.064062044f));
  q = hn::MulAdd(q, y, hn::Set(d, -0.1215242f));
  q = hn::MulAdd(q, y, hn::Set(d, 0.416666627f));
  // Multiply then subtract: one rounding (MulSub) is 0.5 ulp closer but not monotone.
  return hn::Sub(hn::Mul(scale, hn::MulAdd(q, y, hn::Set(d, 1.0f))), hn::Set(d, 0.055f));
}
// sRGB transfer function (IEC 61966-2-1) of a display value in [0, 1].
template <class D>
HWY_INLINE V<D> srgb_encode_unit(D d, V<D> v) {
  const V<D> lin = hn::Mul(hn::Set(d, 12.92f), v);
  const V<D> safe = hn::Max(v, hn::Set(d, 0.0031308f));  // the table's range for every lane
  const V<D> enc = srgb_power_segment(d, safe);
  return hn::IfThenElse(hn::Le(v, hn::Set(d, 0.0031308f)), lin, enc);
}
// The same of a display value clamped to [0, 1] first.
template <class D>
HWY_INLINE V<D> srgb_encode(D d, V<D> v) {
  return srgb_encode_unit(d, saturate(d, v));
}

// Scalar forms (one lane of the above), for tests and callers outside image passes.
inline float reinhard_curve(float x) {
  const OneTag d;
  return hn::GetLane(reinhard_curve(d, hn::Set(d, x)));
}
inline float reinhard_extended_curve(float x, float white) {
  const OneTag d;
  return hn::GetLane(reinhard_extended_curve(d, hn::Set(d, x), white));
}
inline float aces_fitted_curve(float x) {
  const OneTag d;
  return hn::GetLane(aces_fitted_curve(d, hn::Set(d, x)));
}
inline float agx_curve(float t) {
  const OneTag d;
  return hn::GetLane(agx_curve(d, hn::Set(d, t)));
}
inline float agx_log_encode(float v) {
  const OneTag d;
  return hn::GetLane(agx_log_encode(d, hn::Set(d, v)));
}
// The inset: each channel keeps 1 - 2a of itself and takes a of the other two (a = 0.1), a
// matrix whose rows sum to 1, so grey stays grey; the outset is its inverse.
inline constexpr float kAgxInset = 0.1f;
template <class D>
HWY_INLINE Color3<D> agx_inset(D d, const Color3<D>& c) {
  const V<D> keep = hn::Set(d, 1.0f - 2.0f * kAgxInset), a = hn::Set(d, kAgxInset);
  return {hn::Add(hn::Mul(keep, c.c0), hn::Mul(a, hn::Add(c.c1, c.c2))),
          hn::Add(hn::Mul(keep, c.c1), hn::Mul(a, hn::Add(c.c0, c.c2))),
          hn::Add(hn::Mul(keep, c.c2), hn::Mul(a, hn::Add(c.c0, c.c1)))};
}
// Inverse of M = (1 - 3a) I + a J (J: all ones): M^-1 = (I - a J) / (1 - 3a), since J^2 = 3 J.
template <class D>
HWY_INLINE Color3<D> agx_outset(D d, const Color3<D>& c) {
  const V<D> s = hn::Set(d, 1.0f / (1.0f - 3.0f * kAgxInset)), a = hn::Set(d, kAgxInset);
  const V<D> sum = hn::Add(hn::Add(c.c0, c.c1), c.c2);
  return {hn::Mul(s, hn::Sub(c.c0, hn::Mul(a, sum))), hn::Mul(s, hn::Sub(c.c1, hn::Mul(a, sum))),
          hn::Mul(s, hn::Sub(c.c2, hn::Mul(a, sum)))};
}
template <class D>
HWY_INLINE Color3<D> agx(D d, const Color3<D>& c) {
  const Color3<D> in = agx_inset(d, c);
  const Color3<D> curved{agx_curve(d, agx_log_encode(d, in.c0)),
                         agx_curve(d, agx_log_encode(d, in.c1)),
                         agx_curve(d, agx_log_encode(d, in.c2))};
  const Color3<D> out = agx_outset(d, curved);
  return {saturate(d, out.c0), saturate(d, out.c1), saturate(d, out.c2)};
}
Vec3f agx_inset(Vec3f c);
Vec3f agx_outset(Vec3f c);
Vec3f agx(Vec3f c);

// One pixel block: exposure, operator, sRGB encoding. Non-finite or negative input channels
// count as 0 (a display value is never NaN).
template <class D>
HWY_INLINE Color3<D> tonemap_pixel(D d, Color3<D> c, const TonemapSettings& s) {
  const V<D> e = hn::Set(d, s.exposure);
  auto clean = [&](V<D> v) {
    return hn::Mul(hn::IfThenElseZero(hn::And(hn::IsFinite(v), hn::Gt(v, hn::Zero(d))), v), e);
  };
  const Color3<D> x{clean(c.c0), clean(c.c1), clean(c.c2)};
  Color3<D> y;
  switch (s.op) {
    case TonemapOperator::Reinhard:
      y = {reinhard_curve(d, x.c0), reinhard_curve(d, x.c1), reinhard_curve(d, x.c2)};
      break;
    case TonemapOperator::ReinhardExtended:
      y = {reinhard_extended_curve(d, x.c0, s.white), reinhard_extended_curve(d, x.c1, s.white),
           reinhard_extended_curve(d, x.c2, s.white)};
      break;
    case TonemapOperator::AcesFitted:
      y = {aces_fitted_curve(d, x.c0), aces_fitted_curve(d, x.c1), aces_fitted_curve(d, x.c2)};
      break;
    case TonemapOperator::AgX:
      y = agx(d, x);
      break;
    case TonemapOperator::Clamp:
      y = {hn::Min(x.c0, hn::Set(d, 1.0f)), hn::Min(x.c1, hn::Set(d, 1.0f)),
           hn::Min(x.c2, hn::Set(d, 1.0f))};
      break;
  }
  // Every operator ends in [0, 1] (each clips or saturates, for any input, also one the exposure
  // took to infinity; tests: Tonemap.EveryOperatorIsMonotoneAndBounded,
  // Tonemap.SrgbEncodingAndNonFiniteInput): no second clamp.
  if (s.srgb) y = {srgb_encode_unit(d, y.c0), srgb_encode_unit(d, y.c1), srgb_encode_unit(d, y.c2)};
  return y;
}

// One pixel (the one-lane form of the block above).
Vec3f tonemap_pixel(Vec3f linear, const TonemapSettings& s);

// Every pixel of a 3-plane linear HDR image; returns display values in [0, 1]. SettingsError
// for bad settings, InputError for an image without 3 planes.
ImageF tonemap(const ImageF& linear, const TonemapSettings& s, const Exec& exec = {});

// One row: tonemap_pixel of in's 3 planes into out's (`width` pixels; out may be in).
void tonemap_row(const float* const* in, float* const* out, int width, const TonemapSettings& s,
                 const Exec& exec);
// tonemap as a RowPass (post/row_pass.h) on the rows of the pass before it: the same values as
// tonemap() of that pass's output. SettingsError for bad settings.
RowPass tonemap_row_pass(const TonemapSettings& s, const Exec& exec);

}  // namespace afterimage::post
