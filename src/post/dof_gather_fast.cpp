// The depth-of-field gather's fast schedule (dof.h; its plain statement is dof_reference.cpp,
// which it equals bit for bit): tiles with their tap sets built once per neighbourhood radius,
// depth classes and uniform tiles that drop work a tap, lane blocks of four rows sharing each
// source pixel's loads, and the half-resolution layers.
#include "post/dof_gather_fast.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <type_traits>
#include <utility>
#include <vector>

#include "camera/camera.h"
#include "core/lanes.h"
#include "core/prefetch.h"
#include "post/tiles.h"

namespace afterimage::post {

std::vector<float> tile_neighbor_max(const std::vector<float>& tile, int tw, int th) {
  return tile_neighbor_reduce(tile, tw, th, 0.0f, [](float a, float b) { return std::max(a, b); });
}

namespace {
// std::lround of a float (half away from zero) without the library call: x - trunc(x) is
// exact, so the comparison with 0.5 decides as lround does.
inline int round_half_away(float x) {
  const float t = std::trunc(x), r = x - t;
  return int(t) + (r >= 0.5f ? 1 : 0) - (r <= -0.5f ? 1 : 0);
}

// A gather tap: whole-pixel offset, its distance, how many spiral taps merged into it, and its
// offset in the padded planes and in the color planes the gather reads (gather_tiles).
// inner: the tap covers every pixel of the tile fully (set per tap set for the tile's smallest
// neighbourhood radius, gather_tiles).
// dist: bokeh_distance behind the focus plane, dist_front in front of it (equal for a disc or
// an even blade count); edge, edge_front: tap_edge of each.
struct GatherTap {
  int dx, dy;
  float dist, count, edge;  // edge: tap_edge(count, dist)
  ptrdiff_t offset, color_offset;
  bool inner = false;
  float dist_front = 0.0f, edge_front = 0.0f;
};
struct GatherPlanes {
  const float *r, *z, *inv_area, *color[3];
};
// A tile's depth class: every depth of its neighbourhood in front of the focus plane (0 < z <=
// s), behind it (s <= z, finite), or mixed (also non-finite, non-positive depths). The gather
// radius is monotone on each side for every such depth (gather_radius_lanes, dof.h).
enum DepthSide : uint8_t { kDepthMixed = 0, kDepthNear = 1, kDepthFar = 2 };

// A block's own pixels, the start of gather_block's sums: their radius, depth (mixed tiles
// only) and own weight (center / r^2), and their colors times it.
template <int kSide, bool kInput, int kRows, class D>
HWY_INLINE void gather_start(D d, const GatherPlanes& p, float center, const size_t (&i)[kRows],
                             const size_t (&ci)[kRows], V<D> (&rp)[kRows], V<D> (&zp)[kRows],
                             V<D> (&wsum)[kRows], V<D> (&sum)[kRows][3]) {
  for (int r = 0; r < kRows; ++r) {
    rp[r] = hn::LoadU(d, p.r + i[r]);
    zp[r] = kSide == kDepthMixed ? hn::LoadU(d, p.z + (kInput ? ci[r] : i[r])) : hn::Zero(d);
    wsum[r] = hn::Mul(hn::Set(d, center), hn::LoadU(d, p.inv_area + i[r]));
    for (int c = 0; c < 3; ++c)
      sum[r][c] = hn::Mul(wsum[r], hn::LoadU(d, p.color[c] + (kInput ? ci[r] : i[r])));
  }
}
// The sums over the weight: one division a row and three multiplies instead of three divisions
// (within an ulp of the quotients). The output is written with streaming stores (core/simd.h
// store_streaming; the same bits), here and in the uniform tiles' blocks: a block writes 12
// lines (4 rows x 3 planes) of a strip that is not read again in the pass, and the ordinary
// store first read each line in. On an Emerald Rapids Xeon VM (`bench --filter 'post.dof$'
// --sizes 1920x1080`, 8 alternating pairs, medians) 1 thread 22.7 -> 18.2 ms, 2 threads 14.0
// -> 10.5; the chain less (motion blur then reads this output from memory, not the L3): 2
// threads -1.4 ms over 40 pairs, 4K -16 ms (486411e; docs/perf/2026-log.md). gather_tiles
// fences each task's stores.
template <int kRows, class D>
HWY_INLINE void gather_store(D d, const V<D> (&wsum)[kRows], const V<D> (&sum)[kRows][3],
                             float* const (&dst)[kRows][3], int x) {
  for (int r = 0; r < kRows; ++r) {
    const V<D> inv = hn::Div(hn::Set(d, 1.0f), wsum[r]);
    for (int c = 0; c < 3; ++c) store_streaming(hn::Mul(sum[r][c], inv), d, dst[r][c] + x);
  }
}

// Scatter-as-gather at the lanes of one block (pixels at padded index i .. i + lanes - 1):
// the pixel itself spread over its own disc (weight center / r_p^2, `center` the spiral taps
// that round to the pixel itself, at least 1), then every tap whose disc, after the depth order
// (effective_radius), covers the pixel (disc_coverage), weighted by count / r_q^2. A tap of
// weight 0 adds nothing (masked), as if skipped.
//
// kRows blocks of as many rows (padded indices i[r]) share each tap's loop iteration: their
// sums are independent chains, so the out-of-order core overlaps one row's loads and adds
// with the other's (each pixel's operations and their order are unchanged). Four rows a tap
// took 15-21% fewer samples than two in the full-resolution gather (1080p bench frame); the
// layers' gather keeps two (eight sums a row: four rows would not fit the 32 registers). Blocks
// of four rows now take gather_block_sources (below), which loads each pixel once for all four;
// gather_block serves the blocks of two and one row.
//
// kSide: the depth class of the tile's neighbourhood (DepthSide). Where every depth lies on one
// side of the focus plane the radius is monotone in depth, so effective_radius needs no depth:
// in front (near) a tap behind p has r_q <= r_p, so it is r_q; behind (far) a tap in front has
// r_q <= r_p and one behind r_q >= r_p, so it is min(r_q, r_p) either way. The same values, one
// load and two or three operations fewer per tap.
//
// kInput: p.color and p.z are the input's planes (indices ci, tap offsets color_offset) instead
// of the padded copies: the same values inside the image; a tap outside it reads a neighbouring
// row's pixel instead of 0, which its weight 0 masks (the caller keeps every read inside the
// planes).
//
// A tap's colors are added only where its weight is positive (0 times an infinite color is
// NaN), as a fused multiply-add under that mask: AVX-512 merges the mask into the FMA, which
// measured as fast as the unmasked sum.
//
// kFlip (mixed tiles of an odd-bladed bokeh): each tap's edge by the side of the focus plane
// its pixel lies on (depth below `front_of`: edge_front); a near tile takes edge_front, a far
// one edge, whatever kFlip.
template <int kRows, int kSide, bool kInput, bool kFlip = false, class D>
HWY_INLINE void gather_block(D d, const GatherPlanes& p, const std::vector<GatherTap>& taps,
                             float center, const size_t (&i)[kRows], const size_t (&ci)[kRows],
                             float* const (&dst)[kRows][3], int x, float front_of = 0.0f) {
  V<D> rp[kRows], zp[kRows], wsum[kRows], sum[kRows][3];
  gather_start<kSide, kInput>(d, p, center, i, ci, rp, zp, wsum, sum);
  const V<D> zero = hn::Zero(d);
  // Row r's sums take tap weight wq and the tap's colors at cq, where wq is positive: the
  // others (+0 from a zero coverage or 1 / r^2, or negative from a coverage left unclamped
  // below, see tap_coverage) add nothing. Adding a +0 to the positive wsum gave its bits, so
  // the masked add is the clamped form's result without the clamp at 0 (one operation fewer a
  // tap-row: the gather is partly bound by its vector operations).
  const auto add_tap = [&](int r, V<D> wq, size_t cq) {
    const auto used = hn::Gt(wq, zero);
    wsum[r] = hn::IfThenElse(used, hn::Add(wsum[r], wq), wsum[r]);
    for (int c = 0; c < 3; ++c)
      sum[r][c] =
          hn::IfThenElse(used, hn::MulAdd(wq, hn::LoadU(d, p.color[c] + cq), sum[r][c]), sum[r][c]);
  };
  for (const GatherTap& t : taps) {
    // An inner tap covers every pixel fully (gather_tiles: its coverage is `count` at every
    // radius of the neighbourhood), so its weight is count / r_q^2 with no radius, depth or
    // clamp: the same value.
    if (t.inner) {
      const V<D> count = hn::Set(d, t.count);
      for (int r = 0; r < kRows; ++r) {
        const size_t q = size_t(ptrdiff_t(i[r]) + t.offset);
        add_tap(r, hn::Mul(count, hn::LoadU(d, p.inv_area + q)),
                kInput ? size_t(ptrdiff_t(ci[r]) + t.color_offset) : q);
      }
      continue;
    }
    const V<D> count = hn::Set(d, t.count),
               edge = hn::Set(d, kSide == kDepthNear ? t.edge_front : t.edge);
    for (int r = 0; r < kRows; ++r) {
      const size_t q = size_t(ptrdiff_t(i[r]) + t.offset);
      const size_t cq = kInput ? size_t(ptrdiff_t(ci[r]) + t.color_offset) : q;
      const V<D> rq = hn::LoadU(d, p.r + q);
      // effective_radius: a tap behind the pixel covers it at most with the pixel's radius.
      V<D> re, e = edge;
      if constexpr (kSide == kDepthNear) {
        re = rq;
      } else if constexpr (kSide == kDepthFar) {
        re = hn::Min(rq, rp[r]);
      } else {
        const V<D> zq = hn::LoadU(d, p.z + cq);
        re = hn::IfThenElse(hn::Gt(zq, zp[r]), hn::Min(rq, rp[r]), rq);
        if constexpr (kFlip)
          e = hn::IfThenElse(hn::Lt(zq, hn::Set(d, front_of)), hn::Set(d, t.edge_front), edge);
      }
      // tap_coverage, clamp(count r + edge, 0, count), without the clamp at 0: where the
      // coverage is not positive, neither is the weight, which add_tap then leaves out.
      const V<D> cov = hn::Min(hn::MulAdd(count, re, e), count);
      add_tap(r, hn::Mul(cov, hn::LoadU(d, p.inv_area + q)), cq);
    }
  }
  gather_store(d, wsum, sum, dst, x);
}

// A block of 4 (or 2: kSourceRows) rows' taps by the pixels they read. Row r's tap (dx, dy)
// reads the pixel (dx, dy + r) from the block's first row, which row r + 1 reads as its tap (dx,
// dy - 1), and so on: gather_block loads each tap-row's radius, 1 / r^2 and colors (5 vectors, 6
// with the depth), so a pixel up to four times. Loads bound the gather on an AMD Zen 4 core (one
// 512-bit load a cycle: a probe that left out two of a tap-row's color loads took 23% off
// `post.dof`), so gather_block_sources loads each pixel once and hands it to every row that has a
// tap there. Visited in the order of (dy + r, dx), each row meets its taps in row order,
// gather_block's order: the same sums bit for bit. `rows` bit r: row r has a tap on this pixel, of
// `count`, `edge` and `edge_front` (GatherTap). The inner taps' shortcut (GatherTap::inner) is left
// out: the full weight has the same value, and the shortcut measured no faster here.
struct SourceEntry {
  ptrdiff_t offset, color_offset;  // from the block's first row: padded planes, color planes
  uint32_t rows;
  float count[4], edge[4], edge_front[4];
};
// The same for a uniform tile's taps (UniformTaps): row r's weight.
struct UniformSource {
  ptrdiff_t offset, color_offset;
  uint32_t rows;
  float weight[4];
};

// Entries (SourceEntry, UniformSource) of taps at offsets dxdy (row order, every |dx|, |dy| <=
// reach) for blocks of `rows` rows (2 or 4): fill(entry, r, t) sets row r's tap t. Each row's
// taps come in row order: a row's sources (dy + r, dx) are visited in the order of (dy + r, dx).
template <class Entry, class Fill>
std::vector<Entry> source_entries(const std::vector<std::pair<int, int>>& dxdy, int reach,
                                  ptrdiff_t pitch, ptrdiff_t color_pitch, int rows, Fill&& fill) {
  // first[dy + reach] .. first[dy + reach + 1]: the taps of row dy (in dx order).
  const int span = 2 * reach + 1;
  std::vector<size_t> first(size_t(span) + 1, 0);
  for (const auto& [dx, dy] : dxdy) ++first[size_t(dy + reach) + 1];
  for (int r = 0; r < span; ++r) first[size_t(r) + 1] += first[size_t(r)];
  std::vector<Entry> e;
  e.reserve(std::min(size_t(rows) * dxdy.size(), size_t(span + rows - 1) * size_t(span)));
  // Source row sy: row r's taps of dy = sy - r, merged by dx.
  for (int sy = -reach; sy <= reach + rows - 1; ++sy) {
    size_t at[4] = {}, end[4] = {};
    for (int r = 0; r < rows; ++r) {
      const int dy = sy - r;
      const bool in = dy >= -reach && dy <= reach;
      at[r] = in ? first[size_t(dy + reach)] : 0;
      end[r] = in ? first[size_t(dy + reach) + 1] : 0;
    }
    for (;;) {
      int dx = std::numeric_limits<int>::max();
      for (int r = 0; r < rows; ++r)
        if (at[r] < end[r]) dx = std::min(dx, dxdy[at[r]].first);
      if (dx == std::numeric_limits<int>::max()) break;
      e.push_back({});
      e.back().offset = ptrdiff_t(sy) * pitch + dx;
      e.back().color_offset = ptrdiff_t(sy) * color_pitch + dx;
      for (int r = 0; r < rows; ++r)
        if (at[r] < end[r] && dxdy[at[r]].first == dx) {
          e.back().rows |= 1u << r;
          fill(e.back(), r, at[r]++);
        }
    }
  }
  return e;
}

std::vector<SourceEntry> source_entries(const std::vector<GatherTap>& taps, ptrdiff_t pitch,
                                        ptrdiff_t color_pitch, int rows) {
  std::vector<std::pair<int, int>> dxdy;
  int reach = 0;
  for (const GatherTap& t : taps) {
    dxdy.push_back({t.dx, t.dy});
    reach = std::max({reach, std::abs(t.dx), std::abs(t.dy)});
  }
  return source_entries<SourceEntry>(dxdy, reach, pitch, color_pitch, rows,
                                     [&](SourceEntry& e, int r, size_t t) {
                                       e.count[r] = taps[t].count;
                                       e.edge[r] = taps[t].edge;
                                       e.edge_front[r] = taps[t].edge_front;
                                     });
}

// f(std::integral_constant<int, r>{}) for each bit r of `rows` (r < kRows, 2 or 4), in
// increasing r: a source entry's rows, each with its own registers.
template <int kRows, class F>
HWY_INLINE void for_each_row_of(uint32_t rows, F&& f) {
  if (rows & 1u) f(std::integral_constant<int, 0>{});
  if (rows & 2u) f(std::integral_constant<int, 1>{});
  if constexpr (kRows > 2) {
    if (rows & 4u) f(std::integral_constant<int, 2>{});
    if (rows & 8u) f(std::integral_constant<int, 3>{});
  }
}

// gather_block's sums for kRows rows (2 or 4: kSourceRows) over the taps' source pixels
// (SourceEntry). kMasked: each tap-row added under its weight's mask, as gather_block.
// Otherwise the weight clamped at +0 and added unmasked: the same sums wherever every tap of
// zero weight reads a finite color (it adds +0, or 0 times the color: a zero, which leaves a
// sum's bits unchanged but for the sign of a zero sum), and NaN wherever one does not (0 times
// an infinity or a NaN), which gather_block_sources then recomputes masked. AVX2 has no masked
// fused multiply-add (a blend after each: four of a tap-row's 13 operations); AVX-512 merges the
// mask for free.
template <int kRows, int kSide, bool kInput, bool kFlip, bool kMasked, class D>
HWY_INLINE void gather_sources_sums(D d, const GatherPlanes& p,
                                    const std::vector<SourceEntry>& sources, float center,
                                    const size_t (&i)[kRows], const size_t (&ci)[kRows],
                                    float front_of, V<D> (&wsum)[kRows], V<D> (&sum)[kRows][3]) {
  V<D> rp[kRows], zp[kRows];
  gather_start<kSide, kInput>(d, p, center, i, ci, rp, zp, wsum, sum);
  const V<D> zero = hn::Zero(d);
  const float *const r0 = p.r + i[0], *const ia0 = p.inv_area + i[0];
  const size_t c0 = kInput ? ci[0] : i[0];
  const float* const z0 = p.z + c0;
  const float* const color0[3] = {p.color[0] + c0, p.color[1] + c0, p.color[2] + c0};
  for (const SourceEntry& e : sources) {
    const ptrdiff_t cq = kInput ? e.color_offset : e.offset;
    const V<D> rq = hn::LoadU(d, r0 + e.offset), ia = hn::LoadU(d, ia0 + e.offset);
    const V<D> zq = kSide == kDepthMixed ? hn::LoadU(d, z0 + cq) : zero;
    V<D> col[3];
    for (int c = 0; c < 3; ++c) col[c] = hn::LoadU(d, color0[c] + cq);
    const auto row = [&](auto rc) {
      constexpr int r = decltype(rc)::value;
      const V<D> count = hn::Set(d, e.count[r]);
      // effective_radius (gather_block)
      V<D> re, edge = hn::Set(d, kSide == kDepthNear ? e.edge_front[r] : e.edge[r]);
      if constexpr (kSide == kDepthNear) {
        re = rq;
      } else if constexpr (kSide == kDepthFar) {
        re = hn::Min(rq, rp[r]);
      } else {
        re = hn::IfThenElse(hn::Gt(zq, zp[r]), hn::Min(rq, rp[r]), rq);
        if constexpr (kFlip)
          edge =
              hn::IfThenElse(hn::Lt(zq, hn::Set(d, front_of)), hn::Set(d, e.edge_front[r]), edge);
      }
      const V<D> wq = hn::Mul(hn::Min(hn::MulAdd(count, re, edge), count), ia);
      if constexpr (kMasked) {
        const auto used = hn::Gt(wq, zero);
        wsum[r] = hn::IfThenElse(used, hn::Add(wsum[r], wq), wsum[r]);
        for (int c = 0; c < 3; ++c)
          sum[r][c] = hn::IfThenElse(used, hn::MulAdd(wq, col[c], sum[r][c]), sum[r][c]);
      } else {
        const V<D> w = hn::Max(wq, zero);
        wsum[r] = hn::Add(wsum[r], w);
        for (int c = 0; c < 3; ++c) sum[r][c] = hn::MulAdd(w, col[c], sum[r][c]);
      }
    };
    for_each_row_of<kRows>(e.rows, row);
  }
}

// x86 below AVX-512 (AVX2, SSE4) has 16 vector registers, the other targets 32: the gathers'
// rows a block (kSourceRows, kLayerRows) are chosen so that their sums stay in registers.
constexpr bool kSixteenRegisters = HWY_ARCH_X86 && HWY_TARGET > HWY_AVX3;

// The rows that share a source entry (source_entries, gather_sources_sums): four where the
// target has 32 vector registers, two where it has 16. Four rows' sums (16 vectors) left AVX2
// no register for the loaded pixel: the compiler kept half the sums on the stack, each tap-row
// a load and a store of them. `post.dof` at 1080p on a Zen 3 VM, 6 alternating pairs (two 2-row
// halves of each 4-row block): 1 thread 37.4 -> 35.9 ms, 2 threads 19.85 -> 18.8.
constexpr int kSourceRows = kSixteenRegisters ? 2 : 4;

// gather_block for 4 rows over the taps' source pixels (SourceEntry of kSourceRows rows, in
// 4 / kSourceRows passes): the same values bit for bit (a zero's sign aside,
// gather_sources_sums).
template <int kSide, bool kInput, bool kFlip = false, class D>
HWY_INLINE void gather_block_sources(D d, const GatherPlanes& p,
                                     const std::vector<SourceEntry>& sources, float center,
                                     const size_t (&i)[4], const size_t (&ci)[4],
                                     float* const (&dst)[4][3], int x, float front_of = 0.0f) {
  constexpr int kR = kSourceRows;
  for (int first = 0; first < 4; first += kR) {
    size_t pi[kR], pci[kR];
    float* pdst[kR][3];
    for (int r = 0; r < kR; ++r) {
      pi[r] = i[first + r];
      pci[r] = ci[first + r];
      for (int c = 0; c < 3; ++c) pdst[r][c] = dst[first + r][c];
    }
    V<D> wsum[kR], sum[kR][3];
    gather_sources_sums<kR, kSide, kInput, kFlip, false>(d, p, sources, center, pi, pci, front_of,
                                                         wsum, sum);
    // A NaN in any sum (also inf - inf of the check's own adds: then merely recomputed).
    V<D> all = wsum[0];
    for (int r = 0; r < kR; ++r)
      for (int c = 0; c < 3; ++c) all = hn::Add(all, sum[r][c]);
    if (!hn::AllFalse(d, hn::IsNaN(all)))
      gather_sources_sums<kR, kSide, kInput, kFlip, true>(d, p, sources, center, pi, pci, front_of,
                                                          wsum, sum);
    gather_store(d, wsum, sum, pdst, x);
  }
}

// A uniform tile's taps: every raw radius of its 3x3 tiles is the same r (>= 0.5; a background
// at the max_radius clamp: 30% of the pixels of a 1080p focus render), so each tap's weight is
// the same for every pixel of the tile: the value gather_block computes, count coverage / r^2,
// computed once (gather_tiles' uniform_for) from the same operations. Only taps of positive weight
// are kept (gather_block adds the others under a false mask), with the pixel's own weight and the
// sum of all of them in gather_block's order.
struct UniformTaps {
  std::vector<ptrdiff_t> offset, color_offset;  // in the padded planes, in the color planes
  std::vector<float> weight;
  float own = 0.0f, total = 0.0f;
  std::vector<UniformSource> sources;  // the taps by source pixel, for blocks of 4 rows
};
// gather_block's result on a uniform tile (bit for bit: the same products, sums and order, a
// tap's weight a constant instead of its radius, depth and 1 / r^2 loads and six operations):
// three loads and three fused multiply-adds a tap-row.
template <int kRows, bool kInput, class D>
HWY_INLINE void gather_block_uniform(D d, const GatherPlanes& p, const UniformTaps& u,
                                     const size_t (&i)[kRows], const size_t (&ci)[kRows],
                                     float* const (&dst)[kRows][3], int x) {
  V<D> sum[kRows][3];
  const V<D> own = hn::Set(d, u.own);
  for (int r = 0; r < kRows; ++r)
    for (int c = 0; c < 3; ++c)
      sum[r][c] = hn::Mul(own, hn::LoadU(d, p.color[c] + (kInput ? ci[r] : i[r])));
  const std::vector<ptrdiff_t>& offsets = kInput ? u.color_offset : u.offset;
  for (size_t t = 0; t < u.weight.size(); ++t) {
    const V<D> wq = hn::Set(d, u.weight[t]);
    for (int r = 0; r < kRows; ++r) {
      const size_t q = size_t(ptrdiff_t(kInput ? ci[r] : i[r]) + offsets[t]);
      for (int c = 0; c < 3; ++c)
        sum[r][c] = hn::MulAdd(wq, hn::LoadU(d, p.color[c] + q), sum[r][c]);
    }
  }
  const V<D> inv = hn::Div(hn::Set(d, 1.0f), hn::Set(d, u.total));
  for (int r = 0; r < kRows; ++r)
    for (int c = 0; c < 3; ++c) store_streaming(hn::Mul(sum[r][c], inv), d, dst[r][c] + x);
}

// gather_block_uniform for 4 rows over the taps' source pixels (UniformSource, as
// gather_block_sources): three loads a source, three fused multiply-adds a tap-row; the same
// sums bit for bit.
template <bool kInput, class D>
HWY_INLINE void gather_block_uniform_sources(D d, const GatherPlanes& p, const UniformTaps& u,
                                             const size_t (&i)[4], const size_t (&ci)[4],
                                             float* const (&dst)[4][3], int x) {
  constexpr int kRows = 4;
  V<D> sum[kRows][3];
  const V<D> own = hn::Set(d, u.own);
  for (int r = 0; r < kRows; ++r)
    for (int c = 0; c < 3; ++c)
      sum[r][c] = hn::Mul(own, hn::LoadU(d, p.color[c] + (kInput ? ci[r] : i[r])));
  const size_t c0 = kInput ? ci[0] : i[0];
  const float* const color0[3] = {p.color[0] + c0, p.color[1] + c0, p.color[2] + c0};
  for (const UniformSource& e : u.sources) {
    const ptrdiff_t cq = kInput ? e.color_offset : e.offset;
    V<D> col[3];
    for (int c = 0; c < 3; ++c) col[c] = hn::LoadU(d, color0[c] + cq);
    const auto row = [&](auto rc) {
      constexpr int r = decltype(rc)::value;
      const V<D> wq = hn::Set(d, e.weight[r]);
      for (int c = 0; c < 3; ++c) sum[r][c] = hn::MulAdd(wq, col[c], sum[r][c]);
    };
    for_each_row_of<kRows>(e.rows, row);
  }
  const V<D> inv = hn::Div(hn::Set(d, 1.0f), hn::Set(d, u.total));
  for (int r = 0; r < kRows; ++r)
    for (int c = 0; c < 3; ++c) store_streaming(hn::Mul(sum[r][c], inv), d, dst[r][c] + x);
}

// The gather of the half-resolution mode, split into two layers by depth order: the far
// layer (the pixel itself and the taps behind it, which effective_radius clamps to its radius)
// and the near layer (the taps at its depth or in front, which keep their own radius), each
// premultiplied by its share of the weight (their sum is gather_block's result), and the near
// layer's share of the weight, its alpha over the sharp full-resolution color (Bukowski et al.
// 2013's near field with its own alpha; HDRP and UE4 composite it so). dst: 3 far, 3 near, 1
// alpha. Same taps and weights as gather_block; kMasked as gather_sources_sums (the layer sums'
// masks, or the weights zeroed outside their layer and added unmasked).
template <int kRows, bool kFlip, bool kMasked, class D>
HWY_INLINE void gather_layer_sums(D d, const GatherPlanes& p, const std::vector<GatherTap>& taps,
                                  float center, const size_t (&i)[kRows], float front_of,
                                  V<D> (&wsum)[kRows], V<D> (&wnear)[kRows], V<D> (&far)[kRows][3],
                                  V<D> (&near)[kRows][3]) {
  V<D> rp[kRows], zp[kRows];
  const V<D> zero = hn::Zero(d);
  for (int r = 0; r < kRows; ++r) {
    rp[r] = hn::LoadU(d, p.r + i[r]);
    zp[r] = hn::LoadU(d, p.z + i[r]);
    wsum[r] = hn::Mul(hn::Set(d, center), hn::LoadU(d, p.inv_area + i[r]));
    wnear[r] = zero;
    for (int c = 0; c < 3; ++c) {
      far[r][c] = hn::Mul(wsum[r], hn::LoadU(d, p.color[c] + i[r]));
      near[r][c] = zero;
    }
  }
  for (const GatherTap& t : taps) {
    const V<D> count = hn::Set(d, t.count), edge = hn::Set(d, t.edge);
    for (int r = 0; r < kRows; ++r) {
      const size_t q = size_t(ptrdiff_t(i[r]) + t.offset);
      const V<D> rq = hn::LoadU(d, p.r + q), zq = hn::LoadU(d, p.z + q);
      const auto behind = hn::Gt(zq, zp[r]);
      const V<D> re = hn::IfThenElse(behind, hn::Min(rq, rp[r]), rq);
      const V<D> e =
          kFlip ? hn::IfThenElse(hn::Lt(zq, hn::Set(d, front_of)), hn::Set(d, t.edge_front), edge)
                : edge;
      // Without the clamp at 0, as gather_block: only positive weights are added.
      const V<D> cov = hn::Min(hn::MulAdd(count, re, e), count);
      const V<D> wq = hn::Mul(cov, hn::LoadU(d, p.inv_area + q));
      if constexpr (kMasked) {
        // The layer sums as fused multiply-adds under their masks (AVX-512 merges each mask
        // into its FMA): the far layer takes the used taps behind, the near layer the others.
        const auto used = hn::Gt(wq, zero);
        const auto front = hn::Not(behind);
        const auto to_far = hn::And(used, behind), to_near = hn::And(used, front);
        wsum[r] = hn::IfThenElse(used, hn::Add(wsum[r], wq), wsum[r]);
        wnear[r] = hn::IfThenElse(to_near, hn::Add(wnear[r], wq), wnear[r]);
        for (int c = 0; c < 3; ++c) {
          const V<D> col = hn::LoadU(d, p.color[c] + q);
          far[r][c] = hn::IfThenElse(to_far, hn::MulAdd(wq, col, far[r][c]), far[r][c]);
          near[r][c] = hn::IfThenElse(to_near, hn::MulAdd(wq, col, near[r][c]), near[r][c]);
        }
      } else {
        const V<D> w = hn::Max(wq, zero);
        const V<D> w_far = hn::IfThenElseZero(behind, w), w_near = hn::IfThenZeroElse(behind, w);
        wsum[r] = hn::Add(wsum[r], w);
        wnear[r] = hn::Add(wnear[r], w_near);
        for (int c = 0; c < 3; ++c) {
          const V<D> col = hn::LoadU(d, p.color[c] + q);
          far[r][c] = hn::MulAdd(w_far, col, far[r][c]);
          near[r][c] = hn::MulAdd(w_near, col, near[r][c]);
        }
      }
    }
  }
}
// The rows of a layers block: one with 16 vector registers (a row's eight sums and its pixel's
// values fill them), else two.
constexpr int kLayerRows = kSixteenRegisters ? 1 : 2;
// gather_layer_sums unmasked, recomputed masked where a sum turned NaN (gather_block_sources),
// divided by the weight into dst.
template <int kRows, bool kFlip, class D>
HWY_INLINE void gather_block_layers(D d, const GatherPlanes& p, const std::vector<GatherTap>& taps,
                                    float center, const size_t (&i)[kRows],
                                    float* const (&dst)[kRows][7], int x, float front_of) {
  V<D> wsum[kRows], wnear[kRows], far[kRows][3], near[kRows][3];
  gather_layer_sums<kRows, kFlip, false>(d, p, taps, center, i, front_of, wsum, wnear, far, near);
  // A NaN in a layer's sum (the weights' sums stay finite).
  V<D> all = hn::Zero(d);
  for (int r = 0; r < kRows; ++r)
    for (int c = 0; c < 3; ++c) all = hn::Add(all, hn::Add(far[r][c], near[r][c]));
  if (!hn::AllFalse(d, hn::IsNaN(all)))
    gather_layer_sums<kRows, kFlip, true>(d, p, taps, center, i, front_of, wsum, wnear, far, near);
  for (int r = 0; r < kRows; ++r) {  // one division a row (as gather_block)
    const V<D> inv = hn::Div(hn::Set(d, 1.0f), wsum[r]);
    for (int c = 0; c < 3; ++c) {
      hn::StoreU(hn::Mul(far[r][c], inv), d, dst[r][c] + x);
      hn::StoreU(hn::Mul(near[r][c], inv), d, dst[r][3 + c] + x);
    }
    hn::StoreU(hn::Mul(wnear[r], inv), d, dst[r][6] + x);
  }
}

// The padded planes of a gather (pad k, the longest tap offset, on every side): per pixel
// r >= 0.5, depth, 1 / r^2 and the color; outside the image 1 / r^2 = 0, which adds exactly
// nothing, so no tap needs a bounds test. Tiles of kx x ky pixels (both >= k, so the 3x3 tiles
// around a tile hold every tap that can reach it).
struct GatherGrid {
  int w, h, k, kx, ky, pw, ph, tw, th;
  ImageF planes;
  std::vector<float> tile;      // TileMax: the largest radius (before the 0.5 floor) per tile
  std::vector<float> tile_low;  // the smallest radius per tile (gather_tiles' uniform tiles)
  // Per tile, DepthSide bits its depths all satisfy (kDepthNear | kDepthFar before any row;
  // left 0, mixed, where no row is classified).
  std::vector<uint8_t> side;
  GatherGrid(int w_, int h_, int k_, int kx_, int ky_)
      : w(w_),
        h(h_),
        k(k_),
        kx(kx_),
        ky(ky_),
        pw(w_ + 2 * k_),
        ph(h_ + 2 * k_),
        tw((w_ + kx_ - 1) / kx_),
        th((h_ + ky_ - 1) / ky_),
        planes(ImageF::uninitialized(pw, ph, 6)),
        tile(size_t(tw) * size_t(th), 0.0f),
        tile_low(size_t(tw) * size_t(th), std::numeric_limits<float>::infinity()),
        side(size_t(tw) * size_t(th), kDepthMixed) {}
  // The tile maxima and minima of row y's raw radii (tile row y / ky).
  // The radii are finite and >= +0, so the extremes are the same in any order: a lane
  // reduction per vector (the scalar loop was a chain of dependent maxima, ~2% of the chain).
  void tile_max(int y, const float* raw, const Exec& exec) {
    for (int tx = 0; tx < tw; ++tx) {
      float& t = tile[size_t(y / ky) * size_t(tw) + size_t(tx)];
      float& lo = tile_low[size_t(y / ky) * size_t(tw) + size_t(tx)];
      const float* p = raw + size_t(tx) * size_t(kx);
      for_each_lane_block(exec, std::min(kx, w - tx * kx), [&](auto d, int x) {
        const auto v = hn::LoadU(d, p + x);
        t = std::max(t, hn::GetLane(hn::MaxOfLanes(d, v)));
        lo = std::min(lo, hn::GetLane(hn::MinOfLanes(d, v)));
      });
    }
  }
  // The depth classes of row y's depths (tile row y / ky): near keeps tiles whose depths are
  // all in (0, near_max], far those in [far_min, far_max] (float bounds of the double limits).
  void tile_side(int y, const float* z, float near_max, float far_min, float far_max,
                 const Exec& exec) {
    for (int tx = 0; tx < tw; ++tx) {
      uint8_t& t = side[size_t(y / ky) * size_t(tw) + size_t(tx)];
      const float* p = z + size_t(tx) * size_t(kx);
      for_each_lane_block(exec, std::min(kx, w - tx * kx), [&](auto d, int x) {
        const auto v = hn::LoadU(d, p + x);
        if (!hn::AllTrue(d, hn::And(hn::Gt(v, hn::Zero(d)), hn::Le(v, hn::Set(d, near_max)))))
          t &= uint8_t(~kDepthNear);
        if (!hn::AllTrue(d,
                         hn::And(hn::Ge(v, hn::Set(d, far_min)), hn::Le(v, hn::Set(d, far_max)))))
          t &= uint8_t(~kDepthFar);
      });
    }
  }
  size_t index(int x, int y) const { return size_t(y + k) * size_t(pw) + size_t(x + k); }
  void fill_padding(size_t from, size_t to) {
    std::fill(planes.plane(0) + from, planes.plane(0) + to, 0.5f);
    for (int c = 1; c < 6; ++c) std::fill(planes.plane(c) + from, planes.plane(c) + to, 0.0f);
  }
  // The padding rows above (tile row 0) or below (the last) and the side padding of row y.
  void pad_rows_of_tile_row(int ty) {
    if (ty == 0)
      for (int py = 0; py < k; ++py) fill_padding(size_t(py) * pw, size_t(py + 1) * pw);
    if (ty == th - 1)
      for (int py = k + h; py < ph; ++py) fill_padding(size_t(py) * pw, size_t(py + 1) * pw);
  }
  void pad_sides(int y) {
    const size_t row = size_t(y + k) * size_t(pw);
    fill_padding(row, row + size_t(k));
    fill_padding(row + size_t(k + w), row + size_t(pw));
  }
  GatherPlanes view() const {
    return {planes.plane(0),
            planes.plane(1),
            planes.plane(2),
            {planes.plane(3), planes.plane(4), planes.plane(5)}};
  }
};

// The gather over a grid: the 3x3 neighbourhood max of the tile maxima (NeighborMax), the taps
// of each tile, its rows kTapRows (4, 2 or 1) a tap in lane blocks, then two, then one. focus(x0,
// span, y0, y1) takes the tiles whose neighbourhood is in focus, coarse(tx, ty) those whose
// neighbourhood radius is coarse_from or more; block(rows, d, taps, sources, center, uniform,
// i, y, x, side) the lane block of `rows` rows from row y at column x (padded indices i; sources:
// the taps by source pixel, SourceEntry, built where kTapRows is 4). skip(tx, ty, x0, span, y0,
// y1) first: true leaves the tile to it.
// color_pitch: the row pitch of the color planes block reads (GatherTap::color_offset), 0 for
// the padded planes.
//
// kUniform: tiles whose 3x3 tiles hold one radius and whose taps stay inside the image hand
// block a UniformTaps (else nullptr) for gather_block_uniform, and mark each tile's inner taps
// (GatherTap::inner, gather_block).
template <int kTapRows, bool kUniform, class Focus, class Block, class Coarse, class Skip>
void gather_tiles(const GatherGrid& g, int n_taps, const Bokeh& bokeh, const Exec& exec,
                  Focus&& focus, Block&& block, float coarse_from, Coarse&& coarse, Skip&& skip,
                  int color_pitch = 0) {
  const int k = g.k, kx = g.kx, ky = g.ky, tw = g.tw, th = g.th, w = g.w, h = g.h;
  const std::vector<float>& tile = g.tile;
  const std::vector<float> neighbor = tile_neighbor_max(tile, tw, th);
  // The smallest radius of each tile's 3x3 tiles: equal to the largest, the tile is uniform.
  const std::vector<float> neighbor_low =
      kUniform ? tile_neighbor_reduce(g.tile_low, tw, th, std::numeric_limits<float>::infinity(),
                                      [](float a, float b) { return std::min(a, b); })
               : std::vector<float>{};
  // The depth class of each tile's 3x3 tiles (the taps reach no farther): the bits all share.
  const std::vector<uint8_t> side =
      tile_neighbor_reduce(g.side, tw, th, uint8_t(kDepthNear | kDepthFar),
                           [](uint8_t a, uint8_t b) { return uint8_t(a & b); });
  // Golden-angle spiral over the unit disc, equal area per tap (Vogel 1979).
  std::vector<std::pair<float, float>> spiral(static_cast<size_t>(n_taps));
  for (int i = 0; i < n_taps; ++i) {
    const double rad = std::sqrt((i + 0.5) / n_taps), a = i * 2.39996322972865332;
    spiral[size_t(i)] = {float(rad * std::cos(a)), float(rad * std::sin(a))};
  }
  // The distance of every whole-pixel offset within the pad, computed once (hypot of each
  // tap of each tile was ~1% of the chain): bokeh_distance behind and in front of the focus
  // plane.
  const int span_k = 2 * k + 1;
  std::vector<float> offset_dist(size_t(span_k) * size_t(span_k)),
      offset_dist_front(offset_dist.size());
  for (int dy = -k; dy <= k; ++dy)
    for (int dx = -k; dx <= k; ++dx) {
      const size_t at = size_t(dy + k) * size_t(span_k) + size_t(dx + k);
      offset_dist[at] = bokeh_distance(bokeh, dx, dy, false);
      offset_dist_front[at] = bokeh_distance(bokeh, dx, dy, true);
    }
  // The taps of a neighbourhood radius R as whole-pixel offsets: the spiral scaled by R and
  // rounded (a pixel sits at an integer position), merged where several round to the same
  // pixel (their weights add up), in row order (dy, then dx). Those that round to
  // the pixel itself are its own weight, `center` (at least 1): each pixel's weight is then its
  // share of the disc's area, its own included. Counting it as 1 whatever R, as an earlier version
  // did, gave the neighbours of a small disc most of the weight: at a CoC radius of 0.75 px about
  // 55 of the 96 taps fall on the pixel itself, and a point spread with 3.2x the disc's
  // variance. The taps depend on R only, so each tile computes them once; `counts` (per task,
  // all 0 between calls) counts the spiral taps of each offset, read back in row order over
  // the disc's square (a sort of the merged taps had been ~3% of the pass's CPU).
  // Row order, not the spiral's: consecutive taps read the same rows of the
  // planes, which the spiral's order scattered over the tile's window. The sums only change
  // order (last-bit differences); `post.dof` at 1080p, one thread, -25% (27.5-31.0 -> 21.5-21.8
  // ms on an AVX-512 Xeon), a 1080p `focus` render -11% (65.7 -> 58.0 ms a frame).
  const int pw = g.pw, cpitch = color_pitch > 0 ? color_pitch : g.pw;
  auto taps_for = [&](float big, std::vector<GatherTap>& taps, std::vector<float>& counts,
                      float& center) {
    taps.clear();
    center = 0.0f;
    for (const auto& [ux, uy] : spiral) {
      const int dx = round_half_away(ux * big), dy = round_half_away(uy * big);
      if (dx == 0 && dy == 0)
        center += 1.0f;
      else
        counts[size_t(dy + k) * size_t(span_k) + size_t(dx + k)] += 1.0f;
    }
    // |ux|, |uy| < 1: every offset lies within ceil(big) <= k of the pixel.
    const int reach = std::min(k, int(std::ceil(big)));
    for (int dy = -reach; dy <= reach; ++dy)
      for (int dx = -reach; dx <= reach; ++dx) {
        const size_t d = size_t(dy + k) * size_t(span_k) + size_t(dx + k);
        if (counts[d] == 0.0f) continue;
        taps.push_back({dx, dy, offset_dist[d], counts[d], tap_edge(counts[d], offset_dist[d]),
                        ptrdiff_t(dy) * pw + dx, ptrdiff_t(dy) * cpitch + dx, false,
                        offset_dist_front[d], tap_edge(counts[d], offset_dist_front[d])});
        counts[d] = 0.0f;
      }
    center = std::max(center, 1.0f);
  };
  // A uniform tile's weights at radius r (>= 0.5) from `taps`: gather_block's operations on
  // one lane (the padded planes' r and 1 / r^2 as the setup computes them).
  auto uniform_for = [&](float r, const std::vector<GatherTap>& taps, float center,
                         UniformTaps& u) {
    const OneTag d;
    const auto zero = hn::Zero(d);
    const auto rq = hn::Max(hn::Set(d, r), hn::Set(d, 0.5f));
    const auto ia = hn::Div(hn::Set(d, 1.0f), hn::Mul(rq, rq));
    auto wsum = hn::Mul(hn::Set(d, center), ia);
    u.own = hn::GetLane(wsum);
    u.offset.clear();
    u.color_offset.clear();
    u.weight.clear();
    std::vector<std::pair<int, int>> kept;
    for (const GatherTap& t : taps) {
      const auto count = hn::Set(d, t.count);
      const auto cov = hn::Min(hn::Max(hn::MulAdd(count, rq, hn::Set(d, t.edge)), zero), count);
      const auto wq = hn::Mul(cov, ia);
      wsum = hn::Add(wsum, wq);
      if (hn::GetLane(wq) > 0.0f) {
        kept.push_back({t.dx, t.dy});
        u.offset.push_back(t.offset);
        u.color_offset.push_back(t.color_offset);
        u.weight.push_back(hn::GetLane(wq));
      }
    }
    u.total = hn::GetLane(wsum);
    if constexpr (kTapRows >= 4)
      u.sources = source_entries<UniformSource>(
          kept, std::min(k, int(std::ceil(r))), pw, cpitch, 4,
          [&](UniformSource& e, int row, size_t t) { e.weight[row] = u.weight[t]; });
  };
  // The taps of each neighbourhood radius the tiles use, built once a frame by the first tile
  // row that needs them and shared by the others: the bench frame's 68 tile rows had built 309
  // tap sets a frame (1.0-1.3 ms of CPU) of ~100 distinct radii. A tap set's inner flags depend
  // on the tile's smallest radius as well and serve only the blocks of fewer than four rows
  // (gather_block_sources computes every weight in full, the same value): a tile row that has
  // such blocks copies the taps and flags them.
  struct BaseSet {
    std::vector<GatherTap> taps;
    float center = 1.0f;               // the pixel's own weight in taps (gather_block)
    std::vector<SourceEntry> sources;  // kTapRows 4: the taps by source pixel
  };
  std::vector<float> radii;
  for (const float big : neighbor)
    if (big >= 0.5f && big < coarse_from) radii.push_back(big);
  std::sort(radii.begin(), radii.end());
  radii.erase(std::unique(radii.begin(), radii.end()), radii.end());
  std::vector<BaseSet> base(radii.size());
  const std::unique_ptr<std::once_flag[]> built(new std::once_flag[radii.size()]);
  // (A build runs no parallel work, so a tile row waiting on another's build cannot deadlock.)
  const auto base_for = [&](float big, std::vector<float>& counts) -> const BaseSet& {
    const size_t b = size_t(std::lower_bound(radii.begin(), radii.end(), big) - radii.begin());
    std::call_once(built[b], [&] {
      taps_for(big, base[b].taps, counts, base[b].center);
      if constexpr (kTapRows >= 4)
        base[b].sources = source_entries(base[b].taps, pw, cpitch, kSourceRows);
    });
    return base[b];
  };
  // Rows of tiles in parallel. A tile row first takes its tiles' tap sets, one per
  // (neighbourhood radius, smallest radius) pair its tiles use, then runs its rows a block of
  // kTapRows rows at a time across all its tiles, in lane blocks (the same per-pixel order of
  // operations at every width, and in any order of the blocks).
  // Row blocks across the tile row, not tile by tile: the blocks then read the planes and
  // write the output along the rows, which the hardware prefetchers follow, where a tile's 16
  // columns of ~22 rows in 5 planes and 16 output rows in 3 touch ~160 lines on as many pages
  // (the likely cause; this VM has no counters to confirm it). A standalone copy of the loop
  // (1080p, radius 3, one thread): 24 -> 14 cycles a tap-row; `post.dof` 1080p, 2 threads, 3
  // pairs: 13.4-13.8 -> 10.2-11.7 ms (9aabf85; docs/perf/2026-log.md).
  // In strips of whole tiles, all the tile row's blocks over one strip before the next: the
  // planes' rows a tile row's blocks read (ky + 2k of 6 planes, 1.1 KB a column at k = 16) fill
  // 0.25 MB a strip, which a core's L2 keeps from one block row to the next (a 1080p row of
  // them, 2.2 MB, had gone to L3 and back: AMD Zen 3 has 512 KB of L2 a core).
  const int strip_px =
      std::max(1, int((size_t(1) << 18) / (size_t(ky + 2 * k) * 6 * sizeof(float)) / size_t(kx))) *
      kx;
  struct TapSet {
    float radius, low;  // low: the smallest radius the inner flags were set for (-1: none)
    const BaseSet* base;
    bool flagged = false;         // taps holds base's taps with their inner flags
    std::vector<GatherTap> taps;  // (flagged)
    bool has_uniform = false;
    UniformTaps uniform;  // built for the set's first uniform tile (its radius only)
    const std::vector<GatherTap>& gather_taps() const { return flagged ? taps : base->taps; }
  };
  struct TileJob {
    int x0, span;
    size_t set;
    bool uniform;
    uint8_t side;
  };
  parallel_rows(exec, th, [&](int ty) {
    std::vector<TapSet> sets;
    std::vector<TileJob> jobs;
    std::vector<float> counts(offset_dist.size(), 0.0f);
    const int y0 = ty * ky, y_end = std::min(h, (ty + 1) * ky);
    // Blocks of fewer than four rows (gather_block) take the inner flags.
    const bool flags = kUniform && (kTapRows < 4 || (y_end - y0) % 4 != 0);
    for (int tx = 0; tx < tw; ++tx) {
      const float big = neighbor[size_t(ty) * size_t(tw) + size_t(tx)];
      const uint8_t sd = side[size_t(ty) * size_t(tw) + size_t(tx)];
      const int x0 = tx * kx, span = std::min(w, x0 + kx) - x0;
      if (skip(tx, ty, x0, span, y0, y_end)) continue;
      if (big < 0.5f) {  // focus field around: unchanged
        focus(x0, span, y0, y_end);
        continue;
      }
      if (big >= coarse_from) {  // left to the half-resolution layers
        coarse(tx, ty);
        continue;
      }
      // Inner taps (kUniform): coverage `count` at the neighbourhood's smallest radius (low <=
      // every r_q, r_p, min(r_q, r_p) the block reads, padding aside, whose 1 / r^2 = 0 makes
      // the weight +0 either way), so at each radius it holds (the fused multiply-add rounds
      // monotonically in r). A flag a tap, not a leading run: in row order they lie inside.
      const float raw_low = kUniform ? neighbor_low[size_t(ty) * size_t(tw) + size_t(tx)] : -1.0f;
      const float low = kUniform ? std::max(raw_low, 0.5f) : -1.0f;
      auto set = std::find_if(sets.begin(), sets.end(),
                              [&](const TapSet& t) { return t.radius == big && t.low == low; });
      if (set == sets.end()) {
        const BaseSet& b = base_for(big, counts);
        sets.push_back({big, low, &b, flags, {}, false, {}});
        set = sets.end() - 1;
        if (flags) {
          set->taps = b.taps;
          const OneTag d1;
          // Inner on both sides of the focus plane (the two edges differ for an odd bokeh).
          for (GatherTap& t : set->taps)
            t.inner = hn::GetLane(hn::MulAdd(hn::Set(d1, t.count), hn::Set(d1, low),
                                             hn::Set(d1, t.edge))) >= t.count &&
                      hn::GetLane(hn::MulAdd(hn::Set(d1, t.count), hn::Set(d1, low),
                                             hn::Set(d1, t.edge_front))) >= t.count;
        }
      }
      bool uniform = false;
      if constexpr (kUniform) {
        const int reach = int(std::ceil(big));
        // (Not for an odd bokeh: its weights also depend on each tap's side of the focus plane.)
        uniform = !bokeh.flips() && raw_low == big && x0 - reach >= 0 && x0 + span + reach <= w &&
                  y0 - reach >= 0 && y_end + reach <= h;
        if (uniform && !set->has_uniform) {
          uniform_for(big, set->base->taps, set->base->center, set->uniform);
          set->has_uniform = true;
        }
      }
      jobs.push_back({x0, span, size_t(set - sets.begin()), uniform, sd});
    }
    // The rows of jobs [first, last) from row y, `rows` (4, 2 or 1) a block.
    size_t first = 0, last = 0;
    const auto run_rows = [&](auto rows, int y) {
      constexpr int kRows = decltype(rows)::value;
      for (size_t n = first; n < last; ++n) {
        const TileJob& j = jobs[n];
        const TapSet& set = sets[j.set];
        const UniformTaps* uni = j.uniform ? &set.uniform : nullptr;
        for_each_lane_block(exec, j.span, [&](auto d, int xo) {
          size_t i[kRows];
          for (int r = 0; r < kRows; ++r) i[r] = g.index(j.x0 + xo, y + r);
          block(rows, d, set.gather_taps(), set.base->sources, set.base->center, uni, i, y,
                j.x0 + xo, j.side);
        });
      }
    };
    for (first = 0; first < jobs.size(); first = last) {  // a strip's jobs at a time
      last = first + 1;
      while (last < jobs.size() && jobs[last].x0 / strip_px == jobs[first].x0 / strip_px) ++last;
      int y = y0;
      if constexpr (kTapRows >= 4)
        for (; y + 4 <= y_end; y += 4) run_rows(std::integral_constant<int, 4>{}, y);
      if constexpr (kTapRows >= 2)
        for (; y + 2 <= y_end; y += 2) run_rows(std::integral_constant<int, 2>{}, y);  // two a tap
      for (; y < y_end; ++y) run_rows(std::integral_constant<int, 1>{}, y);
    }
    stream_fence();  // the blocks' streaming stores (gather_store) visible before the task ends
  });
}

// Half resolution (DofResolution::half): the gather over a 2x2 downsample of the full-resolution
// planes, as two layers (gather_block_layers). The downsample anchors each 2x2 block on its
// largest-radius pixel (its depth and radius): the blur that reaches farthest survives the
// downsample, so a blurred field does not shrink at its edges, and in-focus pixels lose nothing
// since the composite gives them their own sharp color. The color averages the block's pixels
// at the anchor's depth or behind it, and the nearer ones by closeness of radius (1 - |r_q -
// r_anchor|, full pixels): a sharp foreground pixel does not bleed into the blurred background
// behind it (UE4's and Jimenez 2014's downsamples are CoC-aware for the same reason), while a
// near-field pixel's color is diluted by what lies behind it (the thin dark rim of the `focus`
// sphere doubled in width with the radius weight alone). Odd sizes: the last row / column pairs
// with itself. Returns hw x hh x 8: far (3), near (3), near alpha, the anchor's depth (0 where
// no tile was downsampled).
// bokeh, front_of: as the full-resolution gather's (gather_block).
ImageF half_res_layers(const GatherGrid& full, const std::vector<uint8_t>& coarse,
                       const DofSettings& s, const Bokeh& bokeh, float front_of, const Exec& exec) {
  const int w = full.w, h = full.h, hw = (w + 1) / 2, hh = (h + 1) / 2;
  // Radii in half pixels: half_res_radius of the full ones (at most max_radius / 2); tiles twice
  // as wide as tall: a tile row of 16 fills an AVX-512 vector (8 would leave every pixel to the
  // 1-lane path).
  const int kh = (s.max_radius + 1) / 2;
  GatherGrid g(hw, hh, kh, 2 * kh, kh);
  const GatherPlanes in = full.view();
  float* rp_ = g.planes.plane(0);
  float* zp_ = g.planes.plane(1);
  float* ia_ = g.planes.plane(2);
  float* cp_[3] = {g.planes.plane(3), g.planes.plane(4), g.planes.plane(5)};
  // The half tiles the composite reads: those of the coarse full tiles' pixels, widened by the
  // upsample's one half pixel.
  std::vector<uint8_t> needed(g.tile.size(), 0);
  for (int ty = 0; ty < full.th; ++ty)
    for (int tx = 0; tx < full.tw; ++tx) {
      if (!coarse[size_t(ty) * size_t(full.tw) + size_t(tx)]) continue;
      const int x0 = std::max(0, tx * full.kx / 2 - 1),
                x1 = std::min(hw - 1, ((tx + 1) * full.kx + 1) / 2);
      const int y0 = std::max(0, ty * full.ky / 2 - 1),
                y1 = std::min(hh - 1, ((ty + 1) * full.ky + 1) / 2);
      for (int u = y0 / g.ky; u <= y1 / g.ky; ++u)
        for (int v = x0 / g.kx; v <= x1 / g.kx; ++v)
          needed[size_t(u) * size_t(g.tw) + size_t(v)] = 1;
    }
  // The half tiles downsampled: the needed ones and their neighbours (their gathers' taps and
  // the 3x3 tile maxima reach no farther).
  std::vector<uint8_t> sampled(g.tile.size(), 0);
  for (int ty = 0; ty < g.th; ++ty)
    for (int tx = 0; tx < g.tw; ++tx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int ux = tx + dx, uy = ty + dy;
          if (ux >= 0 && uy >= 0 && ux < g.tw && uy < g.th &&
              needed[size_t(uy) * size_t(g.tw) + size_t(ux)])
            sampled[size_t(ty) * size_t(g.tw) + size_t(tx)] = 1;
        }
  parallel_rows(exec, g.th, [&](int ty) {
    g.pad_rows_of_tile_row(ty);
    std::vector<float, DefaultInitAllocator<float>> raw(static_cast<size_t>(hw));
    for (int y = ty * kh; y < std::min(hh, (ty + 1) * kh); ++y) {
      g.pad_sides(y);
      const size_t o = g.index(0, y);
      const size_t row[2] = {full.index(0, 2 * y), full.index(0, std::min(h - 1, 2 * y + 1))};
      // The four pixels of half pixels x .. x + lanes - 1 (pairs de-interleaved), or of the last
      // one of an odd width (its own column twice).
      auto block = [&](auto d, int x, bool single) {
        using VD = V<decltype(d)>;
        const auto taps = [&](const float* plane, VD(&t)[4]) {
          for (int j = 0; j < 2; ++j) {
            const float* p = plane + row[j] + size_t(2 * x);
            if (single)
              t[2 * j] = t[2 * j + 1] = hn::Set(d, p[0]);
            else
              hn::LoadInterleaved2(d, p, t[2 * j], t[2 * j + 1]);
          }
        };
        VD rs[4], zs[4], cs[3][4];
        taps(in.r, rs);
        taps(in.z, zs);
        for (int c = 0; c < 3; ++c) taps(in.color[c], cs[c]);
        VD ra = rs[0], za = zs[0];
        for (int q = 1; q < 4; ++q) {  // the first of the largest radii
          const auto m = hn::Gt(rs[q], ra);
          ra = hn::IfThenElse(m, rs[q], ra);
          za = hn::IfThenElse(m, zs[q], za);
        }
        const VD one = hn::Set(d, 1.0f), zero = hn::Zero(d);
        VD wsum = zero, sum[3] = {zero, zero, zero};
        for (int q = 0; q < 4; ++q) {
          const VD wq = hn::IfThenElse(hn::Ge(zs[q], za), one,
                                       hn::Max(hn::Sub(one, hn::Abs(hn::Sub(rs[q], ra))), zero));
          wsum = hn::Add(wsum, wq);
          for (int c = 0; c < 3; ++c) sum[c] = hn::Add(sum[c], hn::Mul(wq, cs[c][q]));
        }
        const VD e = hn::Sub(hn::Mul(ra, ra), hn::Set(d, 4.0f * kHalfResVariance));
        const VD r = hn::IfThenElseZero(hn::Gt(e, zero),
                                        hn::Mul(hn::Set(d, 0.5f), hn::Sqrt(hn::Max(e, zero))));
        const VD rq = hn::Max(r, hn::Set(d, 0.5f));
        hn::StoreU(r, d, raw.data() + x);
        hn::StoreU(rq, d, rp_ + o + size_t(x));
        hn::StoreU(za, d, zp_ + o + size_t(x));
        hn::StoreU(hn::Div(one, hn::Mul(rq, rq)), d, ia_ + o + size_t(x));
        for (int c = 0; c < 3; ++c) hn::StoreU(hn::Div(sum[c], wsum), d, cp_[c] + o + size_t(x));
      };
      for (int tx = 0; tx < g.tw; ++tx) {
        const int x0 = tx * g.kx, x1 = std::min(hw, x0 + g.kx);
        if (!sampled[size_t(ty) * size_t(g.tw) + size_t(tx)]) {
          std::fill(raw.data() + x0, raw.data() + x1, 0.0f);
          continue;
        }
        const int pairs = std::min(x1, w / 2) - x0;  // half pixels with two columns
        for_each_lane_block(exec, pairs, [&](auto d, int x) { block(d, x0 + x, false); });
        if (x0 + pairs < x1) block(OneTag(), hw - 1, true);  // an odd width's last column
      }
      g.tile_max(y, raw.data(), exec);
    }
  });
  ImageF layers = ImageF::uninitialized(hw, hh, 8);
  const GatherPlanes planes = g.view();
  gather_tiles<kLayerRows, false>(
      g, s.taps, bokeh, exec,
      [&](int x0, int span, int y0, int y1) {  // in focus: the pixel alone, no near layer
        for (int y = y0; y < y1; ++y)
          for (int c = 0; c < 7; ++c) {
            float* o = layers.row(c, y) + x0;
            if (c < 3)
              std::copy(cp_[c] + g.index(x0, y), cp_[c] + g.index(x0, y) + span, o);
            else
              std::fill(o, o + span, 0.0f);
          }
      },
      [&](auto rows, auto d, const std::vector<GatherTap>& taps, const std::vector<SourceEntry>&,
          float center, const UniformTaps*, const auto& i, int y, int x, uint8_t) {
        constexpr int kRows = decltype(rows)::value;
        float* dst[kRows][7];
        for (int r = 0; r < kRows; ++r)
          for (int c = 0; c < 7; ++c) dst[r][c] = layers.row(c, y + r);
        if (bokeh.flips())
          gather_block_layers<kRows, true>(d, planes, taps, center, i, dst, x, front_of);
        else
          gather_block_layers<kRows, false>(d, planes, taps, center, i, dst, x, front_of);
      },
      std::numeric_limits<float>::infinity(), [](int, int) {},
      [&](int tx, int ty, int x0, int span, int y0, int y1) {
        if (needed[size_t(ty) * size_t(g.tw) + size_t(tx)]) return false;
        for (int y = y0; y < y1; ++y)  // never composited: zeros, so nothing is read unset
          for (int c = 0; c < 7; ++c)
            std::fill(layers.row(c, y) + x0, layers.row(c, y) + x0 + span, 0.0f);
        return true;
      });
  parallel_rows(exec, hh, [&](int y) {
    float* o = layers.row(7, y);
    for (int tx = 0; tx < g.tw; ++tx) {
      const int x0 = tx * g.kx, x1 = std::min(hw, x0 + g.kx);
      if (sampled[size_t(y / g.ky) * size_t(g.tw) + size_t(tx)])
        std::copy(zp_ + g.index(x0, y), zp_ + g.index(x1, y), o + x0);
      else
        std::fill(o + x0, o + x1, 0.0f);
    }
  });
  return layers;
}

// The near channels (3 .. 6) of full row pixels [2 hx0, 2 hx1) upsampled from half rows i (3/4)
// and j (1/4), columns [lo, hi) (hx0 - 1 .. hx1 inside the layers), with each tap gated: it
// adds nothing where the pixel is in the focus field (half_res_blend 0) and the tap's anchor lies
// behind it (composite_half_res). Where every tap passes, the plain upsample's operations in its
// order: the same bits. `rows`: scratch of 2 x 5 x (hw + 2) floats; overwrites up's channels
// 3 .. 6 (2 hw floats each).
void gated_near_row(const ImageF& layers, int i, int j, int lo, int hi, int hx0, int hx1,
                    const float* rrow, const float* zrow, const Exec& exec,
                    std::vector<float, DefaultInitAllocator<float>>& rows,
                    std::vector<float, DefaultInitAllocator<float>>& up) {
  const int hw = layers.width();
  const size_t pitch = size_t(hw + 2);
  // Padded copies: row r (0: i, 1: j), channel c (3 .. 7), column x at [1 + x], the edges
  // repeated (the plain upsample's clamp).
  const auto row = [&](int r, int c) {
    return rows.data() + (size_t(r) * 5 + size_t(c - 3)) * pitch;
  };
  for (int r = 0; r < 2; ++r)
    for (int c = 3; c < 8; ++c) {
      float* v = row(r, c);
      const float* src = layers.row(c, r == 0 ? i : j);
      std::copy(src + lo, src + hi, v + 1 + lo);
      if (lo == 0) v[0] = v[1];
      if (hi == hw) v[hw + 1] = v[hw];
    }
  for_each_lane_block(exec, hx1 - hx0, [&](auto d, int xo) {
    using VD = V<decltype(d)>;
    const int m = hx0 + xo;  // half pixels m ..; full pixels 2m (even) and 2m + 1 (odd)
    const VD q = hn::Set(d, 0.25f), t = hn::Set(d, 0.75f);
    VD r_e, r_o, z_e, z_o;
    hn::LoadInterleaved2(d, rrow + 2 * size_t(m), r_e, r_o);
    hn::LoadInterleaved2(d, zrow + 2 * size_t(m), z_e, z_o);
    // Blurred pixels take every tap.
    const auto all_e = hn::Gt(half_res_blend_lanes(d, r_e), hn::Zero(d));
    const auto all_o = hn::Gt(half_res_blend_lanes(d, r_o), hn::Zero(d));
    // Gates of taps at column offset k (-1, 0, +1) of rows i and j, for the even / odd pixels.
    const auto gate = [&](int r, int k, hn::Mask<decltype(d)> all, VD z) {
      return hn::Or(all, hn::Le(hn::LoadU(d, row(r, 7) + 1 + m + k), z));
    };
    const auto ge_i0 = gate(0, 0, all_e, z_e), ge_i1 = gate(0, -1, all_e, z_e);
    const auto ge_j0 = gate(1, 0, all_e, z_e), ge_j1 = gate(1, -1, all_e, z_e);
    const auto go_i0 = gate(0, 0, all_o, z_o), go_i1 = gate(0, 1, all_o, z_o);
    const auto go_j0 = gate(1, 0, all_o, z_o), go_j1 = gate(1, 1, all_o, z_o);
    for (int c = 3; c < 7; ++c) {
      const auto at = [&](int r, int k) { return hn::LoadU(d, row(r, c) + 1 + m + k); };
      // Vertically first, then across, as the plain upsample.
      const auto vert = [&](hn::Mask<decltype(d)> gi, hn::Mask<decltype(d)> gj, int k) {
        return hn::Add(hn::Mul(t, hn::IfThenElseZero(gi, at(0, k))),
                       hn::Mul(q, hn::IfThenElseZero(gj, at(1, k))));
      };
      const VD even =
          hn::Add(hn::Mul(t, vert(ge_i0, ge_j0, 0)), hn::Mul(q, vert(ge_i1, ge_j1, -1)));
      const VD odd = hn::Add(hn::Mul(t, vert(go_i0, go_j0, 0)), hn::Mul(q, vert(go_i1, go_j1, 1)));
      hn::StoreInterleaved2(even, odd, d, up.data() + size_t(c) * size_t(2 * hw) + 2 * size_t(m));
    }
  });
}

// The half-resolution layers composited into the rows of `out` whose tiles are marked coarse
// (tile rows of k): the layers upsampled bilinearly (full pixel 2i takes 3/4 of half pixel i and
// 1/4 of i - 1, 2i + 1 of i + 1, clamped at the edges; vertically first), then half_res_blend by
// the pixel's radius (the full-resolution planes). Where the blend is 0 and no near layer
// reaches the pixel it keeps its color bit for bit (the focus field is unchanged).
//
// The near layer of a half pixel is what lies in front of its anchor, the block's largest
// radius: beside an in-focus edge, the blurred background behind it. So in the focus field
// (blend a = 0) a pixel's near layer takes only the half pixels whose anchor is not behind it
// (gated_near_row). Upsampled plainly, the background's near share had covered the sharp edge:
// on a 1080p `focus` render (256 spp) the in-focus pixels' squared error was 3.2x the
// unprocessed image's, 0.99x so (full resolution: 0.99x). Gating the blurred pixels below a = 1
// as well measured worse there (radii 1-2 px: 8.1e-5 -> 8.8e-5), so they take the plain upsample.
void composite_half_res(const GatherGrid& full, const ImageF& layers, const ImageF& color,
                        const std::vector<uint8_t>& coarse, const Exec& exec, ImageF& out) {
  const int w = full.w, h = full.h, hw = layers.width(), hh = layers.height(), k = full.k;
  parallel_rows(exec, full.th, [&](int ty) {
    std::vector<float, DefaultInitAllocator<float>> vert(size_t(7) * size_t(hw + 2));
    std::vector<float, DefaultInitAllocator<float>> up(size_t(7) * size_t(2 * hw));
    std::vector<float, DefaultInitAllocator<float>> use(static_cast<size_t>(w));
    std::vector<float, DefaultInitAllocator<float>> rows(size_t(10) * size_t(hw + 2));
    // The columns from the first coarse tile of the row to its last: full pixels [cx0, cx1),
    // half pixels [hx0, hx1), vertically interpolated with one more on each side [lo, hi).
    int first = -1, last = -1;
    for (int tx = 0; tx < full.tw; ++tx) {
      const bool c = coarse[size_t(ty) * size_t(full.tw) + size_t(tx)] != 0;
      if (c) last = tx;
      if (c && first < 0) first = tx;
      std::fill(use.data() + tx * k, use.data() + std::min(w, (tx + 1) * k), c ? 1.0f : 0.0f);
    }
    if (first < 0) return;
    const int cx0 = first * k, cx1 = std::min(w, (last + 1) * k);
    const int hx0 = cx0 / 2, hx1 = (cx1 + 1) / 2;
    const int lo = std::max(0, hx0 - 1), hi = std::min(hw, hx1 + 1);
    for (int y = ty * k; y < std::min(h, (ty + 1) * k); ++y) {
      const int i = y / 2, j = (y % 2 == 0) ? std::max(i - 1, 0) : std::min(i + 1, hh - 1);
      for (int c = 0; c < 7; ++c) {
        float* v = vert.data() + size_t(c) * size_t(hw + 2);
        const float *ri = layers.row(c, i), *rj = layers.row(c, j);
        for_each_lane_block(exec, hi - lo, [&](auto d, int xo) {
          const int x = lo + xo;
          hn::StoreU(hn::Add(hn::Mul(hn::Set(d, 0.75f), hn::LoadU(d, ri + x)),
                             hn::Mul(hn::Set(d, 0.25f), hn::LoadU(d, rj + x))),
                     d, v + 1 + x);
        });
        if (lo == 0) v[0] = v[1];
        if (hi == hw) v[hw + 1] = v[hw];
        float* u = up.data() + size_t(c) * size_t(2 * hw);
        for_each_lane_block(exec, hx1 - hx0, [&](auto d, int xo) {
          const int x = hx0 + xo;
          const auto m = hn::Mul(hn::Set(d, 0.75f), hn::LoadU(d, v + 1 + x));
          const auto q = hn::Set(d, 0.25f);
          hn::StoreInterleaved2(hn::Add(m, hn::Mul(q, hn::LoadU(d, v + x))),
                                hn::Add(m, hn::Mul(q, hn::LoadU(d, v + 2 + x))), d, u + 2 * x);
        });
      }
      const float* rrow = full.planes.plane(0) + full.index(0, y);
      const float* zrow = full.planes.plane(1) + full.index(0, y);
      // A pixel of the focus field in the row (half_res_blend 0)? Then the near layer is
      // upsampled again, gated.
      bool sharp_pixels = false;
      for_each_lane_block(exec, cx1 - cx0, [&](auto d, int xo) {
        const auto a = half_res_blend_lanes(d, hn::LoadU(d, rrow + cx0 + xo));
        sharp_pixels = sharp_pixels || !hn::AllTrue(d, hn::Gt(a, hn::Zero(d)));
      });
      if (sharp_pixels) gated_near_row(layers, i, j, lo, hi, hx0, hx1, rrow, zrow, exec, rows, up);
      const auto layer = [&](int c) { return up.data() + size_t(c) * size_t(2 * hw); };
      for_each_lane_block(exec, cx1 - cx0, [&](auto d, int xo) {
        const int x = cx0 + xo;
        const auto one = hn::Set(d, 1.0f), zero = hn::Zero(d);
        const auto a = half_res_blend_lanes(d, hn::LoadU(d, rrow + x));
        const auto nf = hn::LoadU(d, layer(6) + x);
        const auto keep = hn::Mul(hn::Sub(one, a), hn::Sub(one, nf));
        const auto sharp_only = hn::And(hn::Eq(a, zero), hn::Eq(nf, zero));
        const auto take = hn::Gt(hn::LoadU(d, use.data() + x), zero);
        for (int c = 0; c < 3; ++c) {
          const auto sharp = hn::LoadU(d, color.row(c, y) + x);
          const auto mixed =
              hn::Add(hn::Add(hn::Mul(keep, sharp), hn::Mul(a, hn::LoadU(d, layer(c) + x))),
                      hn::LoadU(d, layer(3 + c) + x));
          float* o = out.row(c, y) + x;
          const auto v = hn::IfThenElse(sharp_only, sharp, mixed);
          // Blocks all in coarse tiles (most of them) need not read the gather's pixels.
          hn::StoreU(hn::AllTrue(d, take) ? v : hn::IfThenElse(take, v, hn::LoadU(d, o)), d, o);
        }
      });
    }
  });
}

}  // namespace

ImageF dof_gather_fast(const Frame& f, const ImageF& color, const DofSettings& s,
                       const ThinLens& thin, const Exec& exec) {
  const int w = color.width(), h = color.height(), k = s.max_radius;
  const bool ranges = s.coc == DofCoc::ranges;
  const CocLens lens(thin, w, k);
  const CocRanges range(s);
  // The bokeh's shape and the depth below which a pixel lies in front of the focus plane (its
  // bokeh point-reflected): near_end for the ranges (between them the radius is 0).
  const Bokeh bokeh = lens_bokeh(thin);
  const float front_of = ranges ? range.near_end : float(thin.focus_distance);
  // Padded planes allocated without a fill and written once, in parallel (a serial fill of the
  // six planes cost about 12% of the pass at 1080p on 2 threads).
  GatherGrid g(w, h, k, k, k);
  float *rp_ = g.planes.plane(0), *zp_ = g.planes.plane(1), *ia_ = g.planes.plane(2);
  // The radius is non-increasing in depth up to the focus distance and non-decreasing from it
  // on (gather_radius_lanes), for coc=ranges up to far_start and from near_end (CocRanges), for
  // every depth: every tile is classified.
  std::fill(g.side.begin(), g.side.end(), uint8_t(kDepthNear | kDepthFar));
  const float near_max = ranges ? range.far_start : lens.s,
              far_min = ranges ? range.near_end : lens.s,
              far_max = std::numeric_limits<float>::max();
  float* cp_[3] = {g.planes.plane(3), g.planes.plane(4), g.planes.plane(5)};
  // The full-resolution gather reads the colors and depths from the input's planes where every
  // tap stays inside them: rows [y, y + rows) with a row between their taps' k rows and the
  // planes' ends (a tap at most k columns out reads a neighbouring row). Only the rows near the
  // top and the bottom are copied into the padded planes (the color copy was ~10% of the pass's
  // CPU; the depth copy 8 MB of the 1080p frame's writes); the half mode's downsample reads
  // them all.
  const bool half = s.resolution == DofResolution::half;
  const auto reads_input = [&](int y, int rows) {
    return w >= k && y - k - 1 >= 0 && y + rows + k + 1 <= h;
  };
  // Rows no block that reads the padded colors reaches (those blocks start within k + 1 rows
  // of an end, span at most 4 rows, and reach k rows farther).
  const auto reads_input_only = [&](int y) {
    return !half && w >= k && y >= 2 * k + 5 && y < h - 2 * k - 5;
  };
  // One task per tile row: the planes of its image rows (the padding rows go with the first
  // and the last tile row) and its tiles' maxima. Radii on lanes (gather_radius_lanes), the
  // maxima of non-negative values in any order (max is exact).
  parallel_rows(exec, g.th, [&](int ty) {
    g.pad_rows_of_tile_row(ty);
    std::vector<float, DefaultInitAllocator<float>> raw(static_cast<size_t>(w));
    for (int y = ty * k; y < std::min(h, (ty + 1) * k); ++y) {
      g.pad_sides(y);
      const size_t o = g.index(0, y);
      const float* depth = f.depth.row(0, y);
      for_each_lane_block(exec, w, [&](auto d, int x) {
        __builtin_prefetch(depth + x + kRowPrefetchAhead);  // changes no value
        for (float* plane : {rp_, ia_})
          __builtin_prefetch(plane + o + size_t(x) + kRowPrefetchAhead, 1);
        const auto z = hn::LoadU(d, depth + x);
        const auto r = ranges ? range_radius_lanes(d, z, range) : gather_radius_lanes(d, z, lens);
        const auto rq = hn::Max(r, hn::Set(d, 0.5f));
        hn::StoreU(r, d, raw.data() + x);
        hn::StoreU(rq, d, rp_ + o + size_t(x));
        hn::StoreU(hn::Div(hn::Set(d, 1.0f), hn::Mul(rq, rq)), d, ia_ + o + size_t(x));
      });
      if (!reads_input_only(y)) {
        std::copy(depth, depth + w, zp_ + o);
        for (int c = 0; c < 3; ++c) std::copy(color.row(c, y), color.row(c, y) + w, cp_[c] + o);
      }
      g.tile_max(y, raw.data(), exec);
      g.tile_side(y, depth, near_max, far_min, far_max, exec);
    }
  });
  const GatherPlanes planes = g.view();
  const GatherPlanes input_planes{planes.r,
                                  f.depth.plane(0),
                                  planes.inv_area,
                                  {color.plane(0), color.plane(1), color.plane(2)}};
  ImageF out = ImageF::uninitialized(w, h, 3);
  // Half resolution: the tiles whose neighbourhood radius reaches half_from take the
  // half-resolution layers, the others (smaller blurs, which the resampling would widen, and
  // cheap at full resolution: few distinct taps) the full-resolution gather.
  std::vector<uint8_t> coarse(half ? g.tile.size() : 0, 0);
  gather_tiles<4, true>(
      g, s.taps, bokeh, exec,
      [&](int x0, int span, int y0, int y1) {  // no input copy: focus tiles copy their pixels
        // Streamed as the gathered blocks are (gather_store): a tile's rows are as scattered.
        for (int y = y0; y < y1; ++y)
          for (int c = 0; c < 3; ++c) {
            const float* src = color.row(c, y) + x0;
            float* dst = out.row(c, y) + x0;
            for_each_lane_block(exec, span, [&](auto d, int x) {
              store_streaming(hn::LoadU(d, src + x), d, dst + x);
            });
          }
      },
      [&](auto rows, auto d, const std::vector<GatherTap>& taps,
          const std::vector<SourceEntry>& sources, float center, const UniformTaps* uni,
          const auto& i, int y, int x, uint8_t side) {
        constexpr int kRows = decltype(rows)::value;
        float* dst[kRows][3];
        size_t ci[kRows];
        for (int r = 0; r < kRows; ++r) {
          for (int c = 0; c < 3; ++c) dst[r][c] = out.row(c, y + r);
          ci[r] = size_t(y + r) * size_t(w) + size_t(x);
        }
        const auto run = [&](auto input) {
          constexpr bool kInput = decltype(input)::value;
          const GatherPlanes& p = kInput ? input_planes : planes;
          if constexpr (kRows == 4) {
            if (uni)
              gather_block_uniform_sources<kInput>(d, p, *uni, i, ci, dst, x);
            else if (side & kDepthNear)
              gather_block_sources<kDepthNear, kInput>(d, p, sources, center, i, ci, dst, x);
            else if (side & kDepthFar)
              gather_block_sources<kDepthFar, kInput>(d, p, sources, center, i, ci, dst, x);
            else if (bokeh.flips())
              gather_block_sources<kDepthMixed, kInput, true>(d, p, sources, center, i, ci, dst, x,
                                                              front_of);
            else
              gather_block_sources<kDepthMixed, kInput>(d, p, sources, center, i, ci, dst, x);
          } else if (uni)
            gather_block_uniform<kRows, kInput>(d, p, *uni, i, ci, dst, x);
          else if (side & kDepthNear)
            gather_block<kRows, kDepthNear, kInput>(d, p, taps, center, i, ci, dst, x);
          else if (side & kDepthFar)
            gather_block<kRows, kDepthFar, kInput>(d, p, taps, center, i, ci, dst, x);
          else if (bokeh.flips())
            gather_block<kRows, kDepthMixed, kInput, true>(d, p, taps, center, i, ci, dst, x,
                                                           front_of);
          else
            gather_block<kRows, kDepthMixed, kInput>(d, p, taps, center, i, ci, dst, x);
        };
        if (reads_input(y, kRows))
          run(std::true_type{});
        else
          run(std::false_type{});
      },
      half ? s.half_from : std::numeric_limits<float>::infinity(),
      [&](int tx, int ty) { coarse[size_t(ty) * size_t(g.tw) + size_t(tx)] = 1; },
      [](int, int, int, int, int, int) { return false; }, w);
  if (half && std::find(coarse.begin(), coarse.end(), uint8_t(1)) != coarse.end())
    composite_half_res(g, half_res_layers(g, coarse, s, bokeh, front_of, exec), color, coarse, exec,
                       out);
  return out;
}

}  // namespace afterimage::post
