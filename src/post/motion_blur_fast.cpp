// Motion blur's fast schedule (motion_blur.h; its plain statement is motion_blur_reference.cpp,
// which it equals bit for bit): half vectors and TileMax on double lanes with a float scan that
// proves most tiles without them, and the reconstruction in lane blocks of one path, with taps
// at a fixed offset read as plain loads and the others through a two-vector window.
#include "post/motion_blur_fast.h"
#include "post/motion_blur_camera.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "core/lanes.h"
#include "core/prefetch.h"
#include "reproject/forward.h"

namespace afterimage::post {

namespace {

// Per-pixel jitter in [-0.5, 0.5) of the lanes' pixels x .. x + lanes - 1 of row y: a hash of
// the pixel (deterministic, thread-independent), n = h >> 8 < 2^24 scaled to (n - 2^23) 2^-24
// (exact in float, the same value as the double form it was).
template <class D>
HWY_INLINE V<D> pixel_jitter_lanes(D d, int x, int y) {
  const hn::RebindToUnsigned<D> du;
  const hn::RebindToSigned<D> di;
  auto h = hn::Xor(hn::Mul(hn::BitCast(du, iota_from(di, x)), hn::Set(du, 0x8da6b343u)),
                   hn::Set(du, uint32_t(y) * 0xd8163841u));
  h = hn::Xor(h, hn::ShiftRight<15>(h));
  h = hn::Mul(h, hn::Set(du, 0x2c1b3c6du));
  h = hn::Xor(h, hn::ShiftRight<12>(h));
  const auto n = hn::Sub(hn::BitCast(di, hn::ShiftRight<8>(h)), hn::Set(di, 1 << 23));
  return hn::Mul(hn::ConvertTo(d, n), hn::Set(d, 1.0f / 16777216.0f));
}

double length(Vec2d v) {
  return std::sqrt(v.x * v.x + v.y * v.y);
}

// TileMax of one tile (or NeighborMax of 3x3 tiles) and the box that holds all of their half
// vectors: a small box means the neighbourhood moves as one (the fast path).
struct VelocityTile {
  Vec2d longest{0, 0};
  double min_x = HUGE_VAL, max_x = -HUGE_VAL, min_y = HUGE_VAL, max_y = -HUGE_VAL;
  void add(Vec2d c) {
    if (length(c) > length(longest)) longest = c;
    min_x = std::min(min_x, c.x);
    max_x = std::max(max_x, c.x);
    min_y = std::min(min_y, c.y);
    max_y = std::max(max_y, c.y);
  }
  // add() of n pixels of one row in x order, from their half vectors and squared lengths: the
  // first of the longest replaces `longest` only if strictly longer (as add() in order), and
  // the box's minima and maxima, exact in any order (a -0 for a +0 changes no box width).
  void add_row(const double* vx, const double* vy, const double* sq, int n, const Exec& exec);
  void merge(const VelocityTile& t) {
    if (length(t.longest) > length(longest)) longest = t.longest;
    min_x = std::min(min_x, t.min_x);
    max_x = std::max(max_x, t.max_x);
    min_y = std::min(min_y, t.min_y);
    max_y = std::max(max_y, t.max_y);
  }
  bool uniform(double tolerance) const {
    return max_x - min_x <= tolerance && max_y - min_y <= tolerance;
  }
};

// ---- The reconstruction at the lanes of one block (core/simd.h): pixels x .. x + lanes - 1
// of one row, all of the same path. Float arithmetic, the same order at every width, so the
// 1-lane path (--simd off) gives the same bits.

// What a pixel's row pre-pass found: its NeighborMax vector, its tap jitter in [-0.5, 0.5) and
// its path.
enum PixelPath : uint8_t { kCopy = 0, kFast = 1, kFull = 2 };
struct BlurRow {
  std::vector<float> vx, vy;
  std::vector<uint8_t> path;
};
struct BlurPlanes {
  int w, h;
  bool exact_float_index;  // w h < 2^23: tap_index's flat index in float
  const float *len, *depth, *color[3];
};

// soft_depth_compare(z_a, z_b) into ab and soft_depth_compare(z_b, z_a) into ba from one
// division: (z_b - z_a) / (extent min(z_b, z_a)) is the negated quotient (a NaN depth makes
// both NaN; the sign of a +0 numerator changes nothing after 1 -).
template <class D>
HWY_INLINE void soft_depth_compare_lanes(D d, V<D> za, V<D> zb, float extent, V<D>& ab, V<D>& ba) {
  const V<D> one = hn::Set(d, 1.0f);
  const V<D> q = hn::Div(hn::Sub(za, zb), hn::Mul(hn::Set(d, extent), hn::Min(za, zb)));
  ab = hn::Min(hn::Max(hn::Sub(one, q), hn::Zero(d)), one);
  ba = hn::Min(hn::Max(hn::Sub(one, hn::Neg(q)), hn::Zero(d)), one);
}
// clamp(1 - distance / |v|, 0, 1) (cone_weight; |v| >= 0.5 here) from inv_len = 1 / |v|: a
// multiply instead of a division (the full path took five divisions a tap, its bound; the
// reciprocal moves a weight by an ulp or two).
template <class D>
HWY_INLINE V<D> cone_lanes(D d, V<D> dist, V<D> inv_len) {
  return hn::Min(hn::Max(hn::Sub(hn::Set(d, 1.0f), hn::Mul(dist, inv_len)), hn::Zero(d)),
                 hn::Set(d, 1.0f));
}
// 1 - smoothstep(0.95 |v|, 1.05 |v|, distance) (cylinder_weight), from inv_tenth = 1 / (0.1 |v|).
template <class D>
HWY_INLINE V<D> cylinder_lanes(D d, V<D> dist, V<D> len, V<D> inv_tenth) {
  const V<D> t = hn::Min(
      hn::Max(hn::Mul(hn::Sub(dist, hn::Mul(hn::Set(d, 0.95f), len)), inv_tenth), hn::Zero(d)),
      hn::Set(d, 1.0f));
  return hn::Sub(hn::Set(d, 1.0f),
                 hn::Mul(hn::Mul(t, t), hn::Sub(hn::Set(d, 3.0f), hn::Add(t, t))));
}

// Flat index of tap p on side `sign` of every lane: (p + 0.5 + 0.5 j) / pairs of the way along
// +-vn, rounded to a pixel inside the image; also its offset from the lane's pixel (floats,
// whole numbers). The pixel coordinates stay in float (whole numbers, exact), and below 2^23
// pixels so does the flat index, converted by the 2^23 bias (exact for whole numbers in
// [0, 2^23)): two float-to-int conversions with their overflow fix-ups and an integer
// multiply per tap were half of the fast path's operations. Larger images multiply in
// integers. Either way the same indices.
constexpr float kExactIndexBias = 8388608.0f;  // 2^23
// (p + 0.5 + 0.5 j) / pairs: the way along the half vector of tap pair p, the same for both
// sides (a tap's side only signs it), so one division serves the pair.
template <class D>
HWY_INLINE V<D> tap_fraction(D d, V<D> jit, int p, V<D> pairs) {
  return hn::Div(hn::Add(hn::Set(d, float(p) + 0.5f), hn::Mul(hn::Set(d, 0.5f), jit)), pairs);
}
template <class D>
HWY_INLINE VI<D> tap_index(D d, const BlurPlanes& pl, V<D> xs, V<D> ys, V<D> vx, V<D> vy,
                           V<D> fraction, float sign, V<D>& dx, V<D>& dy) {
  const hn::RebindToSigned<D> di;
  const V<D> t = hn::Mul(hn::Set(d, sign), fraction);
  const V<D> half = hn::Set(d, 0.5f), zero = hn::Zero(d);
  // clamp(floor(.), 0, w - 1) of whole numbers in float: the integer clamp's values.
  const V<D> px = hn::Min(hn::Max(hn::Floor(hn::Add(hn::Add(xs, hn::Mul(t, vx)), half)), zero),
                          hn::Set(d, float(pl.w - 1)));
  const V<D> py = hn::Min(hn::Max(hn::Floor(hn::Add(hn::Add(ys, hn::Mul(t, vy)), half)), zero),
                          hn::Set(d, float(pl.h - 1)));
  dx = hn::Sub(px, xs);  // xs, ys: whole numbers (the lanes' pixels)
  dy = hn::Sub(py, ys);
  if (pl.exact_float_index) {
    const V<D> flat =
        hn::Add(hn::Add(hn::Mul(py, hn::Set(d, float(pl.w))), px), hn::Set(d, kExactIndexBias));
    return hn::Sub(hn::BitCast(di, flat), hn::BitCast(di, hn::Set(d, kExactIndexBias)));
  }
  return hn::Add(hn::Mul(hn::ConvertTo(di, py), hn::Set(di, pl.w)), hn::ConvertTo(di, px));
}

// The lanes of a plane at flat indices idx. When they fall within two vectors of the plane
// (most taps of a block stay in one row and a few pixels of it), two loads and lane permutes
// give the same values as a gather at a fraction of its cost (as taau's SampleWindow).
template <class D>
struct TapWindow {
  bool in_register = false;
  size_t base = 0;
  decltype(hn::IndicesFromVec(D(), hn::Zero(hn::RebindToSigned<D>()))) lane{};
  hn::Mask<D> upper{};
  VI<D> rel{};  // each lane's position in the two vectors, 0 .. 2 lanes - 1
};
template <class D>
HWY_INLINE TapWindow<D> tap_window(D d, VI<D> idx, size_t plane_size) {
  TapWindow<D> t;
  if constexpr (hn::MaxLanes(D()) > 1) {
    const hn::RebindToSigned<D> di;
    const hn::RebindToUnsigned<D> du;
    const int n = int(hn::Lanes(d));
    // The window starts half a vector before lane 0's tap, not at the lanes' minimum: the taps
    // of a block on one row stray from lane 0's by no more than the jitter's spread, |v| /
    // (2 pairs) + 1 pixels, so they still fit, and MinOfLanes (a chain of dependent shuffles
    // per tap) had bounded the fast path. Any window that holds every lane fetches the same
    // values; one that does not (unsigned: below the start too) falls back to the gather.
    const int lo = hn::GetLane(idx) - n / 2;
    if (lo < 0 || size_t(lo) + size_t(2 * n) > plane_size) return t;
    const VI<D> rel = hn::Sub(idx, hn::Set(di, lo));
    if (!hn::AllTrue(du, hn::Lt(hn::BitCast(du, rel), hn::Set(du, uint32_t(2 * n))))) return t;
    t.in_register = true;
    t.base = size_t(lo);
    t.rel = rel;
    t.lane = hn::IndicesFromVec(d, hn::And(rel, hn::Set(di, n - 1)));
    t.upper = hn::RebindMask(d, hn::Gt(rel, hn::Set(di, n - 1)));
  }
  return t;
}
template <class D>
HWY_INLINE V<D> fetch(D d, const float* plane, VI<D> idx, const TapWindow<D>& t) {
  if constexpr (hn::MaxLanes(D()) > 1) {
    if (t.in_register) {
      const V<D> a = hn::LoadU(d, plane + t.base), b = hn::LoadU(d, plane + t.base + hn::Lanes(d));
#if HWY_TARGET <= HWY_AVX3
      // AVX-512's two-table permute (vpermt2ps): one shuffle instead of two and a blend; the
      // shuffle port had bounded the box filter (6 of its ~28 operations a tap and row).
      if constexpr (sizeof(a.raw) == 64) {
        V<D> r;
        r.raw = _mm512_permutex2var_ps(a.raw, t.rel.raw, b.raw);
        return r;
      } else if constexpr (sizeof(a.raw) == 32) {
        V<D> r;
        r.raw = _mm256_permutex2var_ps(a.raw, t.rel.raw, b.raw);
        return r;
      }
#endif
      return hn::IfThenElse(t.upper, hn::TableLookupLanes(b, t.lane),
                            hn::TableLookupLanes(a, t.lane));
    }
  }
  return hn::GatherIndex(d, plane, idx);
}

// The pixel offset, per axis, that tap pair p's tap on side `sign` takes from its pixel
// whatever the pixel's jitter, when there is one: tap_index rounds x + t v + 0.5 down, t =
// sign (p + 0.5 + 0.5 j) / pairs with j in [-0.5, 0.5), so the real offsets lie between the
// ends j = -0.5 and j = 0.5; if floor(. + 0.5) is the same at both ends widened by `kSlack`
// (far above the float rounding of the fraction, of t v and of x + t v below 2^13 px, |v|
// <= 256), every jitter gives that offset. Sets `off`, returns whether it is fixed.
constexpr double kFixedTapSlack = 1.0 / 256.0;
inline bool fixed_tap_offset(double v, double sign, int p, double pairs, int& off) {
  const double a = sign * v * (p + 0.25) / pairs, b = sign * v * (p + 0.75) / pairs;
  const double lo = std::floor(std::min(a, b) - kFixedTapSlack + 0.5);
  const double hi = std::floor(std::max(a, b) + kFixedTapSlack + 0.5);
  off = int(lo);
  return lo == hi;
}
// The taps that land at one offset from every pixel of a half vector (vx, vy) with n_pairs
// pairs: plain loads at that offset, no index, window or jitter (the pixels tap_index would
// pick, so the same sums bit for bit), where a block's lanes share one half vector (a tile's
// NeighborMax without tile jitter) and the offsets stay inside the image. At 1 px of half
// vector (the bench frame's camera pan) all four taps are fixed and pair 0's are the pixel
// itself. Kept per row pass and recomputed when the half vector changes (scalar double work
// per tap that cost as much as the loads it saved when done per block).
struct FixedTaps {
  static constexpr int kMaxPairs = 32;  // samples <= 63
  float vx = NAN, vy = NAN;
  int n_pairs = -1;
  bool has(float vx_, float vy_) const { return vx_ == vx && vy_ == vy; }
  bool any_free = false;
  int min_dx = 0, max_dx = 0, min_dy = 0, max_dy = 0;  // over the fixed taps
  bool fixed[kMaxPairs][2];
  int dx[kMaxPairs][2], dy[kMaxPairs][2];
  void update(const BlurPlanes& pl, float vx_, float vy_, int n_pairs_) {
    vx = vx_;
    vy = vy_;
    n_pairs = n_pairs_;
    if (n_pairs > kMaxPairs) return;  // no fixed taps (use_fixed checks n_pairs)
    const bool small = pl.w <= 8192 && pl.h <= 8192;
    any_free = false;
    min_dx = max_dx = min_dy = max_dy = 0;
    for (int p = 0; p < n_pairs; ++p)
      for (int side = 0; side < 2; ++side) {
        const double sign = side == 0 ? -1.0 : 1.0;
        int ox = 0, oy = 0;
        const bool f = small && fixed_tap_offset(vx, sign, p, n_pairs, ox) &&
                       fixed_tap_offset(vy, sign, p, n_pairs, oy);
        fixed[p][side] = f;
        dx[p][side] = ox;
        dy[p][side] = oy;
        any_free = any_free || !f;
        if (f) {
          min_dx = std::min(min_dx, ox);
          max_dx = std::max(max_dx, ox);
          min_dy = std::min(min_dy, oy);
          max_dy = std::max(max_dy, oy);
        }
      }
  }
};

// Fast path: the equal-weight mean of the taps (the box filter along the motion), for the same
// lanes of kRows rows ys[r] (into o[r]) that share the row pre-pass: their taps' chains are
// independent, so the out-of-order core overlaps them (each pixel's operations unchanged).
// spacing > 0 (fast_tap_spacing): each pixel takes ceil(|v| / spacing) pairs (1 .. pairs), so
// its taps lie at most `spacing` apart; a block runs to its longest and masks the rest (a
// masked lane keeps its sum, so a pixel's bits do not depend on its neighbours').
template <int kRows, class D>
HWY_INLINE void box_rows(D d, const BlurPlanes& pl, const BlurRow& row, int x,
                         const int (&ys)[kRows], int pairs, float spacing, FixedTaps& ft,
                         float* const (&o)[kRows][3]) {
  const V<D> xs = iota_from(d, float(x));
  const V<D> vx = hn::LoadU(d, row.vx.data() + x), vy = hn::LoadU(d, row.vy.data() + x);
  // One half vector on every lane (a tile's NeighborMax): every lane takes n_pairs pairs, and
  // while it repeats, its pair count and fixed taps are kept from the block before.
  const float vx0 = hn::GetLane(vx), vy0 = hn::GetLane(vy);
  const bool one_vector =
      hn::AllTrue(d, hn::Eq(vx, hn::Set(d, vx0))) && hn::AllTrue(d, hn::Eq(vy, hn::Set(d, vy0)));
  V<D> lane_pairs = hn::Set(d, float(pairs));
  int n_pairs = pairs;
  if (one_vector && ft.has(vx0, vy0)) {
    n_pairs = ft.n_pairs;  // the MaxOfLanes below of equal lanes
    lane_pairs = hn::Set(d, float(n_pairs));
  } else {
    if (spacing > 0.0f) {
      const V<D> len = hn::Sqrt(hn::Add(hn::Mul(vx, vx), hn::Mul(vy, vy)));
      lane_pairs = hn::Min(hn::Max(hn::Ceil(hn::Div(len, hn::Set(d, spacing))), hn::Set(d, 1.0f)),
                           lane_pairs);
      n_pairs = int(hn::GetLane(hn::MaxOfLanes(d, lane_pairs)));
    }
    if (one_vector) ft.update(pl, vx0, vy0, n_pairs);
  }
  // Every fixed tap inside the image: the fixed taps are plain loads.
  bool use_fixed = one_vector && n_pairs <= FixedTaps::kMaxPairs;
  if (use_fixed) {
    use_fixed = x + ft.min_dx >= 0 && x + int(hn::Lanes(d)) - 1 + ft.max_dx <= pl.w - 1;
    for (int r = 0; r < kRows; ++r)
      use_fixed = use_fixed && ys[r] + ft.min_dy >= 0 && ys[r] + ft.max_dy <= pl.h - 1;
  }
  V<D> yv[kRows], jit[kRows], sum[kRows][3];
  size_t at[kRows];
  for (int r = 0; r < kRows; ++r) {
    yv[r] = hn::Set(d, float(ys[r]));
    at[r] = size_t(ys[r]) * size_t(pl.w) + size_t(x);
    if (!use_fixed || ft.any_free) jit[r] = pixel_jitter_lanes(d, x, ys[r]);
    for (int c = 0; c < 3; ++c) sum[r][c] = hn::Zero(d);
  }
  // A fixed tap: plain loads, every lane active (one n_pairs).
  const auto add_fixed = [&](int p, int side) {
    const ptrdiff_t off = ptrdiff_t(ft.dy[p][side]) * pl.w + ft.dx[p][side];
#pragma GCC unroll 4
    for (int r = 0; r < kRows; ++r)
#pragma GCC unroll 3
      for (int c = 0; c < 3; ++c)
        sum[r][c] = hn::Add(sum[r][c], hn::LoadU(d, pl.color[c] + ptrdiff_t(at[r]) + off));
  };
  // Every tap at a fixed offset (a block that pans as one, every lane active): the same sums in
  // the same order in a loop of their own. Sharing the loop below, whose free taps need a dozen
  // more vectors, AVX2's 16 registers had kept two of the six sums on the stack (a store and a
  // reload a tap: perf annotate on a Zen 3).
  if (use_fixed && !ft.any_free) {
    for (int p = 0; p < n_pairs; ++p) {
      add_fixed(p, 0);
      add_fixed(p, 1);
    }
  } else {
    // Unrolled, so the sums stay in registers (a loop over the signs kept them on the stack:
    // a store-to-load chain per tap and channel).
    for (int p = 0; p < n_pairs; ++p) {
      const auto active = hn::Lt(hn::Set(d, float(p)), lane_pairs);
      const bool free_pair = !use_fixed || !ft.fixed[p][0] || !ft.fixed[p][1];
      V<D> fraction[kRows];
      if (free_pair) {
#pragma GCC unroll 4
        for (int r = 0; r < kRows; ++r) fraction[r] = tap_fraction(d, jit[r], p, lane_pairs);
      }
#pragma GCC unroll 2
      for (int side = 0; side < 2; ++side) {
        if (use_fixed && ft.fixed[p][side]) {
          add_fixed(p, side);
          continue;
        }
#pragma GCC unroll 4
        for (int r = 0; r < kRows; ++r) {
          V<D> dx, dy;
          const VI<D> idx =
              tap_index(d, pl, xs, yv[r], vx, vy, fraction[r], side == 0 ? -1.0f : 1.0f, dx, dy);
          const TapWindow<D> win = tap_window(d, idx, size_t(pl.w) * size_t(pl.h));
#pragma GCC unroll 3
          for (int c = 0; c < 3; ++c)
            sum[r][c] = hn::IfThenElse(active, hn::Add(sum[r][c], fetch(d, pl.color[c], idx, win)),
                                       sum[r][c]);
        }
      }
    }
  }
  const V<D> n = hn::Add(lane_pairs, lane_pairs);  // 2 pairs, exact
  if (one_vector && (n_pairs & (n_pairs - 1)) == 0) {
    // A power of two on every lane: dividing by it and multiplying by its reciprocal round the
    // same real quotient, so the same bits without the division's latency.
    const V<D> inv = hn::Set(d, 0.5f / float(n_pairs));
    for (int r = 0; r < kRows; ++r)
      for (int c = 0; c < 3; ++c) hn::StoreU(hn::Mul(sum[r][c], inv), d, o[r][c]);
    return;
  }
  for (int r = 0; r < kRows; ++r)
    for (int c = 0; c < 3; ++c) hn::StoreU(hn::Div(sum[r][c], n), d, o[r][c]);
}

// Full path (McGuire et al. 2012, Sec. 3.3): the pixel weighted 1 / |V_X|, each tap by a
// blurry tap in front reaching this pixel, a tap behind a blurry pixel (the background it
// uncovers) and both blurry together; taps on the pixel itself count once, as the pixel.
// With `mirror`, Jimenez 2014's mirrored pair weights (see mirror_weights).
template <class D>
HWY_INLINE void full_block(D d, const BlurPlanes& pl, const BlurRow& row, int x, int y, int pairs,
                           float soft_depth, bool mirror, FixedTaps& ft, float* const dst[3]) {
  const hn::RebindToSigned<D> di;
  const V<D> xs = iota_from(d, float(x)), ys = hn::Set(d, float(y));
  const VI<D> self = iota_from(di, y * pl.w + x);
  const size_t ix = size_t(y) * size_t(pl.w) + size_t(x);
  const V<D> vx = hn::LoadU(d, row.vx.data() + x), vy = hn::LoadU(d, row.vy.data() + x);
  // One NeighborMax vector on every lane (a tile's, without tile jitter): taps at a fixed offset
  // (see FixedTaps) read every plane with plain loads, their distance and whether they fall on
  // the pixel itself the same on every lane.
  const float vx0 = hn::GetLane(vx), vy0 = hn::GetLane(vy);
  bool use_fixed = pairs <= FixedTaps::kMaxPairs && hn::AllTrue(d, hn::Eq(vx, hn::Set(d, vx0))) &&
                   hn::AllTrue(d, hn::Eq(vy, hn::Set(d, vy0)));
  if (use_fixed) {
    if (!ft.has(vx0, vy0)) ft.update(pl, vx0, vy0, pairs);
    use_fixed = x + ft.min_dx >= 0 && x + int(hn::Lanes(d)) - 1 + ft.max_dx <= pl.w - 1 &&
                y + ft.min_dy >= 0 && y + ft.max_dy <= pl.h - 1;
  }
  const V<D> jit =
      !use_fixed || ft.any_free ? pixel_jitter_lanes(d, x, y) : hn::Zero(d);  // unused if fixed
  const V<D> lx = hn::LoadU(d, pl.len + ix), zx = hn::LoadU(d, pl.depth + ix);
  V<D> weight = hn::Div(hn::Set(d, 1.0f), lx), sum[3];
  const V<D> inv_lx = weight,
             inv_tenth_lx = hn::Div(hn::Set(d, 1.0f), hn::Mul(hn::Set(d, 0.1f), lx));
  for (int c = 0; c < 3; ++c) sum[c] = hn::Mul(hn::LoadU(d, pl.color[c] + ix), weight);
  for (int p = 0; p < pairs; ++p) {
    VI<D> idx[2];
    TapWindow<D> win[2];
    V<D> a[2], z[2], l[2];
    hn::Mask<D> on_self[2];
    const bool fixed[2] = {use_fixed && ft.fixed[p][0], use_fixed && ft.fixed[p][1]};
    const ptrdiff_t off[2] = {fixed[0] ? ptrdiff_t(ft.dy[p][0]) * pl.w + ft.dx[p][0] : 0,
                              fixed[1] ? ptrdiff_t(ft.dy[p][1]) * pl.w + ft.dx[p][1] : 0};
    V<D> fraction = hn::Zero(d);
    if (!fixed[0] || !fixed[1]) fraction = tap_fraction(d, jit, p, hn::Set(d, float(pairs)));
      // Both sides unrolled (as the box filter's loops), so a, z, l and the windows stay in
      // registers.
#pragma GCC unroll 2
    for (int side = 0; side < 2; ++side) {
      V<D> dist;
      if (fixed[side]) {
        const int ox = ft.dx[p][side], oy = ft.dy[p][side];
        on_self[side] = hn::FirstN(d, off[side] == 0 ? hn::Lanes(d) : 0);  // all or none
        z[side] = hn::LoadU(d, pl.depth + ptrdiff_t(ix) + off[side]);
        l[side] = hn::LoadU(d, pl.len + ptrdiff_t(ix) + off[side]);
        // The lanes' Sqrt of dx^2 + dy^2 below (float, correctly rounded: the same value).
        dist = hn::Set(d, std::sqrt(float(ox * ox + oy * oy)));
      } else {
        V<D> dx, dy;
        idx[side] = tap_index(d, pl, xs, ys, vx, vy, fraction, side == 0 ? -1.0f : 1.0f, dx, dy);
        on_self[side] = hn::RebindMask(d, hn::Eq(idx[side], self));
        win[side] = tap_window(d, idx[side], size_t(pl.w) * size_t(pl.h));
        z[side] = fetch(d, pl.depth, idx[side], win[side]);
        l[side] = fetch(d, pl.len, idx[side], win[side]);
        // dx^2 + dy^2 of whole numbers below 2^24: exact in float, as it was in integers.
        dist = hn::Sqrt(hn::Add(hn::Mul(dx, dx), hn::Mul(dy, dy)));
      }
      V<D> front, back;
      soft_depth_compare_lanes(d, z[side], zx, soft_depth, front, back);
      // One division for the tap's two weights (1 / (0.1 |V|) as ten times 1 / |V|).
      const V<D> inv_l = hn::Div(hn::Set(d, 1.0f), l[side]);
      const V<D> w = hn::Add(
          hn::Add(hn::Mul(front, cone_lanes(d, dist, inv_l)),
                  hn::Mul(back, cone_lanes(d, dist, inv_lx))),
          hn::Mul(hn::Set(d, 2.0f),
                  hn::Mul(cylinder_lanes(d, dist, l[side], hn::Mul(hn::Set(d, 10.0f), inv_l)),
                          cylinder_lanes(d, dist, lx, inv_tenth_lx))));
      a[side] = hn::IfThenZeroElse(on_self[side], w);
    }
    if (mirror) {
      // The tap in front that moves at least as fast lends its weight to its partner.
      const auto behind = hn::Gt(z[0], z[1]), faster = hn::Gt(l[1], l[0]);
      const V<D> m0 = hn::IfThenElse(hn::And(behind, faster), a[1], a[0]);
      const V<D> m1 = hn::IfThenElse(hn::Or(behind, faster), a[1], a[0]);
      a[0] = hn::IfThenZeroElse(on_self[0], m0);
      a[1] = hn::IfThenZeroElse(on_self[1], m1);
    }
#pragma GCC unroll 2
    for (int side = 0; side < 2; ++side) {
      const auto used = hn::Gt(a[side], hn::Zero(d));
      weight = hn::Add(weight, hn::IfThenElseZero(used, a[side]));
      for (int c = 0; c < 3; ++c) {
        const V<D> color = fixed[side] ? hn::LoadU(d, pl.color[c] + ptrdiff_t(ix) + off[side])
                                       : fetch(d, pl.color[c], idx[side], win[side]);
        sum[c] = hn::Add(sum[c], hn::IfThenElseZero(used, hn::Mul(a[side], color)));
      }
    }
  }
  for (int c = 0; c < 3; ++c) hn::StoreU(hn::Div(sum[c], weight), d, dst[c]);
}

// blur_half_vector on double lanes: the same operations in the same order; `sq` is the
// squared length of the result (length() is its square root).
template <class DD>
HWY_INLINE void blur_half_vector_lanes(DD dd, V<DD> mx, V<DD> my, float shutter, int max_radius,
                                       V<DD>& vx, V<DD>& vy, V<DD>& sq) {
  const V<DD> k = hn::Set(dd, -0.5 * double(shutter)), r = hn::Set(dd, double(max_radius));
  vx = hn::Mul(k, mx);
  vy = hn::Mul(k, my);
  sq = hn::Add(hn::Mul(vx, vx), hn::Mul(vy, vy));
  // Nothing clamped (most blocks): sq <= r^2 (exact, r <= 256) makes sqrt(sq) <= r, so the
  // vectors are final with no square root or division.
  if (hn::AllTrue(dd, hn::Le(sq, hn::Mul(r, r)))) return;
  const V<DD> length = hn::Sqrt(sq);
  const auto inside = hn::Le(length, r);
  const auto scalable = hn::And(hn::Gt(length, hn::Zero(dd)), hn::IsFinite(length));
  const V<DD> scale = hn::Div(r, length);
  vx = hn::IfThenElse(inside, vx, hn::IfThenElseZero(scalable, hn::Mul(vx, scale)));
  vy = hn::IfThenElse(inside, vy, hn::IfThenElseZero(scalable, hn::Mul(vy, scale)));
  sq = hn::Add(hn::Mul(vx, vx), hn::Mul(vy, vy));
}

// The half vectors of one row at a time (the whole image's would be 16 bytes a pixel).
class HalfVectorRows {
 public:
  HalfVectorRows(const Frame& f, const MotionBlurSettings& s, const FrameHeader* previous)
      : f_(f), s_(s), split_(splits_camera_motion(s)), camera_(f, s, previous) {
    check_motion_blur_camera(f, s);  // every entry point of the pass builds its rows here
  }
  // True when the half vectors are the motion times a constant (no camera split): TileMax's
  // float scan (tile_max_from_motion) applies.
  bool scaled_motion() const { return !split_; }
  // Row y's half vectors into vx, vy (width() each) and, if `sq` is given, their squared
  // lengths (x x + y y in double lanes; length() is the square root).
  void row(const Exec& exec, int y, double* vx, double* vy, double* sq = nullptr) const {
    row_part(exec, y, 0, f_.width, vx, vy, sq);
  }
  // The same for pixels x0 .. x1 - 1 of row y only (into vx[x0 .. x1 - 1], ...).
  void row_part(const Exec& exec, int y, int x0, int x1, double* vx, double* vy, double* sq) const {
    const float* mx = f_.motion.row(0, y) + x0;
    const float* my = f_.motion.row(1, y) + x0;
    vx += x0;
    vy += x0;
    if (sq) sq += x0;
    if (!split_) {
      const float shutter = s_.shutter;  // in registers: the stores below may alias s_
      const int max_radius = s_.max_radius;
      for_each_lane_block<double>(exec, x1 - x0, [&](auto dd, int x) {
        const hn::Rebind<float, decltype(dd)> df;
        __builtin_prefetch(mx + x + kRowPrefetchAhead);  // changes no value
        __builtin_prefetch(my + x + kRowPrefetchAhead);
        V<decltype(dd)> hx, hy, hq;
        blur_half_vector_lanes(dd, hn::PromoteTo(dd, hn::LoadU(df, mx + x)),
                               hn::PromoteTo(dd, hn::LoadU(df, my + x)), shutter, max_radius, hx,
                               hy, hq);
        hn::StoreU(hx, dd, vx + x);
        hn::StoreU(hy, dd, vy + x);
        if (sq) hn::StoreU(hq, dd, sq + x);
      });
      return;
    }
    split_row(y, x0, x1, mx, my, vx, vy);
    if (sq)
      for_each_lane_block<double>(exec, x1 - x0, [&](auto dd, int x) {
        const auto hx = hn::LoadU(dd, vx + x), hy = hn::LoadU(dd, vy + x);
        hn::StoreU(hn::Add(hn::Mul(hx, hx), hn::Mul(hy, hy)), dd, sq + x);
      });
  }

