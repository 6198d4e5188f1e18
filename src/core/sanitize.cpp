#include "core/sanitize.h"

#include <array>

#include "core/neighborhood.h"

namespace afterimage {

namespace {

// One lane block of sanitize_color (moved from taa/resolver.cpp; same operations).
template <class D>
HWY_INLINE void sanitize_block(D d, const ImageF& in, ImageF& out, ImageF& invalid, int x, int y) {
  const int w = in.width(), h = in.height();
  const std::array<size_t, 3> rows = neighborhood_rows(y, w, h);
  const auto zero = hn::Zero(d);
  auto any_bad = zero;
  for (int c = 0; c < 3; ++c) {
    const float* p = in.plane(c);
    auto v = hn::LoadU(d, p + rows[1] + x);
    auto fin = hn::IsFinite(v);
    any_bad = hn::IfThenElse(fin, any_bad, hn::Set(d, 1.0f));
    auto r = hn::Max(hn::IfThenElse(fin, v, zero), zero);
    if (!hn::AllTrue(d, fin)) {
      auto sum = zero, cnt = zero;
      for (int i = 1; i < 9; ++i) {
        auto q = load_neighbor(d, p, rows, x, i, 1, w);
        auto qf = hn::IsFinite(q);
        sum = hn::Add(sum, hn::IfThenElse(qf, hn::Max(q, zero), zero));
        cnt = hn::Add(cnt, hn::IfThenElse(qf, hn::Set(d, 1.0f), zero));
      }
      auto mean =
          hn::IfThenElse(hn::Gt(cnt, zero), hn::Div(sum, hn::Max(cnt, hn::Set(d, 1.0f))), zero);
      r = hn::IfThenElse(fin, r, mean);
    }
    hn::StoreU(r, d, out.plane(c) + rows[1] + x);
  }
  hn::StoreU(any_bad, d, invalid.plane(0) + rows[1] + x);
}

}  // namespace

bool row_needs_sanitize(const ImageF& color, int y) {
  // Vectorised (the scalar count loop was not: 3.5% of a resolve); stops at the first bad
  // vector. NaN fails both comparisons.
  const int w = color.width();
  const FullTag d;
  const int n = int(hn::Lanes(d));
  const auto lo = hn::Zero(d), hi = hn::Set(d, 3.4e38f);
  for (int c = 0; c < 3; ++c) {
    const float* r = color.row(c, y);
    int x = 0;
    for (; x + n <= w; x += n) {
      const auto v = hn::LoadU(d, r + x);
      if (!hn::AllTrue(d, hn::And(hn::Ge(v, lo), hn::Le(v, hi)))) return true;
    }
    for (; x < w; ++x)
      if (!(r[x] >= 0.0f && r[x] <= 3.4e38f)) return true;
  }
  return false;
}

bool needs_sanitize(const ImageF& color, const Exec& ex) {
  double bad = parallel_sum_rows(ex, color.height(),
                                 [&](int y) { return row_needs_sanitize(color, y) ? 1.0 : 0.0; });
  return bad > 0.0;
}

bool sanitize_color(const ImageF& color, ImageF& out, ImageF& invalid, const Exec& ex) {
  AI_CHECK_EQ(color.channels(), 3);
  if (!needs_sanitize(color, ex)) return false;
  const int w = color.width(), h = color.height();
  if (!out.same_shape(color)) out = ImageF(w, h, 3);
  if (invalid.width() != w || invalid.height() != h || invalid.channels() != 1)
    invalid = ImageF(w, h, 1);
  parallel_rows(ex, h, [&](int y) {
    for_each_lane_block(ex, w,
                        [&](auto d, int x) { sanitize_block(d, color, out, invalid, x, y); });
  });
  return true;
}

}  // namespace afterimage
