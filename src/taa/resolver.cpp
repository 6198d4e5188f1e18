#include "taa/resolver.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <string_view>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/lanes.h"
#include "core/neighborhood.h"
#include "core/prefetch.h"
#include "core/sanitize.h"
#include "core/state_file.h"
#include "reproject/consistency.h"
#include "reproject/footprint.h"
#include "reproject/gather.h"
#include "reproject/history.h"
#include "taa/taa_kernels.h"

namespace afterimage::taa {

namespace {

// Everything one frame's kernel reads and writes. Plain pointers: rows are independent.
struct ResolveContext {
  const TaaSettings* s = nullptr;
  int w = 0, h = 0;
  const float* cur[3] = {};        // sanitized current color
  const float* invalid = nullptr;  // 1 where the input color was not finite (null: none)
  const float* depth = nullptr;
  bool has_depth = false;
  const float* motion[2] = {};
  const uint32_t* id = nullptr;   // null if the frame has no ids
  const float* change = nullptr;  // temporal_change (A-SVGF lambda); null: absent or ignored
  bool has_history = false;
  reproject::Planes<3> history;  // previous resolved color
  const float* count = nullptr;  // previous effective sample count
  reproject::Planes<kLumaMomentPlanes>
      moments;                            // previous luma statistics (LumaMoments; confidence)
  const float* prev_depth = nullptr;      // null if unusable
  const float* prev_motion[2] = {};       // null if unusable
  const uint32_t* prev_id = nullptr;      // null if unusable
  std::array<float, 9> filter_weights{};  // per-frame current filter (jitter dependent)
  std::array<float, 9> fresh_weights{};   // the wider filter of fresh history (if any)
  bool fresh = false;
  bool filter = false;
  int neighbors_needed = 1;  // how many of the 9 current samples the settings use
  bool box_first = false;    // the box is built with the current samples (block_current)
  float* out[3] = {};        // next history
  float* result[3] = {};     // the returned image: the same values (but fresh_filter_sigma's)
  float* out_count = nullptr;
  float* out_moments[kLumaMomentPlanes] = {};  // null unless settings.confidence
  const float* spreads[kSpreadPlanes] = {};    // derived from `moments` (kSpreadPlanes)
  float* out_spreads[kSpreadPlanes] = {};
};

// Whether history confidence reads the 8 neighbours' moments and spreads (neighbor_evidence;
// on content at rest).
inline bool reads_neighbor_evidence(const TaaSettings& s) {
  return s.confidence_neighbor_z > 0.0f || s.confidence_drift_z > 0.0f;
}

// The geometry rejection tests this frame runs (step 5): each needs its setting on and the
// previous frame's plane (and this frame's, for depth and id).
struct GeometryTests {
  bool depth, id, velocity;
};
inline GeometryTests geometry_tests(const ResolveContext& k) {
  const TaaSettings& s = *k.s;
  return {s.depth_reject != Rejection::Off && k.prev_depth && k.has_depth,
          s.id_reject != Rejection::Off && k.prev_id && k.id,
          s.velocity_reject != Rejection::Off && k.prev_motion[0]};
}

// Step 3 of one lane block: velocity dilation, with the dilated neighbour's id and the
// neighbours' largest squared speed (confidence).
template <class D>
struct BlockMotion {
  V<D> depth, mx, my, max_speed2;
  hn::Vec<hn::RebindToUnsigned<D>> id;
};

template <class D>
HWY_INLINE BlockMotion<D> block_motion(D d, const ResolveContext& k, int x,
                                       const std::array<size_t, 3>& rows) {
  const TaaSettings& s = *k.s;
  const int w = k.w;
  const hn::RebindToUnsigned<D> du;
  auto load = [&](const float* plane, int i) { return load_neighbor(d, plane, rows, x, i, 1, w); };
  auto max_speed2 = hn::Zero(d);  // largest squared speed of the neighbours read (confidence)
  auto id_c = k.id ? load_neighbor(du, k.id, rows, x, 0, 1, w) : hn::Zero(du);
  const DilatedMotion<D> dm = dilate_velocity_streamed(
      d, s.dilation,
      [&](int i, V<D>& de, V<D>& mx, V<D>& my) {
        de = sanitize_depth(d, load(k.depth, i), kBackgroundDepth);
        mx = load(k.motion[0], i);
        my = load(k.motion[1], i);
        if (s.confidence) {
          const auto l2 = hn::MulAdd(mx, mx, hn::Mul(my, my));
          max_speed2 = hn::Max(max_speed2, hn::IfThenElseZero(hn::IsFinite(l2), l2));
        }
      },
      [&](int i, hn::Mask<D> take) {
        if (k.id)
          id_c = hn::IfThenElse(hn::RebindMask(du, take), load_neighbor(du, k.id, rows, x, i, 1, w),
                                id_c);
      });
  return {dm.depth, dm.mx, dm.my, max_speed2, id_c};
}

// Step 4's resample of one lane block (k.has_history only): the history at p + motion,
// bicubic clamped to its 2x2 footprint box when anti-ringing is on; not yet checked for finiteness.
template <class D>
HWY_INLINE Color3<D> block_history(D d, const ResolveContext& k, int x, int y, V<D> mx, V<D> my) {
  const TaaSettings& s = *k.s;
  const reproject::HistoryPosition<D> hp = reproject::history_position(d, x, y, mx, my, k.w, k.h);
  reproject::PixelBox<D, 3> ring;
  const bool bicubic = s.history != HistorySampler::Bilinear && !s.static_mode;
  reproject::PixelBox<D, 3>* ring_out = s.anti_ringing && bicubic ? &ring : nullptr;
  Color3<D> hist = reproject::as_color3(reproject::sample_history(
      d, history_filter(s.history, s.static_mode), k.history, hp.x, hp.y, ring_out));
  if (ring_out) hist = clamp_to_aabb(reproject::as_aabb(ring), hist);
  return hist;
}

// Steps 1-2 of one lane block: the current neighbourhood (already sanitized). A loop of
// constant count, unrolled, so the neighbours stay in registers (see dilate_velocity_unrolled).
template <class D, class Load>
HWY_INLINE void load_current(const ResolveContext& k, Load&& load, Color3<D> (&nb)[9]) {
  if (k.neighbors_needed == 9) {
#pragma GCC unroll 9
    for (int i = 0; i < 9; ++i) nb[i] = {load(k.cur[0], i), load(k.cur[1], i), load(k.cur[2], i)};
  } else {
    nb[0] = {load(k.cur[0], 0), load(k.cur[1], 0), load(k.cur[2], 0)};
  }
}

// This frame's share of one lane block: the current color, its filtered color, the
// neighbourhood box (k.box_first), its luma and 3x3 luma deviation and what the 8 neighbours'
// moments say (confidence). None of it depends on the history.
template <class D>
struct BlockCurrent {
  Color3<D> raw, filtered;
  Aabb<D> box;
  V<D> luma, sigma_spatial;
  NeighborEvidence<D> nbe;
};

template <class D>
HWY_INLINE BlockCurrent<D> block_current(D d, const ResolveContext& k, int x,
                                         const std::array<size_t, 3>& rows, V<D> max_speed2) {
  const TaaSettings& s = *k.s;
  const auto zero = hn::Zero(d);
  auto load = [&](const float* plane, int i) {
    return load_neighbor(d, plane, rows, x, i, 1, k.w);
  };
  Color3<D> nb[9];
  load_current<D>(k, load, nb);
  BlockCurrent<D> c;
  c.raw = nb[0];
  c.filtered =
      k.filter ? filter_current_color(d, nb, k.filter_weights, s.filter_luma_weight) : nb[0];
  if (k.box_first) c.box = neighborhood_box(d, s, nb);
  c.luma = luminance(d, nb[0]);
  c.sigma_spatial = zero;      // this frame's 3x3 luma standard deviation
  c.nbe = {zero, zero, zero};  // what the 8 neighbours say (at rest)
  if (s.confidence) {
    V<D> lumas[9];
    for (int i = 0; i < 9; ++i) lumas[i] = luminance(d, nb[i]);
    c.sigma_spatial = hn::Sqrt(neighborhood_luma_variance(d, lumas, 9));
    // Unused where the neighbours' speed alone gives a speed factor of +0 in every lane
    // (history_confidence returns +0 there: the remembered speed is at least this one).
    const bool moving = hn::AllTrue(
        d, hn::Eq(confidence_from_speed(d, hn::Sqrt(max_speed2), s.confidence_motion_px), zero));
    if (k.has_history && reads_neighbor_evidence(s) && !moving)
      c.nbe = neighbor_evidence(d, lumas, load, k.moments.p[0], k.moments.p[6], k.spreads[0],
                                k.spreads[1]);
  }
  return c;
}

// The rest of one lane block of the resolve (see the steps in resolver.h), given this frame's
// share (block_current), its dilated motion (block_motion) and, with history, its resampled
// history (block_history).
template <class D>
HWY_INLINE void resolve_block(D d, const ResolveContext& k, int x, int y,
                              const BlockCurrent<D>& cur, const BlockMotion<D>& bm,
                              const Color3<D>& hist_sampled) {
  const TaaSettings& s = *k.s;
  const int w = k.w, h = k.h;
  const hn::RebindToUnsigned<D> du;
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  const std::array<size_t, 3> rows = neighborhood_rows(y, w, h);
  auto load = [&](const float* plane, int i) { return load_neighbor(d, plane, rows, x, i, 1, w); };
  // The 3x3 colours again, for the rare steps that need them all (the convex hull, the fresh
  // filter in young history): loaded, not kept live across the block.
  auto neighbors = [&](Color3<D>(&nb)[9]) { load_current<D>(k, load, nb); };

  // 1-2. Current color (already sanitized) and its filtered color (block_current).
  const Color3<D> raw = cur.raw, filtered = cur.filtered;

  // 3. Velocity dilation (block_motion): depth, motion and id of the chosen neighbour.
  const hn::Vec<decltype(du)> no_id = hn::Zero(du);
  const auto max_speed2 = bm.max_speed2;
  const auto id_own = k.id ? load_neighbor(du, k.id, rows, x, 0, 1, w) : no_id;
  const auto id_c = bm.id;
  const auto depth_c = bm.depth;
  const auto depth_own = sanitize_depth(d, load(k.depth, 0), kBackgroundDepth);
  const auto mx = bm.mx, my = bm.my;

  // Reprojection: history for pixel center p is read at p + motion (DESIGN.md §3);
  // off-screen positions are rejected.
  const reproject::HistoryPosition<D> hp = reproject::history_position(d, x, y, mx, my, w, h);
  const auto px = hp.x, py = hp.y;
  // History weight in [0, 1]: 0 = no usable history for this pixel.
  auto keep = k.has_history ? hn::IfThenElse(hp.onscreen, one, zero) : zero;

  // 4. History fetch.
  Color3<D> hist = raw;
  auto n_hist = zero;
  // History confidence (taa_kernels.h): the raw sample's luma against the pixel's temporal
  // luma distribution, fetched at p + motion like history.
  const auto luma_x = cur.luma;
  const auto speed_nb = hn::Sqrt(max_speed2);  // the neighbours' largest speed (confidence)
  LumaMoments<D> moments{luma_x, zero, luma_x, zero, zero, speed_nb, zero};
  const auto sigma_spatial = cur.sigma_spatial;
  const NeighborEvidence<D> nbe = cur.nbe;
  auto conf = zero;
  // aliasing_sigma of the fetched moments: the z score's and the box relaxation's (one square
  // root; 0 without history, as aliasing_sigma of the restarted moments).
  auto sigma_alias = zero;
  auto failed = hn::Gt(zero, zero);  // a geometry test failed (confidence); none yet
  auto at_rest = one;                // how far that failure may be read as aliasing
  if (k.has_history) {
    // Anti-ringing: bicubic history clamped to its 2x2 footprint box (block_history).
    hist = hist_sampled;
    // A non-finite history pixel (e.g. from a loaded state) is reset, never propagated.
    auto fin = all_finite(d, hist);
    keep = hn::IfThenElse(fin, keep, zero);
    hist = select<D>(fin, hist, raw);
    if (s.sample_count || s.confidence) {
      n_hist = reproject::gather_plane(d, k.count, reproject::nearest_pixel_index(d, w, h, px, py));
    }
    if (s.confidence) {
      // The moments are read at the nearest pixel, not resampled: confidence only acts below
      // confidence_motion_px, where that pixel is the same surface, and a bilinear read beside
      // an emitter's edge mixes in the edge pixel's variance. In `room` the ceiling light (luma
      // 13) next to the ceiling (0.02), under a 0.04 px/frame dolly, gave the ceiling pixel a
      // few percent of the edge pixel's variance, a box wider than the light's glow, and a
      // history that built up to 0.44 against a reference of 0.024 (0.18 without confidence).
      hn::Mask<D> m_ok;
      moments = fetch_luma_moments(d, k.moments, px, py, luma_x, hn::FirstN(d, hn::Lanes(d)), m_ok);
      conf = history_confidence(d, luma_x, moments, hn::And(m_ok, hn::Gt(keep, zero)),
                                sigma_spatial, nbe, speed_nb, s);
      // The z score's (same inputs: CSE'd). Unneeded where every lane's confidence is +0: the
      // relaxation is then +0 times a finite sigma (the moments are finite or restarted).
      if (!hn::AllTrue(d, hn::Eq(conf, zero))) sigma_alias = aliasing_sigma(d, moments);
    }
    const auto keep_fetched = keep;

    // 5. Geometry rejection on the 2x2 footprint around p + motion: passes if any of the
    // four previous pixels matches, so reprojection onto an edge is not falsely rejected.
    const auto [test_depth, test_id, test_vel] = geometry_tests(k);
    if (test_depth || test_id || test_vel) {
      // Taps with zero bilinear weight contribute no history, so they cannot validate it;
      // static mode reads only the nearest pixel.
      const reproject::Footprint<D> fp = reproject::bilinear_footprint(d, w, h, px, py);
      const VI<D> taps[4] = {fp.i00, fp.i10, fp.i01, fp.i11};
      const auto fx = s.static_mode ? zero : fp.fx, fy = s.static_mode ? zero : fp.fy;
      hn::Mask<D> used[4];
      reproject::taps_used(d, reproject::bilinear_tap_weights(d, fx, fy), used);
      const VI<D> nearest = reproject::nearest_pixel_index(d, w, h, px, py);
      auto tap = [&](int i) { return s.static_mode ? nearest : taps[i]; };
      auto apply = [&](auto match, Rejection mode) {
        auto fail = hn::Set(d, mode == Rejection::Reset ? 0.0f : s.reject_keep);
        keep = hn::IfThenElse(match, keep, hn::Mul(keep, fail));
      };
      // A tap matches the dilated neighbour's surface or the pixel's own.
      hn::Mask<D> same[4];
      if (test_depth) {
        for (int i = 0; i < 4; ++i) {
          auto pd =
              sanitize_depth(d, reproject::gather_plane(d, k.prev_depth, tap(i)), kBackgroundDepth);
          same[i] = hn::Or(reproject::depth_within_relative(d, pd, depth_c, s.depth_tolerance),
                           reproject::depth_within_relative(d, pd, depth_own, s.depth_tolerance));
        }
        apply(reproject::any_used_tap_passes(d, used, same), s.depth_reject);
      }
      if (test_id) {
        for (int i = 0; i < 4; ++i) {
          auto pid = reproject::gather_plane(du, k.prev_id, tap(i));
          same[i] = hn::RebindMask(d, hn::Or(reproject::id_matches(du, pid, id_c),
                                             reproject::id_matches(du, pid, id_own)));
        }
        apply(reproject::any_used_tap_passes(d, used, same), s.id_reject);
      }
      if (test_vel) {
        auto tol2 = hn::Set(d, s.velocity_tolerance * s.velocity_tolerance);
        for (int i = 0; i < 4; ++i)
          same[i] = reproject::motion_within(
              d, reproject::gather_plane(d, k.prev_motion[0], tap(i)),
              reproject::gather_plane(d, k.prev_motion[1], tap(i)), mx, my, tol2);
        apply(reproject::any_used_tap_passes(d, used, same), s.velocity_reject);
      }
    }
    if (s.confidence) {
      // A failed geometry test withdraws the confidence (a disocclusion must not keep the
      // occluder's history), except near rest (below confidence_geometry_px): seed 003 ① reads
      // depth that changes at zero velocity as sub-pixel geometry seen through jitter, and a color
      // inside the pixel's temporal distribution confirms it, so the confident share of the history
      // is kept.
      // The history's side of "at rest" (a background pixel that a moving blade has just
      // uncovered is still, but what its history holds moved) is already in conf: its speed
      // factor reads the 3x3 speed the moments remember, decayed by confidence_motion_memory.
      // Until 7c8d9b1 at_rest also read the previous frame's motion at the history position,
      // copied every frame (2 planes) for these lanes; without it the demo's 12 scenes moved
      // by at most 0.00013 FLIP (the tuning scenes' sum .14235 -> .14220) and 1080p -9%.
      failed = hn::Lt(keep, keep_fetched);
      // at_rest only matters where a test failed (here and in the moments' restart below):
      // most blocks skip its square root.
      if (!hn::AllFalse(d, failed))
        at_rest = confidence_from_motion(d, mx, my, s.confidence_geometry_px);
      conf = hn::IfThenElse(failed, hn::Mul(conf, at_rest), conf);
      keep = hn::Max(keep, hn::Mul(conf, keep_fetched));
    }
  }

  // 6. Rectification against the current neighbourhood.
  const bool need_box = k.has_history && (s.rectify != Rectify::None || s.adaptive_clamp_distance);
  const auto relax =
      s.confidence ? box_relaxation(d, sigma_alias, conf, s.confidence_box_sigma) : zero;
  RectifiedHistory<D> rh{hist, zero, zero, zero};
  if (need_box && k.box_first) {
    rh = rectify_with_box(d, s, cur.box, filtered, hist, relax);
  } else if (need_box) {
    Color3<D> nb[9];
    neighbors(nb);
    rh = rectify_history(d, s, nb, filtered, hist, relax);
  }
  Color3<D> hist_r = rh.history;
  const V<D> luma_h = rh.luma, luma_lo = rh.luma_lo, luma_hi = rh.luma_hi;

  // 7. Blend factor and blend.
  // With history confidence, a fully trusted pixel blends its raw sample and any other the
  // filtered color (confident_blend_source).
  const Color3<D> cur_b = !s.blend_filtered ? raw
                          : s.confidence    ? confident_blend_source(d, raw, filtered, conf)
                                            : filtered;
  // Fresh history: the color shown (not the one stored) takes the wider filter's color, handed
  // over as frames accumulate. Blocks whose every lane has handed over skip the second filter.
  Color3<D> cur_shown = cur_b;
  bool shown_differs = false;
  if (k.fresh) {
    const auto t = fresh_filter_handover(d, hn::Mul(n_hist, keep), s.fresh_filter_frames);
    const auto handed_over = hn::Ge(t, one);
    shown_differs = !hn::AllTrue(d, handed_over);
    if (shown_differs) {
      Color3<D> nb[9];
      neighbors(nb);
      // A lane that has handed over shows cur_b itself, as in a block that skips the blend:
      // lerp(wide, cur_b, 1) can differ from cur_b in the last bit, and a pixel must not
      // depend on its block (--simd off runs every pixel as a block of one).
      cur_shown = select<D>(
          handed_over, cur_b,
          fresh_blend_source(d, filter_current_color(d, nb, k.fresh_weights, s.filter_luma_weight),
                             cur_b, t));
    }
  }
  auto alpha = hn::Set(d, s.sample_count ? s.alpha_min : s.alpha);
  if (s.confidence) alpha = lerp<D>(alpha, hn::Set(d, s.confident_alpha_min), conf);
  if (s.adaptive_luma_difference)
    alpha = alpha_from_luma_difference(d, luminance(d, cur_b), luminance(d, hist_r),
                                       s.luma_feedback_min, s.luma_feedback_max);
  if (s.adaptive_depth && k.has_depth)
    alpha = alpha_from_depth(d, alpha, depth_c, s.depth_alpha_far, s.depth_alpha_distance,
                             kBackgroundDepth);
  if (s.adaptive_clamp_distance && need_box)
    alpha = alpha_from_clamp_distance(d, alpha, luma_h, luma_lo, luma_hi, s.clamp_alpha_scale);
  if (s.adaptive_velocity)
    alpha = alpha_from_velocity(d, alpha, mx, my, s.velocity_alpha_max, s.velocity_alpha_px);
  // Rejection scales the sample count: N = keep * N_prev + 1 (reset -> box restarts).
  const auto n_new = hn::MulAdd(n_hist, keep, one);
  // 1 / max(N, 1): the sample-count alpha's and, where N >= 1 (every lane of almost every
  // block), the moments' 1 / N below: one division for both, the same bits.
  const auto inv_n = s.sample_count ? inverse_sample_count(d, n_new) : zero;
  if (s.sample_count) {
    alpha = hn::Max(alpha, inv_n);  // alpha_from_sample_count
  } else {
    alpha = hn::NegMulAdd(hn::Sub(one, alpha), keep, one);  // 1 - (1 - alpha) keep
  }
  if (k.change) {
    // A-SVGF's rule (Schied et al. 2018 Sec. 5) on TAA's blend: alpha' = (1 - l) alpha + l,
    // l = min(1, scale * lambda). With the sample count, N = 1 / alpha' also shortens the
    // history the next frames build on. A non-finite lambda counts as no change.
    auto lam = hn::Mul(hn::LoadU(d, k.change + rows[1] + x), hn::Set(d, s.temporal_change));
    lam = saturate(d, hn::IfThenElseZero(hn::IsFinite(lam), lam));
    alpha = hn::MulAdd(hn::Sub(one, lam), alpha, lam);
  }
  alpha = hn::Min(hn::Max(alpha, hn::Set(d, 0.001f)), one);
  // A pixel whose input was not finite has no current sample: keep its history as is (its
  // sanitized value only serves the neighbours' boxes and filters); without history the
  // sanitized value (neighbourhood mean) is used.
  auto count = hn::Div(one, alpha);  // effective N = 1 / alpha (exact while alpha = 1/N)
  if (k.invalid) {
    auto hold = hn::And(hn::Gt(hn::LoadU(d, k.invalid + rows[1] + x), zero), hn::Gt(keep, zero));
    alpha = hn::IfThenElse(hold, zero, alpha);
    count = hn::IfThenElse(hold, hn::Max(hn::Mul(n_hist, keep), one), count);
  }
  // Without history the blend must return the current color exactly.
  const auto has_history = hn::Gt(keep, zero);
  const auto blend = [&](const Color3<D>& cur) {
    const Color3<D> h = select<D>(has_history, hist_r, cur);
    return s.luma_weight ? blend_luma_weighted(d, cur, h, alpha)
                         : blend_exponential(d, cur, h, alpha);
  };
  Color3<D> out = blend(cur_b);
  const auto fin = all_finite(d, out);  // e.g. overflow of huge HDR values
  out = select<D>(fin, out, cur_b);
  // The shown color: the same blend of the fresh-history color (see above).
  Color3<D> shown = out;
  if (shown_differs) {
    shown = blend(cur_shown);
    shown = select<D>(all_finite(d, shown), shown, cur_shown);
  }
  count = hn::IfThenElse(fin, count, one);
  if (s.confidence) {
    // The moments remember as many frames as the history (its count, floored by
    // moments_alpha_min) and restart where the history was dropped. A change does not
    // restart them: the lagging mean keeps z high (and the box tight) until it has caught up.
    const auto inv =
        s.sample_count && hn::AllTrue(d, hn::Ge(n_new, one)) ? inv_n : hn::Div(one, n_new);
    auto a_m = hn::Max(hn::Set(d, s.moments_alpha_min), inv);
    a_m = hn::IfThenElse(hn::Le(keep, zero), one, a_m);
    // A geometry failure that is not aliasing (something moved) restarts them too.
    a_m = hn::IfThenElse(failed, hn::Max(a_m, hn::Sub(one, at_rest)), a_m);
    if (k.invalid) a_m = hn::IfThenElse(hn::Eq(alpha, zero), zero, a_m);  // held pixel
    const LumaMoments<D> m = update_luma_moments(
        d, moments, luma_x, hn::Mul(sigma_spatial, sigma_spatial), a_m, s.confidence_drift_alpha);
    store_luma_moments(d, m, moments.recent_motion, k.out_moments, k.out_spreads,
                       rows[1] + size_t(x), s);
  }

  const size_t o = rows[1] + size_t(x);
  hn::StoreU(out.c0, d, k.out[0] + o);
  hn::StoreU(out.c1, d, k.out[1] + o);
  hn::StoreU(out.c2, d, k.out[2] + o);
  hn::StoreU(shown.c0, d, k.result[0] + o);
  hn::StoreU(shown.c1, d, k.result[1] + o);
  hn::StoreU(shown.c2, d, k.result[2] + o);
  hn::StoreU(count, d, k.out_count + o);
}

// Software prefetch for one row (core/prefetch.h; 0aefc8c, docs/perf/profile-taa-resolve.md): the
// default resolve streams ~30 planes at once (the inputs' three rows, the previous frame's planes
// around the reprojected rows, ~16 output planes), and its hottest instructions were the first
// loads of the row below. One line per plane and block, kPrefetchAhead pixels ahead: the inputs'
// row below (the only new one per row) of the planes read as 3x3 neighbourhoods, the outputs for
// writing, and the previous frame's planes at the lowest row the history filter reads at rest
// (a guess where motion is large; those rows are read by the next rows anyway). Kernel samples
// -18 to -25% (default), -20% (`none`).
// Pixels: 8 blocks of 16 lanes; 64, 256 and 512 measured 4-10% slower (taa.resolve, 1874b0e).
constexpr int kPrefetchAhead = 128;

PlanePrefetch row_prefetch(const ResolveContext& k, int y, const std::array<size_t, 3>& rows) {
  const TaaSettings& s = *k.s;
  using P = PlanePrefetch;
  PlanePrefetch p;
  p.set_row(P::kRead, rows[2]);
  p.set_row(P::kWrite, rows[1]);
  // The lowest history row read at rest: bilinear (and static mode's point read) y + 1,
  // Catmull-Rom 5 y + 2.
  const bool bilinear = s.history == HistorySampler::Bilinear || s.static_mode;
  p.set_row(P::kPrevious, size_t(std::min(y + (bilinear ? 1 : 2), k.h - 1)) * size_t(k.w));
  if (k.neighbors_needed == 9)
    for (int c = 0; c < 3; ++c) p.add(P::kRead, k.cur[c]);
  if (s.dilation != VelocityDilation::None) {
    p.add(P::kRead, k.depth);
    p.add(P::kRead, k.motion[0]);
    p.add(P::kRead, k.motion[1]);
    if (k.id) p.add(P::kRead, k.id);
  }
  if (s.confidence && k.has_history && reads_neighbor_evidence(s)) {
    p.add(P::kRead, k.moments.p[0]);
    p.add(P::kRead, k.moments.p[6]);
    p.add(P::kRead, k.spreads[0]);
    p.add(P::kRead, k.spreads[1]);
  }
  for (int c = 0; c < 3; ++c) p.add(P::kWrite, k.out[c]);
  for (int c = 0; c < 3; ++c) p.add(P::kWrite, k.result[c]);
  p.add(P::kWrite, k.out_count);
  if (s.confidence) {
    for (int c = 0; c < kLumaMomentPlanes; ++c) p.add(P::kWrite, k.out_moments[c]);
    for (int c = 0; c < kSpreadPlanes; ++c) p.add(P::kWrite, k.out_spreads[c]);
  }
  if (k.has_history) {
    for (int c = 0; c < 3; ++c) p.add(P::kPrevious, k.history.p[c]);
    if (s.sample_count || s.confidence) p.add(P::kPrevious, k.count);
    if (s.confidence)
      for (int c = 0; c < kLumaMomentPlanes; ++c) p.add(P::kPrevious, k.moments.p[c]);
    if (k.prev_depth) p.add(P::kPrevious, k.prev_depth);
    if (k.prev_id) p.add(P::kPrevious, k.prev_id);
  }
  return p;
}

// The planes one frame streams (TemporalResolver::last_traffic): those the kernel reads for
// every pixel (a 3x3 neighbourhood, the history's resampling footprint and the rejection taps
// each count once) and those it and the row copies of the G-buffer (`copied`) write.
PlaneTraffic streamed_planes(const ResolveContext& k, int copied) {
  const TaaSettings& s = *k.s;
  // Color, depth (or the flat background plane), motion (one zero plane when absent).
  int read = 3 + 1 + (k.motion[0] == k.motion[1] ? 1 : 2);
  read += int(k.invalid != nullptr) + int(k.id != nullptr) + int(k.change != nullptr);
  if (k.has_history) {
    read += 3 + int(s.sample_count || s.confidence);  // history, its sample count
    if (s.confidence) {
      read += kLumaMomentPlanes;
      // The neighbours' spreads (neighbor_evidence: read at rest, prefetched wherever).
      if (reads_neighbor_evidence(s)) read += kSpreadPlanes;
    }
    const GeometryTests t = geometry_tests(k);
    read += int(t.depth) + int(t.id) + 2 * int(t.velocity);
  }
  // The next history, the shown color, the sample count, the moments and their spreads.
  const int write = 3 + 3 + 1 + (s.confidence ? kLumaMomentPlanes + kSpreadPlanes : 0) + copied;
  return {read, write};
}

// One lane block: this frame's share, the dilation, the history resample, the rest. (Run as
// four loops over strips of blocks, which spilled less, they measured 0-15% faster by the load
// on the machine, and not faster with the row prefetch: docs/perf/profile-taa-resolve.md.)
template <class D>
HWY_INLINE void resolve_block_fused(D d, const ResolveContext& k, int x, int y,
                                    const std::array<size_t, 3>& rows) {
  const BlockMotion<D> m = block_motion(d, k, x, rows);
  const BlockCurrent<D> c = block_current(d, k, x, rows, m.max_speed2);
  Color3<D> hist;
  if (k.has_history) hist = block_history(d, k, x, y, m.mx, m.my);
  resolve_block(d, k, x, y, c, m, hist);
}

// One row of the resolve: each full-width block first prefetches the lines the block
// kPrefetchAhead pixels on will read and write (row_prefetch).
void resolve_row(const Exec& ex, const ResolveContext& k, int y) {
  const std::array<size_t, 3> rows = neighborhood_rows(y, k.w, k.h);
  int x = 0;
  if (ex.simd) {
    const PlanePrefetch prefetch = row_prefetch(k, y, rows);
    const FullTag d;
    const int n = int(hn::Lanes(d));
    for (; x + n <= k.w; x += n) {
      const size_t xa = size_t(std::min(x + kPrefetchAhead, k.w - 1));
      prefetch.lines(xa, xa, xa);
      resolve_block_fused(d, k, x, y, rows);
    }
  }
  const OneTag d1;
  for (; x < k.w; ++x) resolve_block_fused(d1, k, x, y, rows);
}

void check_channel(const ImageF& img, int channels, int w, int h, const char* name) {
  if (img.empty()) return;
  if (img.channels() != channels || img.width() != w || img.height() != h)
    throw InputError(fmt::format("taa input frame: {} is {}x{}x{}, expected {}x{}x{}", name,
                                 img.width(), img.height(), img.channels(), w, h, channels));
}

}  // namespace

TemporalResolver::TemporalResolver(const TaaSettings& settings, Exec exec)
    : settings_(settings), exec_(exec) {
  settings_.validate();
}

void TemporalResolver::set_settings(const TaaSettings& s) {
  s.validate();
  settings_ = s;
}

void TemporalResolver::reset() {
  valid_ = false;
  frames_ = 0;
  loaded_from_.clear();
}

ImageF TemporalResolver::process(const Frame& f) {
  if (f.color.channels() != 3 || f.color.empty())
    throw InputError("taa input frame: missing color channels R G B");
  const int w = f.color.width(), h = f.color.height();
  check_channel(f.depth, 1, w, h, "depth");
  check_channel(f.motion, 2, w, h, "motion");
  check_channel(f.temporal_change, 1, w, h, "temporal_change");
  if (!f.id.empty() && (f.id.channels() != 1 || f.id.width() != w || f.id.height() != h))
    throw InputError(fmt::format("taa input frame: id is {}x{}x{}, expected {}x{}x1", f.id.width(),
                                 f.id.height(), f.id.channels(), w, h));

  // A state file saved at another size is the user's mistake, not a resolution change:
  // say so instead of silently starting without the history they asked for.
  if (!loaded_from_.empty() && valid_ && (w != width_ || h != height_))
    throw InputError(fmt::format("{}: state saved at {}x{}, the sequence is {}x{}", loaded_from_,
                                 width_, height_, w, h));
  loaded_from_.clear();
  // History is unusable across a resolution change or a camera cut.
  if (w != width_ || h != height_ || history_.empty()) {
    width_ = w;
    height_ = h;
    valid_ = false;
    history_ = ImageF(w, h, 3);
    count_ = ImageF(w, h, 1);
  }
  if (f.camera_cut) valid_ = false;
  if (!next_history_.same_shape(history_)) {
    next_history_ = ImageF(w, h, 3);
    next_count_ = ImageF(w, h, 1);
  }
  if (settings_.confidence) {
    // Unknown moments (NaN) restart at the first sample (a state saved without them, a
    // resolution change, or confidence switched on mid-sequence).
    if (moments_.width() != w || moments_.height() != h || moments_.channels() != kLumaMomentPlanes)
      moments_ = ImageF(w, h, kLumaMomentPlanes, std::numeric_limits<float>::quiet_NaN());
    if (!next_moments_.same_shape(moments_)) next_moments_ = ImageF(w, h, kLumaMomentPlanes);
    // The spreads derived from the moments; unknown (NaN: the neighbour counts for nothing)
    // until a frame has stored them.
    if (spreads_.width() != w || spreads_.height() != h)
      spreads_ = ImageF(w, h, kSpreadPlanes, std::numeric_limits<float>::quiet_NaN());
    if (!next_spreads_.same_shape(spreads_)) next_spreads_ = ImageF(w, h, kSpreadPlanes);
  }

  const TaaSettings& s = settings_;
  ResolveContext k;
  k.s = &s;
  k.w = w;
  k.h = h;
  // NaN / Inf / negative inputs never enter history (core/sanitize.h). Checked row by row
  // during the resolve (below); the color is used as is unless a row needs sanitising.
  for (int c = 0; c < 3; ++c) k.cur[c] = f.color.plane(c);
  k.invalid = nullptr;
  k.has_depth = f.has_depth();
  if (!k.has_depth && background_depth_.width() != w * h) {
    background_depth_ = ImageF(w * h, 1, 1, kBackgroundDepth);  // one flat plane
  }
  k.depth = k.has_depth ? f.depth.plane(0) : background_depth_.plane(0);
  if (f.has_motion()) {
    k.motion[0] = f.motion.plane(0);
    k.motion[1] = f.motion.plane(1);
  } else {
    if (zero_motion_.width() != w * h) zero_motion_ = ImageF(w * h, 1, 1, 0.0f);
    k.motion[0] = k.motion[1] = zero_motion_.plane(0);
  }
  k.id = f.has_id() ? f.id.plane(0) : nullptr;
  k.change = s.temporal_change > 0.0f && f.has(Channel::temporal_change)
                 ? f.temporal_change.plane(0)
                 : nullptr;
  k.has_history = valid_;
  k.history = reproject::planes_of<3>(history_);
  k.count = count_.plane(0);
  if (s.confidence) {
    k.moments = reproject::planes_of<kLumaMomentPlanes>(moments_);
    for (int c = 0; c < kLumaMomentPlanes; ++c) k.out_moments[c] = next_moments_.plane(c);
    for (int c = 0; c < kSpreadPlanes; ++c) {
      k.spreads[c] = spreads_.plane(c);
      k.out_spreads[c] = next_spreads_.plane(c);
    }
  }
  k.prev_depth =
      prev_depth_.channels() == 1 && prev_depth_.width() == w && prev_depth_.height() == h
          ? prev_depth_.plane(0)
          : nullptr;
  if (prev_motion_.channels() == 2 && prev_motion_.width() == w && prev_motion_.height() == h) {
    k.prev_motion[0] = prev_motion_.plane(0);
    k.prev_motion[1] = prev_motion_.plane(1);
  }
  k.prev_id = prev_id_.channels() == 1 && prev_id_.width() == w && prev_id_.height() == h
                  ? prev_id_.plane(0)
                  : nullptr;
  k.filter = s.current_filter != CurrentFilter::None;
  k.filter_weights = current_filter_weights(s.current_filter, s.filter_sigma,
                                            {float(f.jitter.x), float(f.jitter.y)});
  k.fresh = s.fresh_filter_sigma > 0.0f && s.sample_count;
  if (k.fresh)
    k.fresh_weights = current_filter_weights(CurrentFilter::Gaussian, s.fresh_filter_sigma,
                                             {float(f.jitter.x), float(f.jitter.y)});
  k.neighbors_needed =
      (k.filter || s.rectify != Rectify::None || s.adaptive_clamp_distance || s.confidence) ? 9 : 1;
  // Every rectification but the convex hull needs only the box of the current samples.
  k.box_first = k.has_history && (s.rectify != Rectify::None || s.adaptive_clamp_distance) &&
                s.rectify != Rectify::ConvexHull;
  for (int c = 0; c < 3; ++c) k.out[c] = next_history_.plane(c);
  k.out_count = next_count_.plane(0);

  // The returned image is stored by the kernel beside the history (no copy pass). The G-buffer
  // the next frame compares against (prev_depth_ / prev_motion_ / prev_id_) is written row by
  // row right after the row is resolved, while its data are in cache, and only the planes the
  // settings' rejection tests read (a preset without them, like `none`, copies nothing;
  // settings switched to a test start it a frame later, as after a frame without the
  // channel). The previous G-buffer is still read by this frame's gathers, so it goes to
  // scratch images swapped in afterwards.
  ImageF out = ImageF::uninitialized(w, h, 3);  // every pixel is stored by the kernel
  for (int c = 0; c < 3; ++c) k.result[c] = out.plane(c);
  auto full_size = [&](const auto& img) { return img.width() == w && img.height() == h; };
  const bool want_depth = s.depth_reject != Rejection::Off;
  const bool want_motion = s.velocity_reject != Rejection::Off;
  const bool want_id = s.id_reject != Rejection::Off;
  const bool keep_depth = want_depth && f.has_depth() && full_size(f.depth);
  const bool keep_motion = want_motion && f.has_motion() && full_size(f.motion);
  const bool keep_id = want_id && f.has_id() && full_size(f.id);
  if (keep_depth && !next_prev_depth_.same_shape(f.depth)) next_prev_depth_ = ImageF(w, h, 1);
  if (keep_motion && !next_prev_motion_.same_shape(f.motion)) next_prev_motion_ = ImageF(w, h, 2);
  if (keep_id && !next_prev_id_.same_shape(f.id)) next_prev_id_ = ImageU32(w, h, 1);
  row_needs_sanitize_.assign(size_t(h), 0);
  const size_t row_bytes = size_t(w) * sizeof(float);
  auto resolve_frame = [&](bool check_rows) {
    parallel_rows(exec_, h, [&](int y) {
      resolve_row(exec_, k, y);
      if (check_rows) row_needs_sanitize_[size_t(y)] = row_needs_sanitize(f.color, y);
      if (keep_depth) std::memcpy(next_prev_depth_.row(0, y), f.depth.row(0, y), row_bytes);
      if (keep_motion)
        for (int c = 0; c < 2; ++c)
          std::memcpy(next_prev_motion_.row(c, y), f.motion.row(c, y), row_bytes);
      if (keep_id) std::memcpy(next_prev_id_.row(0, y), f.id.row(0, y), row_bytes);
    });
  };
  resolve_frame(true);
  traffic_ = streamed_planes(k, int(keep_depth) + 2 * int(keep_motion) + int(keep_id));
  if (std::find(row_needs_sanitize_.begin(), row_needs_sanitize_.end(), 1) !=
      row_needs_sanitize_.end()) {
    // Rare: some input was NaN / Inf / negative. Sanitise the frame and resolve it again
    // (everything written above is overwritten).
    const bool sanitized = sanitize_color(f.color, sanitized_, invalid_, exec_);
    AI_CHECK(sanitized);
    for (int c = 0; c < 3; ++c) k.cur[c] = sanitized_.plane(c);
    k.invalid = invalid_.plane(0);
    resolve_frame(false);
  }

  std::swap(history_, next_history_);
  std::swap(count_, next_count_);
  if (s.confidence) {
    std::swap(moments_, next_moments_);
    std::swap(spreads_, next_spreads_);
  }
  if (keep_depth) {
    std::swap(prev_depth_, next_prev_depth_);
  } else {
    prev_depth_ = want_depth && f.has_depth() ? f.depth : ImageF();
  }
  if (keep_motion) {
    std::swap(prev_motion_, next_prev_motion_);
  } else {
    prev_motion_ = want_motion && f.has_motion() ? f.motion : ImageF();
  }
  if (keep_id) {
    std::swap(prev_id_, next_prev_id_);
  } else {
    prev_id_ = want_id && f.has_id() ? f.id : ImageU32();
  }
  valid_ = true;
  ++frames_;

  return out;
}

// ------------------------------------------------------------------------------------------
// State file: a core/state_file.h file of kind "taa", version 1. Sections: i64 width, height,
// valid, frames; when width > 0: f32 history (3 planes), count (1 plane), and the previous
// frame's f32 prev_depth (1) / prev_motion (2) / u32 prev_id (1) when it had them, and f32
// moments (kLumaMomentPlanes = 7: luma mean, variance, last sample, spatial variance, variance
// about the mean, recent 3x3 speed, drift) and moment_spreads (kSpreadPlanes = 2, derived from
// them) with history confidence; a file with moments of another plane count is refused with
// the section's size in the message.
// ------------------------------------------------------------------------------------------

namespace {

constexpr const char* kStateKind = "taa";
constexpr uint32_t kStateVersion = 1;

}  // namespace

void TemporalResolver::save_state(const std::string& path) const {
  const bool have = !history_.empty();
  StateWriter w(kStateKind, kStateVersion);
  w.put_i64("width", have ? width_ : 0);
  w.put_i64("height", have ? height_ : 0);
  w.put_i64("valid", have && valid_ ? 1 : 0);
  w.put_i64("frames", frames_);
  if (have) {
    w.put("history", history_);
    w.put("count", count_);
    if (!prev_depth_.empty()) w.put("prev_depth", prev_depth_);
    if (!prev_motion_.empty()) w.put("prev_motion", prev_motion_);
    if (!prev_id_.empty()) w.put("prev_id", prev_id_);
    if (!moments_.empty()) w.put("moments", moments_);
    if (!spreads_.empty()) w.put("moment_spreads", spreads_);
  }
  w.save(path);
}

void TemporalResolver::load_state(const std::string& path) {
  const StateReader r(path, kStateKind, kStateVersion);
  const auto [w, h] = r.get_size("width", "height");
  const bool valid = r.get_flag("valid");
  const int64_t frames = r.get_count("frames");

  // Parse into temporaries; the resolver changes only if everything is valid (get_image
  // checks each section's size before allocating its image).
  ImageF hist, count, pdepth, pmotion, moments, spreads;
  ImageU32 pid;
  if (w > 0) {
    hist = r.get_image<float>("history", w, h, 3);
    count = r.get_image<float>("count", w, h, 1);
    if (r.has("prev_depth")) pdepth = r.get_image<float>("prev_depth", w, h, 1);
    if (r.has("prev_motion")) pmotion = r.get_image<float>("prev_motion", w, h, 2);
    if (r.has("prev_id")) pid = r.get_image<uint32_t>("prev_id", w, h, 1);
    if (r.has("moments")) moments = r.get_image<float>("moments", w, h, kLumaMomentPlanes);
    if (r.has("moment_spreads"))
      spreads = r.get_image<float>("moment_spreads", w, h, kSpreadPlanes);
  }
  width_ = int(w);
  height_ = int(h);
  valid_ = valid && w > 0;
  frames_ = long(frames);
  history_ = std::move(hist);
  count_ = std::move(count);
  prev_depth_ = std::move(pdepth);
  prev_motion_ = std::move(pmotion);
  prev_id_ = std::move(pid);
  moments_ = std::move(moments);
  spreads_ = std::move(spreads);
  loaded_from_ = path;
}

}  // namespace afterimage::taa