 private:
  // Pixels x0 .. x1 - 1 of row y; mx, my, vx, vy start at x0.
  void split_row(int y, int x0, int x1, const float* mx, const float* my, double* vx,
                 double* vy) const {
    for (int i = 0; i < x1 - x0; ++i) {
      const int x = x0 + i;
      const Vec2d m{mx[i], my[i]};
      Vec2d v{0, 0};  // unknown motion: still, as unsplit
      if (std::isfinite(m.x) && std::isfinite(m.y)) {
        const CameraMotion cam = camera_.at(x, y, f_.depth.at(x, y, 0));
        v = split_blur_half_vector(m, cam.full, cam.blur, s_.shutter, s_.camera_max_radius,
                                   s_.object_max_radius, s_.max_radius);
      }
      vx[i] = v.x;
      vy[i] = v.y;
    }
  }

  const Frame& f_;
  const MotionBlurSettings& s_;
  bool split_;
  CameraMotionSplit camera_;
};

// The largest squared length and the box of n half vectors on double lanes, one pass over
// them (the last vector overlapping the one before: maxima and minima are exact in any order
// and count a value twice harmlessly), reduced once; n < the lanes: one lane at a time.
struct RowReduction {
  double sq = -HUGE_VAL, min_x = HUGE_VAL, max_x = -HUGE_VAL, min_y = HUGE_VAL, max_y = -HUGE_VAL;
};
template <class DD>
HWY_INLINE RowReduction reduce_row(DD dd, const double* vx, const double* vy, const double* sq,
                                   int n) {
  const int lanes = int(hn::Lanes(dd));
  V<DD> q = hn::LoadU(dd, sq), hx = hn::LoadU(dd, vx), hy = hn::LoadU(dd, vy);
  V<DD> lo_x = hx, hi_x = hx, lo_y = hy, hi_y = hy;
  for (int x = lanes; x < n; x += lanes) {
    const int at = std::min(x, n - lanes);
    q = hn::Max(q, hn::LoadU(dd, sq + at));
    hx = hn::LoadU(dd, vx + at);
    hy = hn::LoadU(dd, vy + at);
    lo_x = hn::Min(lo_x, hx);
    hi_x = hn::Max(hi_x, hx);
    lo_y = hn::Min(lo_y, hy);
    hi_y = hn::Max(hi_y, hy);
  }
  return {hn::GetLane(hn::MaxOfLanes(dd, q)), hn::GetLane(hn::MinOfLanes(dd, lo_x)),
          hn::GetLane(hn::MaxOfLanes(dd, hi_x)), hn::GetLane(hn::MinOfLanes(dd, lo_y)),
          hn::GetLane(hn::MaxOfLanes(dd, hi_y))};
}

void VelocityTile::add_row(const double* vx, const double* vy, const double* sq, int n,
                           const Exec& exec) {
  const hn::ScalableTag<double> dd;
  const RowReduction r = exec.simd && n >= int(hn::Lanes(dd))
                             ? reduce_row(dd, vx, vy, sq, n)
                             : reduce_row(hn::CappedTag<double, 1>(), vx, vy, sq, n);
  // The longest length is sqrt of the largest square (sqrt is monotonic and correctly
  // rounded). The first pixel of that length: one of that square, or a square so close below
  // it that its root rounds to the same double; a square below topsq (1 - 2^-40) has a root
  // below `top` (2^-41 relative, far above a rounding), so only those closer take a sqrt.
  const double top = std::sqrt(r.sq);
  if (top > length(longest)) {
    const double near = r.sq * (1.0 - 0x1p-40);
    int i = 0;
    while (!(sq[i] == r.sq || (sq[i] >= near && std::sqrt(sq[i]) == top))) ++i;
    longest = {vx[i], vy[i]};
  }
  min_x = std::min(min_x, r.min_x);
  max_x = std::max(max_x, r.max_x);
  min_y = std::min(min_y, r.min_y);
  max_y = std::max(max_y, r.max_y);
}

// One float pass over a tile's motion (pixels x0 .. x0 + n - 1 of rows y0 .. y1 - 1): the
// largest m_x^2 + m_y^2 in float, the extremes of m_x and m_y, and whether every pixel is
// finite with that float square at most `limit`. Maxima and minima in any order (the last
// block overlaps the one before); n < the lanes: one lane at a time.
struct MotionScan {
  float sq, lo_x, hi_x, lo_y, hi_y;
  bool within;
};
template <class D>
HWY_INLINE V<D> motion_square(D d, const float* mx, const float* my, int at) {
  const V<D> a = hn::LoadU(d, mx + at), b = hn::LoadU(d, my + at);
  return hn::MulAdd(a, a, hn::Mul(b, b));
}
template <class D>
MotionScan scan_motion(D d, const ImageF& motion, int x0, int n, int y0, int y1, float limit) {
  const int lanes = int(hn::Lanes(d));
  const V<D> lim = hn::Set(d, limit);
  V<D> sq = hn::Zero(d), lo_x = hn::Set(d, HUGE_VALF), hi_x = hn::Set(d, -HUGE_VALF), lo_y = lo_x,
       hi_y = hi_x;
  auto outside = hn::Lt(sq, sq);  // no lane
  for (int y = y0; y < y1; ++y) {
    const float *mx = motion.row(0, y) + x0, *my = motion.row(1, y) + x0;
    for (int x = 0;; x += lanes) {
      const int at = std::min(x, n - lanes);
      const V<D> a = hn::LoadU(d, mx + at), b = hn::LoadU(d, my + at);
      const V<D> q = motion_square(d, mx, my, at);
      outside = hn::Or(outside, hn::Not(hn::Le(q, lim)));  // also NaN, infinite
      sq = hn::Max(sq, q);
      lo_x = hn::Min(lo_x, a);
      hi_x = hn::Max(hi_x, a);
      lo_y = hn::Min(lo_y, b);
      hi_y = hn::Max(hi_y, b);
      if (at == n - lanes) break;
    }
  }
  return {hn::GetLane(hn::MaxOfLanes(d, sq)),   hn::GetLane(hn::MinOfLanes(d, lo_x)),
          hn::GetLane(hn::MaxOfLanes(d, hi_x)), hn::GetLane(hn::MinOfLanes(d, lo_y)),
          hn::GetLane(hn::MaxOfLanes(d, hi_y)), hn::AllFalse(d, outside)};
}
// Row y of a tile (pixels x0 .. x0 + n - 1 of `motion`): whether it holds a pixel whose float
// square is at least `from` (a candidate), and whether every candidate's motion has the bits of
// the first candidate of the tile (ref, taken from this row if `has_ref` is false).
struct CandidateRow {
  bool any = false, all_ref = true;
};
template <class D>
CandidateRow candidate_row(D d, const ImageF& motion, int x0, int n, int y, float from,
                           bool& has_ref, float& ref_x, float& ref_y) {
  const hn::RebindToSigned<D> di;
  const int lanes = int(hn::Lanes(d));
  const float *mx = motion.row(0, y) + x0, *my = motion.row(1, y) + x0;
  CandidateRow row;
  for (int x = 0;; x += lanes) {
    const int at = std::min(x, n - lanes);
    const auto cand = hn::Ge(motion_square(d, mx, my, at), hn::Set(d, from));
    if (!hn::AllFalse(d, cand)) {
      const V<D> a = hn::LoadU(d, mx + at), b = hn::LoadU(d, my + at);
      if (!has_ref) {
        const size_t i = size_t(hn::FindFirstTrue(d, cand));
        ref_x = hn::ExtractLane(a, i);
        ref_y = hn::ExtractLane(b, i);
        has_ref = true;
      }
      const auto other =
          hn::Or(hn::RebindMask(d, hn::Ne(hn::BitCast(di, a), hn::BitCast(di, hn::Set(d, ref_x)))),
                 hn::RebindMask(d, hn::Ne(hn::BitCast(di, b), hn::BitCast(di, hn::Set(d, ref_y)))));
      row.any = true;
      row.all_ref = row.all_ref && hn::AllFalse(d, hn::And(cand, other));
    }
    if (at == n - lanes) return row;
  }
}

}  // namespace

namespace {
using Row = std::vector<double, DefaultInitAllocator<double>>;  // one row of half vectors

// TileMax of the frame's half vectors (tiles of max_radius pixels, row-major).
std::vector<VelocityTile> tile_max(const Frame& f, const HalfVectorRows& rows,
                                   const MotionBlurSettings& s, const Exec& exec) {
  // TileMax: the longest half vector of each k x k tile with the box that holds all its half
  // vectors (the fast path's test). One task per tile row, a tile at a time: its half vectors
  // a row at a time (double lanes, as blur_half_vector), compared by squared length (no square
  // root per pixel), or, where tile_max_from_motion proves the same tile, a float scan.
  const int w = f.width, h = f.height, k = s.max_radius;
  const int tw = (w + k - 1) / k, th = (h + k - 1) / k;
  std::vector<VelocityTile> tile(size_t(tw) * size_t(th));
  // The float scan (no camera split: half vectors v = c m, c = -shutter / 2). While c^2 |m|^2 <=
  // max_radius^2 nothing is clamped and v is the exact double product c m, so the box is c
  // times the extremes of m. The longest vector is the first pixel (row order) whose double
  // length is the tile's largest, T: the first row holding one takes it in add_row, and no row
  // after replaces it (none is longer); the rows before do not matter. A float square m_x^2 +
  // m_y^2 is within 3 2^-24 of the exact one (normal range), so each pixel of length T has one
  // at least (1 - 2^-16) times the tile's largest (a candidate), and add_row on just the rows
  // holding candidates, in order, ends with the same tile. A row whose candidates all have the
  // bits of one motion (a region that moves as one) needs no double rows: add_row would take
  // that vector if longer; a tile of one motion needs no rows at all (its first pixel's). `limit`
  // keeps c^2 |m|^2 below max_radius^2 despite the float roundings; tiles with a larger, non-finite
  // or tiny (below 1e-30, where squares lose precision) motion take the double rows. The same tiles
  // as before, bit for bit (test: PostMotionBlur.TileMaxIsTheFirstLongestHalfVectorOfEachTile).
  // `post.motion_blur` 1080p (the bench frame's tiles mostly move as one), alternating pairs:
  // the candidate rows against the double rows (3), 1 thread 8.7-9.6 -> 7.8-8.1 ms, 2 threads
  // 4.4-4.6 -> 4.1-4.2; then the one-motion tiles (4), 8.0-8.7 -> 7.4-7.7 and 4.2-4.4 -> 3.8-4.0.
  const double c = -0.5 * double(s.shutter), r2 = double(k) * double(k);
  const double flt_max = std::numeric_limits<float>::max();
  const double limit_d = c == 0.0 ? flt_max : std::min(r2 / (c * c) * (1.0 - 0x1p-20), flt_max);
  float limit = float(limit_d);
  if (double(limit) > limit_d) limit = std::nextafter(limit, 0.0f);
  // vx, vy, sq: a task's rows (the image's width), written at x0 .. x0 + n - 1.
  const auto tile_max_from_motion = [&](VelocityTile& t, int x0, int n, int y0, int y1, Row& vx,
                                        Row& vy, Row& sq) {
    const FullTag d;
    const bool wide = exec.simd && n >= int(hn::Lanes(d));
    const MotionScan m = wide ? scan_motion(d, f.motion, x0, n, y0, y1, limit)
                              : scan_motion(OneTag(), f.motion, x0, n, y0, y1, limit);
    if (!m.within) return false;
    const bool still = m.lo_x == 0.0f && m.hi_x == 0.0f && m.lo_y == 0.0f && m.hi_y == 0.0f;
    if (m.sq < 1e-30f && !still) return false;
    const double ax = c * double(m.lo_x), bx = c * double(m.hi_x);
    const double ay = c * double(m.lo_y), by = c * double(m.hi_y);
    t.min_x = std::min(t.min_x, std::min(ax, bx));
    t.max_x = std::max(t.max_x, std::max(ax, bx));
    t.min_y = std::min(t.min_y, std::min(ay, by));
    t.max_y = std::max(t.max_y, std::max(ay, by));
    if (still) return true;  // every half vector is +-0: longest stays (0, 0)
    if (m.lo_x == m.hi_x && m.lo_y == m.hi_y) {
      // One motion (up to the sign of a zero): every pixel is as long as the first, the one
      // add_row takes.
      const Vec2d v{c * double(f.motion.at(x0, y0, 0)), c * double(f.motion.at(x0, y0, 1))};
      if (length(v) > length(t.longest)) t.longest = v;
      return true;
    }
    const float from = m.sq * (1.0f - 0x1p-16f);
    bool has_ref = false;
    float ref_x = 0.0f, ref_y = 0.0f;
    for (int y = y0; y < y1; ++y) {
      const CandidateRow row =
          wide ? candidate_row(d, f.motion, x0, n, y, from, has_ref, ref_x, ref_y)
               : candidate_row(OneTag(), f.motion, x0, n, y, from, has_ref, ref_x, ref_y);
      if (!row.any) continue;
      if (row.all_ref) {
        // add_row of this row: its largest square is the candidates', all the reference's
        // (the first of them in x order has its vector).
        const Vec2d v{c * double(ref_x), c * double(ref_y)};
        if (length(v) > length(t.longest)) t.longest = v;
        continue;
      }
      rows.row_part(exec, y, x0, x0 + n, vx.data(), vy.data(), sq.data());
      t.add_row(vx.data() + x0, vy.data() + x0, sq.data() + x0, n, exec);
    }
    return true;
  };
  parallel_row_ranges(exec, th, [&](int ty0, int ty1) {
    Row vx(static_cast<size_t>(w)), vy(static_cast<size_t>(w)), sq(static_cast<size_t>(w));
    for (int ty = ty0; ty < ty1; ++ty) {
      const int y0 = ty * k, y1 = std::min(h, (ty + 1) * k);
      // Prefetches (they change no value): a tile's k rows of both planes are as many streams,
      // more than the hardware prefetchers follow, and in a chain the motion is no longer in the
      // cache. While a tile row is scanned, the same tile of the next tile row goes into L2 (k
      // rows of both planes: 120 KB a tile row at 1080p), ready when this thread goes on to that
      // row; the first tile row of a range has had none, so it prefetches the tile two ahead in
      // its own rows instead.
      // TileMax alone on the 1080p bench frame, caches evicted before each call, 60 alternating
      // rounds in one process, against the two-ahead prefetch alone (de5f50a): 2 threads
      // 1.89 -> 0.89 ms (-0.95 +- 0.08), 1 thread 2.23 -> 1.15 (-1.09 +- 0.04); the two-ahead
      // prefetch on every tile row as well no better (-0.06 +- 0.06); the next tile row only
      // within the thread's range, 2 threads -0.04 +- 0.06 (TBB's ranges are short); into L1
      // instead of L2, +0.76 ms.
      const bool next = ty + 1 < th, first = ty == ty0;
      for (int tx = 0; tx < tw; ++tx) {
        VelocityTile& t = tile[size_t(ty) * size_t(tw) + size_t(tx)];
        const int x0 = tx * k, n = std::min(w, x0 + k) - x0;
        if (next)
          for (int y = y1; y < std::min(h, y1 + k); ++y)
            for (int c = 0; c < 2; ++c) {
              const float* row = f.motion.row(c, y);
              __builtin_prefetch(row + x0, 0, 2);
              __builtin_prefetch(row + x0 + n - 1, 0, 2);
            }
        if (const int xp = x0 + 2 * k; first && xp < w)
          for (int y = y0; y < y1; ++y)
            for (int c = 0; c < 2; ++c) {
              const float* row = f.motion.row(c, y);
              __builtin_prefetch(row + xp);
              __builtin_prefetch(row + std::min(w - 1, xp + k - 1));
            }
        if (rows.scaled_motion() && tile_max_from_motion(t, x0, n, y0, y1, vx, vy, sq)) continue;
        for (int y = y0; y < y1; ++y) {
          rows.row_part(exec, y, x0, x0 + n, vx.data(), vy.data(), sq.data());
          t.add_row(vx.data() + x0, vy.data() + x0, sq.data() + x0, n, exec);
        }
      }
    }
  });
  return tile;
}

}  // namespace

ImageF motion_blur_half_vectors(const Frame& f, const MotionBlurSettings& s,
                                const FrameHeader* previous, const Exec& exec) {
  s.validate();
  check_motion_blur_input(f, nullptr);
  const HalfVectorRows rows(f, s, previous);
  ImageF out = ImageF::uninitialized(f.width, f.height, 2);
  parallel_rows(exec, f.height, [&](int y) {
    std::vector<double> vx(size_t(f.width)), vy(size_t(f.width));
    rows.row(exec, y, vx.data(), vy.data());
    for (int x = 0; x < f.width; ++x) {
      out.at(x, y, 0) = float(vx[size_t(x)]);
      out.at(x, y, 1) = float(vy[size_t(x)]);
    }
  });
  return out;
}

std::vector<MotionTile> motion_blur_tile_max(const Frame& f, const MotionBlurSettings& s,
                                             const FrameHeader* previous, const Exec& exec) {
  s.validate();
  check_motion_blur_input(f, nullptr);
  std::vector<MotionTile> out;
  for (const VelocityTile& t : tile_max(f, HalfVectorRows(f, s, previous), s, exec))
    out.push_back({t.longest, t.min_x, t.max_x, t.min_y, t.max_y});
  return out;
}

ImageF motion_blur_fast(const Frame& f, const ImageF& color, const MotionBlurSettings& s,
                        const FrameHeader* previous, const Exec& exec) {
  s.validate();
  check_motion_blur_input(f, &color);
  const int w = color.width(), h = color.height(), k = s.max_radius;
  const HalfVectorRows rows(f, s, previous);
  const int tw = (w + k - 1) / k, th = (h + k - 1) / k;
  const std::vector<VelocityTile> tile = tile_max(f, rows, s, exec);
  std::vector<VelocityTile> neighbor(tile.size());
  // NeighborMax: the same over the 3x3 tiles around.
  parallel_rows(exec, th, [&](int ty) {
    for (int tx = 0; tx < tw; ++tx) {
      VelocityTile n;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int ux = tx + dx, uy = ty + dy;
          if (ux < 0 || uy < 0 || ux >= tw || uy >= th) continue;
          n.merge(tile[size_t(uy) * size_t(tw) + size_t(ux)]);
        }
      neighbor[size_t(ty) * size_t(tw) + size_t(tx)] = n;
    }
  });
  // A pixel's path from its NeighborMax: still neighbourhood: copy (early exit); one that moves
  // as one: fast; else full.
  const auto path_of = [&](const VelocityTile& nb) {
    return length(nb.longest) <= 0.5                                    ? kCopy
           : s.uniform_tolerance > 0 && nb.uniform(s.uniform_tolerance) ? kFast
                                                                        : kFull;
  };
  // Each tile's path, once (the rows' pre-passes had taken a square root a tile a row: 3.5% of
  // `post.motion_blur`'s samples at 1080p on a Zen 3).
  std::vector<uint8_t> tile_path(neighbor.size());
  for (size_t i = 0; i < neighbor.size(); ++i) tile_path[i] = path_of(neighbor[i]);
  // |V| of the pixels the full path reads, floored at half a pixel as McGuire's weights need
  // (computed once: the taps read it up to samples times): a full-path pixel reads its own and
  // its taps', at most max_radius = k px away, so within the 3x3 tiles around its own; its
  // path is its lookup tile's, its own or (tile jitter) a neighbour. A block of mixed paths
  // runs the full path on all its lanes (keeping each lane's own), and its other lanes lie in
  // a tile next to a full-path lane's. So a tile needs |V| when a full tile lies within 2
  // tiles (3 with tile jitter); elsewhere the plane is never read and stays unwritten (a
  // square root per pixel of the whole frame had been a third of the pass before the blur).
  std::vector<float, DefaultInitAllocator<float>> len(size_t(w) * size_t(h));
  {
    std::vector<uint8_t> full(tile.size()), needs(tile.size(), 0);
    for (size_t i = 0; i < tile.size(); ++i) full[i] = tile_path[i] == kFull;
    const int reach = s.tile_jitter > 0 ? 3 : 2;
    std::vector<uint8_t> row_needs(size_t(th), 0);
    for (int ty = 0; ty < th; ++ty)
      for (int tx = 0; tx < tw; ++tx)
        for (int uy = std::max(0, ty - reach); uy <= std::min(th - 1, ty + reach); ++uy)
          for (int ux = std::max(0, tx - reach); ux <= std::min(tw - 1, tx + reach); ++ux)
            if (full[size_t(uy) * size_t(tw) + size_t(ux)]) {
              needs[size_t(ty) * size_t(tw) + size_t(tx)] = 1;
              row_needs[size_t(ty)] = 1;
            }
    parallel_rows(exec, th, [&](int ty) {
      if (!row_needs[size_t(ty)]) return;
      Row vx(static_cast<size_t>(w)), vy(static_cast<size_t>(w)), sq(static_cast<size_t>(w));
      for (int y = ty * k; y < std::min(h, (ty + 1) * k); ++y) {
        float* lr = len.data() + size_t(y) * size_t(w);
        for (int tx = 0; tx < tw; ++tx) {
          if (!needs[size_t(ty) * size_t(tw) + size_t(tx)]) continue;
          const int x0 = tx * k, x1 = std::min(w, x0 + k);
          rows.row_part(exec, y, x0, x1, vx.data(), vy.data(), sq.data());
          for_each_lane_block<double>(exec, x1 - x0, [&](auto dd, int i) {
            const hn::Rebind<float, decltype(dd)> df;
            const auto l = hn::Sqrt(hn::LoadU(dd, sq.data() + x0 + i));
            hn::StoreU(hn::DemoteTo(df, hn::Max(l, hn::Set(dd, 0.5))), df, lr + x0 + i);
          });
        }
      }
    });
  }

