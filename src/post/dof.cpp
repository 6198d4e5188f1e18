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
  // Per pixel: 1 / r^2 (a tap's color spreads evenly over its disc), with r >= 0.5.
  std::vector<float> inv_area(n);
  for (size_t i = 0; i < n; ++i) {
    const float rq = std::max(r[i], 0.5f);
    inv_area[i] = 1.0f / (rq * rq);
  }
  // The taps of a neighbourhood radius R as whole-pixel offsets: the spiral scaled by R and
  // rounded (a pixel sits at an integer position), merged where several round to the same
  // pixel (their weights add up). They depend on R only, so each tile computes them once.
  struct Tap {
    int dx, dy;
    float dist, count;
  };
  auto taps_for = [&](float big, std::vector<Tap>& taps) {
    taps.clear();
    for (const auto& [ux, uy] : spiral) {
      const int dx = int(std::lround(ux * big)), dy = int(std::lround(uy * big));
      if (dx == 0 && dy == 0) continue;
      auto it = std::find_if(taps.begin(), taps.end(),
                             [&](const Tap& t) { return t.dx == dx && t.dy == dy; });
      if (it != taps.end())
        it->count += 1.0f;
      else
        taps.push_back({dx, dy, std::hypot(float(dx), float(dy)), 1.0f});
    }
  };
  ImageF out = color;
  const float* depth = f.depth.plane(0);
  // Rows of tiles in parallel: a tile's taps are built once for its k rows.
  parallel_rows(exec, th, [&](int ty) {
    std::vector<Tap> taps;
    for (int tx = 0; tx < tw; ++tx) {
      const float big = neighbor[size_t(ty) * size_t(tw) + size_t(tx)];
      if (big < 0.5f) continue;  // focus field around: unchanged
      taps_for(big, taps);
      for (int y = ty * k; y < std::min(h, (ty + 1) * k); ++y)
        for (int x = tx * k; x < std::min(w, (tx + 1) * k); ++x) {
          const size_t ip = size_t(y) * size_t(w) + size_t(x);
          const float rp = std::max(r[ip], 0.5f), zp = depth[ip];
          // The pixel itself, spread over its own disc.
          float wsum = inv_area[ip], sum[3];
          for (int c = 0; c < 3; ++c) sum[c] = wsum * color.at(x, y, c);
          for (const Tap& t : taps) {
            const int qx = x + t.dx, qy = y + t.dy;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
            const size_t iq = size_t(qy) * size_t(w) + size_t(qx);
            const float re = effective_radius(std::max(r[iq], 0.5f), depth[iq], rp, zp);
            const float wq = t.count * disc_coverage(re, t.dist) * inv_area[iq];
            if (wq <= 0.0f) continue;
            wsum += wq;
            for (int c = 0; c < 3; ++c) sum[c] += wq * color.plane(c)[iq];
          }
          for (int c = 0; c < 3; ++c) out.at(x, y, c) = sum[c] / wsum;
        }
    }
  });
  return out;
}

}  // namespace afterimage::post
