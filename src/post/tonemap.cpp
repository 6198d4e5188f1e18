#include "post/tonemap.h"

#include <fmt/format.h>

#include <algorithm>

#include "core/color.h"
#include "core/error.h"
#include "core/prefetch.h"

namespace afterimage::post {

namespace {

constexpr EnumNames<TonemapOperator, 5> kOperatorNames{{
    {TonemapOperator::Reinhard, "reinhard"},
    {TonemapOperator::ReinhardExtended, "reinhard_extended"},
    {TonemapOperator::AcesFitted, "aces_fitted"},
    {TonemapOperator::AgX, "agx"},
    {TonemapOperator::Clamp, "clamp"},
}};

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

namespace {
Color3<OneTag> one_lane(Vec3f c) {
  const OneTag d;
  return {hn::Set(d, c.x), hn::Set(d, c.y), hn::Set(d, c.z)};
}
Vec3f to_vec3(const Color3<OneTag>& c) {
  return {hn::GetLane(c.c0), hn::GetLane(c.c1), hn::GetLane(c.c2)};
}
}  // namespace

Vec3f agx_inset(Vec3f c) {
  return to_vec3(agx_inset(OneTag(), one_lane(c)));
}
Vec3f agx_outset(Vec3f c) {
  return to_vec3(agx_outset(OneTag(), one_lane(c)));
}
Vec3f agx(Vec3f c) {
  return to_vec3(agx(OneTag(), one_lane(c)));
}
Vec3f tonemap_pixel(Vec3f linear, const TonemapSettings& s) {
  return to_vec3(tonemap_pixel(OneTag(), one_lane(linear), s));
}

void tonemap_row(const float* const* in, float* const* out, int width, const TonemapSettings& s,
                 const Exec& exec) {
  for_each_lane_block(exec, width, [&](auto d, int x) {
    for (int c = 0; c < 3; ++c) {  // six streams (core/prefetch.h); no value changes
      __builtin_prefetch(in[c] + x + kRowPrefetchAhead);
      __builtin_prefetch(out[c] + x + kRowPrefetchAhead, 1);
    }
    // Every lane is loaded before any is stored, so out may be in.
    const auto r = tonemap_pixel(
        d, {hn::LoadU(d, in[0] + x), hn::LoadU(d, in[1] + x), hn::LoadU(d, in[2] + x)}, s);
    hn::StoreU(r.c0, d, out[0] + x);
    hn::StoreU(r.c1, d, out[1] + x);
    hn::StoreU(r.c2, d, out[2] + x);
  });
}

ImageF tonemap(const ImageF& linear, const TonemapSettings& s, const Exec& exec) {
  s.validate();
  if (linear.channels() != 3)
    throw InputError(
        fmt::format("tonemap: the image has {} planes, RGB (3) expected", linear.channels()));
  ImageF out = ImageF::uninitialized(linear.width(), linear.height(), 3);
  parallel_rows(exec, linear.height(), [&](int y) {
    const float* in[3] = {linear.row(0, y), linear.row(1, y), linear.row(2, y)};
    float* o[3] = {out.row(0, y), out.row(1, y), out.row(2, y)};
    tonemap_row(in, o, linear.width(), s, exec);
  });
  return out;
}

RowPass tonemap_row_pass(const TonemapSettings& s, const Exec& exec) {
  s.validate();
  return [s, exec]() -> RowFn {
    return [s, exec](int, int, float* const* rows, int n) { tonemap_row(rows, rows, n, s, exec); };
  };
}

}  // namespace afterimage::post