  ImageF out = ImageF::uninitialized(w, h, 3);  // every pixel written below (copy or blur)
  const int pairs = (s.samples - 1) / 2;
  const BlurPlanes planes{w,
                          h,
                          size_t(w) * size_t(h) < size_t(1) << 23,
                          len.data(),
                          f.depth.plane(0),
                          {color.plane(0), color.plane(1), color.plane(2)}};
  // Rows y .. y + n_rows - 1 (n_rows 2 only for rows of one tile row without tile jitter, whose
  // pre-passes are the same).
  const auto blur_rows = [&](int y, int n_rows) {
    // Row pre-pass: each pixel's NeighborMax (through the jittered tile lookup), tap jitter and
    // path — still neighbourhood: copy (early exit); one that moves as one: fast; else full.
    BlurRow row;
    row.vx.resize(size_t(w));
    row.vy.resize(size_t(w));
    row.path.resize(size_t(w));
    const double jt = s.tile_jitter;
    if (jt == 0) {  // every pixel of a tile reads its own tile: filled a tile at a time
      for (int tx = 0; tx < tw; ++tx) {
        const VelocityTile& nb = neighbor[size_t(y / k) * size_t(tw) + size_t(tx)];
        const size_t x0 = size_t(tx) * size_t(k), x1 = std::min(size_t(w), x0 + size_t(k));
        std::fill(row.vx.begin() + ptrdiff_t(x0), row.vx.begin() + ptrdiff_t(x1),
                  float(nb.longest.x));
        std::fill(row.vy.begin() + ptrdiff_t(x0), row.vy.begin() + ptrdiff_t(x1),
                  float(nb.longest.y));
        std::fill(row.path.begin() + ptrdiff_t(x0), row.path.begin() + ptrdiff_t(x1),
                  tile_path[size_t(y / k) * size_t(tw) + size_t(tx)]);
      }
    } else {
      for (int x = 0; x < w; ++x) {
        const int tx = jittered_tile(x, 2.0 * jt * tile_jitter_hash(x, y, 1u), k, tw);
        const int ty = jittered_tile(y, 2.0 * jt * tile_jitter_hash(x, y, 2u), k, th);
        const VelocityTile& nb = neighbor[size_t(ty) * size_t(tw) + size_t(tx)];
        row.vx[size_t(x)] = float(nb.longest.x);
        row.vy[size_t(x)] = float(nb.longest.y);
        row.path[size_t(x)] = tile_path[size_t(ty) * size_t(tw) + size_t(tx)];
      }
    }
    FixedTaps fixed_taps, full_fixed_taps;  // each path's fixed taps of its last half vector
    const auto copy_block = [&](auto d, int x, int yr) {
      for (int c = 0; c < 3; ++c)
        hn::StoreU(hn::LoadU(d, color.row(c, yr) + x), d, out.row(c, yr) + x);
    };
    const auto fast_block = [&](auto d, int x, int yr, float* const(&o)[3]) {
      const int ys[1] = {yr};
      float* const os[1][3] = {{o[0], o[1], o[2]}};
      box_rows<1>(d, planes, row, x, ys, pairs, s.fast_tap_spacing, fixed_taps, os);
    };
    const auto full = [&](auto d, int x, int yr, float* const(&o)[3]) {
      full_block(d, planes, row, x, yr, pairs, s.soft_depth, s.mirror_weights, full_fixed_taps, o);
    };
    const auto at = [&](int x, int yr) {
      return std::array<float*, 3>{out.row(0, yr) + x, out.row(1, yr) + x, out.row(2, yr) + x};
    };
    const auto one_pixel = [&](int x, int yr) {
      const OneTag d1;
      const auto a = at(x, yr);
      float* const o[3] = {a[0], a[1], a[2]};
      if (row.path[size_t(x)] == kFast)
        fast_block(d1, x, yr, o);
      else if (row.path[size_t(x)] == kFull)
        full(d1, x, yr, o);
      else
        copy_block(d1, x, yr);
    };
    for_each_lane_block(exec, w, [&](auto d, int x) {
      const int n = int(hn::Lanes(d));
      // The rows' colour planes and outputs some lines ahead (a prefetch changes no value).
      for (int yr = y; yr < y + n_rows; ++yr)
        for (int c = 0; c < 3; ++c) {
          __builtin_prefetch(color.row(c, yr) + x + kRowPrefetchAhead);
          __builtin_prefetch(out.row(c, yr) + x + kRowPrefetchAhead, 1);
        }
      if (n == 1) {
        for (int yr = y; yr < y + n_rows; ++yr) one_pixel(x, yr);
        return;
      }
      const uint8_t first = row.path[size_t(x)];
      // The block's paths, 16 bytes at a time (a byte loop per block had cost ~3 operations a
      // pixel).
      bool same = true, has_fast = false, has_full = false;
      if (n % 16 == 0) {
        for (int i = 0; i < n; i += 16) {
          const hn::FixedTag<uint8_t, 16> d8;
          const auto paths = hn::LoadU(d8, row.path.data() + x + i);
          same = same && hn::AllTrue(d8, hn::Eq(paths, hn::Set(d8, first)));
          has_fast = has_fast || !hn::AllFalse(d8, hn::Eq(paths, hn::Set(d8, uint8_t(kFast))));
          has_full = has_full || !hn::AllFalse(d8, hn::Eq(paths, hn::Set(d8, uint8_t(kFull))));
        }
      } else {
        for (int i = 0; i < n; ++i) {
          same = same && row.path[size_t(x + i)] == first;
          has_fast = has_fast || row.path[size_t(x + i)] == kFast;
          has_full = has_full || row.path[size_t(x + i)] == kFull;
        }
      }
      if (same && first == kFast && n_rows == 2) {  // both rows' box filters together
        const auto a = at(x, y), b = at(x, y + 1);
        const int ys[2] = {y, y + 1};
        float* const os[2][3] = {{a[0], a[1], a[2]}, {b[0], b[1], b[2]}};
        box_rows<2>(d, planes, row, x, ys, pairs, s.fast_tap_spacing, fixed_taps, os);
        return;
      }
      for (int yr = y; yr < y + n_rows; ++yr) {
        const auto a = at(x, yr);
        float* const o[3] = {a[0], a[1], a[2]};
        if (!same) {
          // A mixed block (a tile edge inside it): each path present runs on every lane into
          // scratch and each pixel keeps its own path's result. Lanes are independent, so these
          // are the bits of the pixel-by-pixel (1-lane) path, which cost 16x per pixel.
          alignas(64) float fast_out[3][kMaxLanes], full_out[3][kMaxLanes];
          float* const fo[3] = {fast_out[0], fast_out[1], fast_out[2]};
          float* const uo[3] = {full_out[0], full_out[1], full_out[2]};
          if (has_fast) fast_block(d, x, yr, fo);
          if (has_full) full(d, x, yr, uo);
          for (int i = 0; i < n; ++i) {
            const uint8_t path = row.path[size_t(x + i)];
            for (int c = 0; c < 3; ++c)
              o[c][i] = path == kFast   ? fast_out[c][i]
                        : path == kFull ? full_out[c][i]
                                        : color.row(c, yr)[x + i];
          }
        } else if (first == kFast) {
          fast_block(d, x, yr, o);
        } else if (first == kFull) {
          full(d, x, yr, o);
        } else {
          copy_block(d, x, yr);
        }
      }
    });
  };
  parallel_rows(exec, (h + 1) / 2, [&](int pair) {
    const int y = 2 * pair;
    if (y + 1 < h && s.tile_jitter == 0 && y / k == (y + 1) / k) {
      blur_rows(y, 2);
    } else {
      blur_rows(y, 1);
      if (y + 1 < h) blur_rows(y + 1, 1);
    }
  });
  return out;
}

}  // namespace afterimage::post
