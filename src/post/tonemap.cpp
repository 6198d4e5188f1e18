#include "post/tonemap.h"

#include <fmt/format.h>

#include <algorithm>

#include "core/color.h"
#include "core/error.h"

namespace afterimage::post {

namespace {

constexpr EnumNames<TonemapOperator, 5> kOperatorNames{{
    {TonemapOperator::Reinhard, "reinhard"},
    {TonemapOperator::ReinhardExtended, "reinhard_extended"},
    {TonemapOperator::AcesFitted, "aces_fitted"},
    {TonemapOperator::AgX, "agx"},
    {TonemapOperator::Clamp, "clamp"},
}};

constexpr float kInset = 0.1f;

float sanitize(float v) {
  return std::isfinite(v) && v > 0.0f ? v : 0.0f;
}

}  // namespace

const ParamTable<TonemapSettings>& TonemapSettings::params() {
  static const ParamTable<TonemapSettings> kTable = [] {  // immutable once built
    using S = TonemapSettings;
    ParamTable<S> t("tonemap");
    t.add_float("exposure", &S::exposure, 1e-6f, 1e6f, "multiplies linear radiance first");
    t.add_enum("operator", &S::op, kOperatorNames,
               "curve from linear radiance to display: reinhard, reinhard_extended, "
               "aces_fitted (Narkowicz 2015), agx (AgX-like), clamp");
    t.add_float("white", &S::white, 1e-3f, 1e6f,
                "reinhard_extended: radiance mapped to 1 (Reinhard et al. 2002 Eq. 4)");
    t.add_bool("srgb", &S::srgb, "encode with the sRGB transfer function");
    return t;
  }();
  return kTable;
}
void TonemapSettings::set_assignment(const std::string& assignment) {
  params().set_assignment(*this, assignment);
}
void TonemapSettings::validate() const {
  params().validate(*this);
}
const char* to_string(TonemapOperator op) {
  return enum_name(kOperatorNames, op);
}

Vec3f agx_inset(Vec3f c) {
  const float keep = 1.0f - 2.0f * kInset;
  return {keep * c.x + kInset * (c.y + c.z), keep * c.y + kInset * (c.x + c.z),
          keep * c.z + kInset * (c.x + c.y)};
}

Vec3f agx_outset(Vec3f c) {
  // Inverse of M = (1 - 3a) I + a J (J: all ones): M^-1 = (I - a / (1 - 3a + 3a) J) / (1 - 3a)
  // = (I - a J) / (1 - 3a), since J^2 = 3 J and 1 - 3a + 3a = 1.
  const float s = 1.0f / (1.0f - 3.0f * kInset), sum = c.x + c.y + c.z;
  return {s * (c.x - kInset * sum), s * (c.y - kInset * sum), s * (c.z - kInset * sum)};
}

Vec3f agx(Vec3f c) {
  const Vec3f in = agx_inset(c);
  const Vec3f curved{agx_curve(agx_log_encode(in.x)), agx_curve(agx_log_encode(in.y)),
                     agx_curve(agx_log_encode(in.z))};
  const Vec3f out = agx_outset(curved);
  return {std::clamp(out.x, 0.0f, 1.0f), std::clamp(out.y, 0.0f, 1.0f),
          std::clamp(out.z, 0.0f, 1.0f)};
}

Vec3f tonemap_pixel(Vec3f linear, const TonemapSettings& s) {
  const Vec3f x{sanitize(linear.x) * s.exposure, sanitize(linear.y) * s.exposure,
                sanitize(linear.z) * s.exposure};
  Vec3f y;
  switch (s.op) {
    case TonemapOperator::Reinhard:
      y = {reinhard_curve(x.x), reinhard_curve(x.y), reinhard_curve(x.z)};
      break;
    case TonemapOperator::ReinhardExtended:
      y = {reinhard_extended_curve(x.x, s.white), reinhard_extended_curve(x.y, s.white),
           reinhard_extended_curve(x.z, s.white)};
      break;
    case TonemapOperator::AcesFitted:
      y = {aces_fitted_curve(x.x), aces_fitted_curve(x.y), aces_fitted_curve(x.z)};
      break;
    case TonemapOperator::AgX:
      y = agx(x);
      break;
    case TonemapOperator::Clamp:
      y = {std::min(x.x, 1.0f), std::min(x.y, 1.0f), std::min(x.z, 1.0f)};
      break;
  }
  if (s.srgb) y = {srgb_encode(y.x), srgb_encode(y.y), srgb_encode(y.z)};
  return y;
}

ImageF tonemap(const ImageF& linear, const TonemapSettings& s, const Exec& exec) {
  s.validate();
  if (linear.channels() != 3)
    throw InputError(
        fmt::format("tonemap: the image has {} planes, RGB (3) expected", linear.channels()));
  ImageF out(linear.width(), linear.height(), 3);
  parallel_rows(exec, linear.height(), [&](int y) {
    for (int x = 0; x < linear.width(); ++x) {
      const Vec3f v =
          tonemap_pixel({linear.at(x, y, 0), linear.at(x, y, 1), linear.at(x, y, 2)}, s);
      out.at(x, y, 0) = v.x;
      out.at(x, y, 1) = v.y;
      out.at(x, y, 2) = v.z;
    }
  });
  return out;
}

}  // namespace afterimage::post
