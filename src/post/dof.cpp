#include "post/dof.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "camera/camera.h"
#include "core/error.h"
#include "core/lanes.h"
#include "post/dof_diffusion.h"

namespace afterimage::post {

namespace {
// std::lround of a float (half away from zero) without the library call: x - trunc(x) is
// exact, so the comparison with 0.5 decides as lround does.
inline int round_half_away(float x) {
  const float t = std::trunc(x), r = x - t;
  return int(t) + (r >= 0.5f ? 1 : 0) - (r <= -0.5f ? 1 : 0);
}

// A gather tap: whole-pixel offset, its distance, how many spiral taps merged into it, and its
// offset in the padded planes.
struct GatherTap {
  int dx, dy;
  float dist, count;
  ptrdiff_t offset;
};
struct GatherPlanes {
  const float *r, *z, *inv_area, *color[3];
};

// Scatter-as-gather at the lanes of one block (pixels at padded index i .. i + lanes - 1):
// the pixel itself spread over its own disc, then every tap whose disc, after the depth order
// (effective_radius), covers the pixel (disc_coverage), weighted by count / r_q^2. A tap of
// weight 0 adds nothing (masked), as if skipped.
//
// kRows blocks of as many rows (padded indices i[r]) share each tap's loop iteration: their
// sums are independent chains, so the out-of-order core overlaps one row's loads and adds
// with the other's (each pixel's operations and their order are unchanged).
template <int kRows, class D>
HWY_INLINE void gather_block(D d, const GatherPlanes& p, const std::vector<GatherTap>& taps,
                             const size_t (&i)[kRows], float* const (&dst)[kRows][3], int x) {
  V<D> rp[kRows], zp[kRows], wsum[kRows], sum[kRows][3];
  for (int r = 0; r < kRows; ++r) {
    rp[r] = hn::LoadU(d, p.r + i[r]);
    zp[r] = hn::LoadU(d, p.z + i[r]);
    wsum[r] = hn::LoadU(d, p.inv_area + i[r]);
    for (int c = 0; c < 3; ++c) sum[r][c] = hn::Mul(wsum[r], hn::LoadU(d, p.color[c] + i[r]));
  }
  const V<D> zero = hn::Zero(d), one = hn::Set(d, 1.0f), half = hn::Set(d, 0.5f);
  for (const GatherTap& t : taps) {
    const V<D> dist = hn::Set(d, t.dist), count = hn::Set(d, t.count);
    for (int r = 0; r < kRows; ++r) {
      const size_t q = size_t(ptrdiff_t(i[r]) + t.offset);
      const V<D> rq = hn::LoadU(d, p.r + q), zq = hn::LoadU(d, p.z + q);
      // effective_radius: a tap behind the pixel covers it at most with the pixel's radius.
      const V<D> re = hn::IfThenElse(hn::Gt(zq, zp[r]), hn::Min(rq, rp[r]), rq);
      // disc_coverage: clamp(r - d + 0.5, 0, 1).
      const V<D> cov = hn::Min(hn::Max(hn::Add(hn::Sub(re, dist), half), zero), one);
      const V<D> wq = hn::Mul(hn::Mul(count, cov), hn::LoadU(d, p.inv_area + q));
      const auto used = hn::Gt(wq, zero);
      // wq is +0 or positive (cov >= +0, 1 / r^2 >= 0), so adding it unmasked to the positive
      // wsum gives the masked sum's bits; the colors stay masked (0 times an infinite color).
      wsum[r] = hn::Add(wsum[r], wq);
      for (int c = 0; c < 3; ++c)
        sum[r][c] =
            hn::Add(sum[r][c], hn::IfThenElseZero(used, hn::Mul(wq, hn::LoadU(d, p.color[c] + q))));
    }
  }
  for (int r = 0; r < kRows; ++r)
    for (int c = 0; c < 3; ++c) hn::StoreU(hn::Div(sum[r][c], wsum[r]), d, dst[r][c] + x);
}

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
  const CocLens lens(f.lens, w, k);
  const int tw = (w + k - 1) / k, th = (h + k - 1) / k;
  // Padded planes (pad = k, the longest tap offset, on every side) so that no tap needs a
  // bounds test: outside the image the weight 1 / r^2 is 0, which adds exactly nothing, as the
  // skipped taps did. Per pixel: r >= 0.5, depth, 1 / r^2 (a tap's color spreads evenly over
  // its disc) and the color. Allocated without a fill and written once, in parallel (a serial
  // fill of the six planes cost about 12% of the pass at 1080p on 2 threads).
  const int pad = k, pw = w + 2 * pad, ph = h + 2 * pad;
  ImageF planes_ = ImageF::uninitialized(pw, ph, 6);
  float *rp_ = planes_.plane(0), *zp_ = planes_.plane(1), *ia_ = planes_.plane(2);
  float* cp_[3] = {planes_.plane(3), planes_.plane(4), planes_.plane(5)};
  auto fill_padding = [&](size_t from, size_t to) {
    std::fill(rp_ + from, rp_ + to, 0.5f);
    for (float* p : {zp_, ia_, cp_[0], cp_[1], cp_[2]}) std::fill(p + from, p + to, 0.0f);
  };
  // TileMax: the largest radius (before the 0.5 floor) of each k x k tile.
  std::vector<float> tile(size_t(tw) * size_t(th), 0.0f), neighbor(tile.size(), 0.0f);
  // One task per tile row: the planes of its image rows (the padding rows go with the first
  // and the last tile row) and its tiles' maxima. Radii on lanes (gather_radius_lanes), the
  // maxima of non-negative values in any order (max is exact).
  parallel_rows(exec, th, [&](int ty) {
    if (ty == 0)
      for (int py = 0; py < pad; ++py) fill_padding(size_t(py) * pw, size_t(py + 1) * pw);
    if (ty == th - 1)
      for (int py = pad + h; py < ph; ++py) fill_padding(size_t(py) * pw, size_t(py + 1) * pw);
    std::vector<float, DefaultInitAllocator<float>> raw(static_cast<size_t>(w));
    for (int y = ty * k; y < std::min(h, (ty + 1) * k); ++y) {
      const size_t row = size_t(y + pad) * size_t(pw);
      fill_padding(row, row + size_t(pad));
      fill_padding(row + size_t(pad + w), row + size_t(pw));
      const size_t o = row + size_t(pad);
      const float* depth = f.depth.row(0, y);
      for_each_lane_block(exec, w, [&](auto d, int x) {
        const auto z = hn::LoadU(d, depth + x);
        const auto r = gather_radius_lanes(d, z, lens);
        const auto rq = hn::Max(r, hn::Set(d, 0.5f));
        hn::StoreU(r, d, raw.data() + x);
        hn::StoreU(rq, d, rp_ + o + size_t(x));
        hn::StoreU(z, d, zp_ + o + size_t(x));
        hn::StoreU(hn::Div(hn::Set(d, 1.0f), hn::Mul(rq, rq)), d, ia_ + o + size_t(x));
      });
      for (int c = 0; c < 3; ++c) std::copy(color.row(c, y), color.row(c, y) + w, cp_[c] + o);
      for (int tx = 0; tx < tw; ++tx) {
        float& t = tile[size_t(ty) * size_t(tw) + size_t(tx)];
        const float* p = raw.data() + size_t(tx) * size_t(k);
        for (int x = 0; x < std::min(k, w - tx * k); ++x) t = std::max(t, p[x]);
      }
    }
  });
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
  // The distance of every whole-pixel offset within the pad, computed once (hypot of each
  // tap of each tile was ~1% of the chain).
  const int span_k = 2 * k + 1;
  std::vector<float> offset_dist(size_t(span_k) * size_t(span_k));
  for (int dy = -k; dy <= k; ++dy)
    for (int dx = -k; dx <= k; ++dx)
      offset_dist[size_t(dy + k) * size_t(span_k) + size_t(dx + k)] =
          std::hypot(float(dx), float(dy));
  // The taps of a neighbourhood radius R as whole-pixel offsets: the spiral scaled by R and
  // rounded (a pixel sits at an integer position), merged where several round to the same
  // pixel (their weights add up), in the order of their first spiral tap. They depend on R
  // only, so each tile computes them once; `slot` (per task, all -1 between calls) finds the
  // tap of an offset already taken.
  auto taps_for = [&](float big, std::vector<GatherTap>& taps, std::vector<int>& slot) {
    taps.clear();
    for (const auto& [ux, uy] : spiral) {
      const int dx = round_half_away(ux * big), dy = round_half_away(uy * big);
      if (dx == 0 && dy == 0) continue;
      int& at = slot[size_t(dy + k) * size_t(span_k) + size_t(dx + k)];
      if (at >= 0) {
        taps[size_t(at)].count += 1.0f;
      } else {
        at = int(taps.size());
        taps.push_back({dx, dy, offset_dist[size_t(dy + k) * size_t(span_k) + size_t(dx + k)], 1.0f,
                        ptrdiff_t(dy) * pw + dx});
      }
    }
    for (const GatherTap& t : taps) slot[size_t(t.dy + k) * size_t(span_k) + size_t(t.dx + k)] = -1;
  };
  const GatherPlanes planes{rp_, zp_, ia_, {cp_[0], cp_[1], cp_[2]}};
  ImageF out = ImageF::uninitialized(w, h, 3);
  // Rows of tiles in parallel: a tile's taps are built once for its k rows; the pixels of a
  // tile row run in lane blocks (the same per-pixel order of operations at every width).
  parallel_rows(exec, th, [&](int ty) {
    std::vector<GatherTap> taps;
    std::vector<int> slot(offset_dist.size(), -1);
    for (int tx = 0; tx < tw; ++tx) {
      const float big = neighbor[size_t(ty) * size_t(tw) + size_t(tx)];
      const int x0 = tx * k, span = std::min(w, x0 + k) - x0;
      if (big < 0.5f) {  // focus field around: unchanged
        for (int y = ty * k; y < std::min(h, (ty + 1) * k); ++y)
          for (int c = 0; c < 3; ++c)
            std::copy(color.row(c, y) + x0, color.row(c, y) + x0 + span, out.row(c, y) + x0);
        continue;
      }
      taps_for(big, taps, slot);
      const int y_end = std::min(h, (ty + 1) * k);
      auto row_of = [&](int y) { return size_t(y + pad) * size_t(pw) + size_t(pad + x0); };
      int y = ty * k;
      for (; y + 2 <= y_end; y += 2) {  // two rows a tap
        float* const dst[2][3] = {{out.row(0, y), out.row(1, y), out.row(2, y)},
                                  {out.row(0, y + 1), out.row(1, y + 1), out.row(2, y + 1)}};
        for_each_lane_block(exec, span, [&](auto d, int xo) {
          const size_t i[2] = {row_of(y) + size_t(xo), row_of(y + 1) + size_t(xo)};
          gather_block<2>(d, planes, taps, i, dst, x0 + xo);
        });
      }
      if (y < y_end) {
        float* const dst[1][3] = {{out.row(0, y), out.row(1, y), out.row(2, y)}};
        for_each_lane_block(exec, span, [&](auto d, int xo) {
          const size_t i[1] = {row_of(y) + size_t(xo)};
          gather_block<1>(d, planes, taps, i, dst, x0 + xo);
        });
      }
    }
  });
  return out;
}

}  // namespace afterimage::post
