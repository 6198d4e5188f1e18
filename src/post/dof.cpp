#include "post/dof.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "camera/camera.h"
#include "core/error.h"
#include "post/dof_diffusion.h"

namespace afterimage::post {

namespace {
constexpr EnumNames<DofMode, 2> kDofModeNames{{
    {DofMode::gather, "gather"},
    {DofMode::diffusion, "diffusion"},
}};
}  // namespace

const ParamTable<DofSettings>& DofSettings::params() {
  static const ParamTable<DofSettings> kTable = [] {  // immutable once built
    using S = DofSettings;
    ParamTable<S> t("dof");
    t.add_int("max_radius", &S::max_radius, 1, 128,
              "clamp of the circle-of-confusion radius in pixels, also the tile size");
    t.add_int("taps", &S::taps, 8, 1024, "gather taps over the neighbourhood's disc");
    t.add_enum("mode", &S::mode, kDofModeNames,
               "gather (scatter-as-gather, Jimenez 2014) or diffusion (Kass, Lefohn, Owens 2006)");
    t.add_float("diffusion_scale", &S::diffusion_scale, 0.01f, 100.0f,
                "diffusion: conductivity multiplier (1: the variance of the CoC disc)");
    t.add_int("diffusion_steps", &S::diffusion_steps, 1, 16,
              "diffusion: implicit steps sharing the blur (1: the paper's single ADI step)");
    t.add_bool("diffusion_near_layer", &S::diffusion_near_layer,
               "diffusion: diffuse the near field as its own layer over the background");
    return t;
  }();
  return kTable;
}
void DofSettings::set_assignment(const std::string& assignment) {
  params().set_assignment(*this, assignment);
}
void DofSettings::validate() const {
  params().validate(*this);
}

ImageF depth_of_field(const Frame& f, const ImageF& color, const DofSettings& s, const Exec& exec) {
  s.validate();
  if (!f.has_depth()) throw InputError(fmt::format("dof: frame {} has no depth", f.index));
  const int w = color.width(), h = color.height(), k = s.max_radius;
  if (w != f.width || h != f.height || color.channels() != 3)
    throw InputError(fmt::format("dof: frame {} is {}x{}, its color {}x{}x{}", f.index, f.width,
                                 f.height, w, h, color.channels()));
  if (!(f.lens.f_number > 0.0)) return color;  // pinhole: everything in focus
  validate_lens(f.lens);
  if (s.mode == DofMode::diffusion) return depth_of_field_diffusion(f, color, s, exec);
  const size_t n = size_t(w) * size_t(h);
  std::vector<float> r(n);
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const double coc = circle_of_confusion_px(f.lens, f.depth.at(x, y, 0), w);
      r[size_t(y) * size_t(w) + size_t(x)] =
          std::isfinite(coc) ? std::min(float(0.5 * std::abs(coc)), float(k)) : 0.0f;
    }
  });
  const int tw = (w + k - 1) / k, th = (h + k - 1) / k;
  std::vector<float> tile(size_t(tw) * size_t(th), 0.0f), neighbor(tile.size(), 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float& t = tile[size_t(y / k) * size_t(tw) + size_t(x / k)];
      t = std::max(t, r[size_t(y) * size_t(w) + size_t(x)]);
    }
  for (int ty = 0; ty < th; ++ty)
    for (int tx = 0; tx < tw; ++tx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int ux = tx + dx, uy = ty + dy;
          if (ux < 0 || uy < 0 || ux >= tw || uy >= th) continue;
          float& m = neighbor[size_t(ty) * size_t(tw) + size_t(tx)];
          m = std::max(m, tile[size_t(uy) * size_t(tw) + size_t(ux)]);
        }
  // Golden-angle spiral over the unit disc, equal area per tap (Vogel 1979).
  std::vector<std::pair<float, float>> spiral(size_t(s.taps));
  for (int i = 0; i < s.taps; ++i) {
    const double rad = std::sqrt((i + 0.5) / s.taps), a = i * 2.39996322972865332;
    spiral[size_t(i)] = {float(rad * std::cos(a)), float(rad * std::sin(a))};
  }
  ImageF out = color;
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const float big = neighbor[size_t(y / k) * size_t(tw) + size_t(x / k)];
      if (big < 0.5f) continue;  // focus field around: unchanged
      const size_t ip = size_t(y) * size_t(w) + size_t(x);
      const float rp = std::max(r[ip], 0.5f), zp = f.depth.at(x, y, 0);
      // The pixel itself, spread over its own disc.
      double wsum = 1.0 / (rp * rp), sum[3];
      for (int c = 0; c < 3; ++c) sum[c] = wsum * color.at(x, y, c);
      for (const auto& [ux, uy] : spiral) {
        const int qx = int(std::lround(x + ux * big)), qy = int(std::lround(y + uy * big));
        if ((qx == x && qy == y) || qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
        const size_t iq = size_t(qy) * size_t(w) + size_t(qx);
        const float rq = std::max(r[iq], 0.5f);
        const float re = effective_radius(rq, f.depth.at(qx, qy, 0), rp, zp);
        const float d = std::hypot(float(qx - x), float(qy - y));
        const double wq = disc_coverage(re, d) / double(rq * rq);
        if (wq <= 0.0) continue;
        wsum += wq;
        for (int c = 0; c < 3; ++c) sum[c] += wq * color.at(qx, qy, c);
      }
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = float(sum[c] / wsum);
    }
  });
  return out;
}

}  // namespace afterimage::post
