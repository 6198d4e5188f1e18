#include "svgf/denoiser.h"

#include <fmt/format.h>

#include <algorithm>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>
#include <utility>

#include "core/color.h"
#include "core/error.h"
#include "core/sanitize.h"
#include "core/state_file.h"
#include "reproject/consistency.h"
#include "reproject/footprint.h"
#include "reproject/gather.h"
#include "reproject/history.h"
#include "svgf/accumulate.h"
#include "svgf/gradient.h"
#include "svgf/history_clamp.h"
#include "svgf/reference.h"
#include "svgf/svgf_kernels.h"

namespace afterimage::svgf {

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// A reprojection tap reads up to 12 planes at the same indices: reproject::Tap tests them for
// being consecutive once (the test was about half of the accumulate's CPU samples while it
// built the lane sequence through Highway 1.0's run-time Iota; core/simd.h iota_from).
using reproject::make_tap;
using reproject::read_tap;
using reproject::Tap;

// The history blended over a set of taps with given weights (summing to 1 where any passed).
template <class D>
struct Blended {
  V<D> n;
  Color3<D> c[kMaxSignals];
  Moments<D> m[kMaxSignals];
  Color3<D> f[kMaxSignals];  // the fast history (k.fast only)
};
template <class D, int N>
HWY_INLINE Blended<D> blend_taps(D d, const AccumulateContext& k, const Tap<D> (&tap)[N],
                                 const V<D> (&w)[N]) {
  Blended<D> b;
  b.n = hn::Zero(d);
  for (int t = 0; t < N; ++t) b.n = hn::MulAdd(w[t], read_tap(d, k.prev_length, tap[t]), b.n);
  for (int sg = 0; sg < k.signals; ++sg) {
    auto c0 = hn::Zero(d), c1 = hn::Zero(d), c2 = hn::Zero(d);
    V<D> mean[N], var[N];
    for (int t = 0; t < N; ++t) {
      c0 = hn::MulAdd(w[t], read_tap(d, k.prev_color[3 * sg], tap[t]), c0);
      c1 = hn::MulAdd(w[t], read_tap(d, k.prev_color[3 * sg + 1], tap[t]), c1);
      c2 = hn::MulAdd(w[t], read_tap(d, k.prev_color[3 * sg + 2], tap[t]), c2);
      mean[t] = read_tap(d, k.prev_mean[sg], tap[t]);
      var[t] = read_tap(d, k.prev_var[sg], tap[t]);
    }
    b.c[sg] = {c0, c1, c2};
    b.m[sg] = blend_moments<D, N>(d, w, mean, var);
    if (k.fast) {
      auto f0 = hn::Zero(d), f1 = hn::Zero(d), f2 = hn::Zero(d);
      for (int t = 0; t < N; ++t) {
        f0 = hn::MulAdd(w[t], read_tap(d, k.prev_fast[3 * sg], tap[t]), f0);
        f1 = hn::MulAdd(w[t], read_tap(d, k.prev_fast[3 * sg + 1], tap[t]), f1);
        f2 = hn::MulAdd(w[t], read_tap(d, k.prev_fast[3 * sg + 2], tap[t]), f2);
      }
      b.f[sg] = {f0, f1, f2};
    }
  }
  return b;
}

template <class D>
HWY_INLINE Blended<D> select_blended(const AccumulateContext& k, hn::Mask<D> m,
                                     const Blended<D>& yes, const Blended<D>& no) {
  Blended<D> r;
  r.n = hn::IfThenElse(m, yes.n, no.n);
  for (int sg = 0; sg < k.signals; ++sg) {
    r.c[sg] = select<D>(m, yes.c[sg], no.c[sg]);
    r.m[sg] = {hn::IfThenElse(m, yes.m[sg].mean, no.m[sg].mean),
               hn::IfThenElse(m, yes.m[sg].var, no.m[sg].var)};
    if (k.fast) r.f[sg] = select<D>(m, yes.f[sg], no.f[sg]);
  }
  return r;
}

// True if a lane of the block at offset o fails step 1's tests (AccumulateContext::check): the
// same conditions as core/sanitize.h and any_bad, on values the block reads anyway (in L1), so
// the clean frame needs no separate pass over ~20 planes. Two operations per plane instead of
// two compares and two mask ANDs (mask operations share one port): the minimum of the values
// finds a negative one or -Inf and their sum any NaN or +Inf (NaN makes the minimum unreliable
// but the sum NaN; a finite sum overflowing to Inf is a false alarm, and the rerun is exact).
template <class D>
HWY_INLINE bool inputs_need_sanitize(D d, const AccumulateContext& k, size_t o) {
  const auto zero = hn::Zero(d), max = hn::Set(d, FLT_MAX);
  const auto z = hn::LoadU(d, k.check_depth + o);
  auto lo = zero, sum = zero, finite_sum = zero;
  for (int i = 0; i < k.check_colors; ++i) {
    const auto v = hn::LoadU(d, k.check_color[i] + o);
    lo = hn::Min(lo, v);
    sum = hn::Add(sum, v);
  }
  for (int i = 0; i < k.check_finites; ++i)
    finite_sum = hn::Add(finite_sum, hn::Abs(hn::LoadU(d, k.check_finite[i] + o)));
  const auto good =
      hn::And(hn::And(hn::Gt(z, zero), hn::Le(z, max)),
              hn::And(hn::And(hn::Ge(lo, zero), hn::Le(sum, max)), hn::Le(finite_sum, max)));
  return !hn::AllTrue(d, good);
}

// One lane block of steps 2-4 (denoiser.h); with k.check, returns true (having stored values
// to be discarded) if an input needs step 1.
template <class D>
HWY_INLINE bool accumulate_block(D d, const AccumulateContext& k, int x, int y) {
  const SvgfSettings& s = *k.s;
  const int w = k.w, h = k.h;
  const size_t o = size_t(y) * size_t(w) + size_t(x);
  const hn::RebindToUnsigned<D> du;
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f), half = hn::Set(d, 0.5f);
  auto load = [&](const float* p) { return hn::LoadU(d, p + o); };
  const bool needs_sanitize = k.check && inputs_need_sanitize(d, k, o);
  if (k.keep_depth) {
    // The G-buffer for the next frame (the copy pass read 5 planes again: df19793).
    store_streaming(load(k.depth), d, k.keep_depth + o);
    for (int ch = 0; ch < 3; ++ch) store_streaming(load(k.normal[ch]), d, k.keep_normal[ch] + o);
    if (k.keep_id)
      store_streaming(hn::BitCast(d, hn::LoadU(du, k.keep_id_from + o)), d,
                      reinterpret_cast<float*>(k.keep_id + o));
  }

  // 2. Demodulated signals of this frame and their luminance.
  Color3<D> cur[kMaxSignals];
  for (int sg = 0; sg < k.signals; ++sg) {
    V<D> c[3];
    for (int ch = 0; ch < 3; ++ch) {
      c[ch] = load(k.signal[3 * sg + ch]);
      if (k.subtract_emission && k.emission[ch])
        c[ch] = hn::Max(hn::Sub(c[ch], load(k.emission[ch])), zero);
      if (k.demodulate)
        c[ch] = hn::Div(c[ch], demodulation_factor(d, load(k.albedo[ch]), s.albedo_epsilon));
    }
    cur[sg] = {c[0], c[1], c[2]};
  }
  V<D> lum[kMaxSignals];
  Blended<D> prev;  // the history, or this frame's values where there is none
  prev.n = zero;
  for (int sg = 0; sg < k.signals; ++sg) {
    lum[sg] = luminance(d, cur[sg]);
    prev.c[sg] = cur[sg];
    prev.m[sg] = {lum[sg], zero};
    prev.f[sg] = cur[sg];
  }

  // 3. Reprojection.
  auto ok = hn::Lt(one, zero);  // all false
  if (k.has_history) {
    const auto z = load(k.depth);
    const Color3<D> n{load(k.normal[0]), load(k.normal[1]), load(k.normal[2])};
    const auto gx = load(k.gradient[0]), gy = load(k.gradient[1]);
    const auto grad_len = hn::Sqrt(hn::MulAdd(gx, gx, hn::Mul(gy, gy)));
    const auto id = k.id ? hn::LoadU(du, k.id + o) : hn::Zero(du);
    // The current sample sits at p + jitter; motion is for unjittered positions and the
    // previous pixel q's sample at q + 0.5 + its jitter (DESIGN.md §3; as the shading cache).
    const auto mx = hn::Add(load(k.motion[0]), hn::Set(d, k.jitter_dx));
    const auto my = hn::Add(load(k.motion[1]), hn::Set(d, k.jitter_dy));
    const reproject::HistoryPosition<D> hp = reproject::history_position(d, x, y, mx, my, w, h);
    // A tap is usable if it is inside the image, shows the same surface and has history.
    auto consistent = [&](const Tap<D>& tap, V<D> tx, V<D> ty, hn::Mask<D> inside) {
      const auto dist = hn::Sqrt(
          hn::MulAdd(hn::Sub(hn::Add(tx, half), hp.x), hn::Sub(hn::Add(tx, half), hp.x),
                     hn::Mul(hn::Sub(hn::Add(ty, half), hp.y), hn::Sub(hn::Add(ty, half), hp.y))));
      const auto pd = read_tap(d, k.prev_depth, tap);
      auto pass = hn::And(inside, reproject::depth_within_slope(d, pd, z, s.depth_tolerance,
                                                                s.depth_slope, grad_len, dist));
      const Color3<D> pn{read_tap(d, k.prev_normal[0], tap), read_tap(d, k.prev_normal[1], tap),
                         read_tap(d, k.prev_normal[2], tap)};
      pass = hn::And(pass, reproject::normal_within_angle(d, pn, n, s.normal_cos));
      if (k.id && k.prev_id)
        pass = hn::And(
            pass, hn::RebindMask(d, reproject::id_matches(du, read_tap(du, k.prev_id, tap), id)));
      return hn::And(pass, hn::Gt(read_tap(d, k.prev_length, tap), zero));
    };
    auto in_image = [&](V<D> tx, V<D> ty) {
      return hn::And(hn::And(hn::Ge(tx, zero), hn::Lt(tx, hn::Set(d, float(w)))),
                     hn::And(hn::Ge(ty, zero), hn::Lt(ty, hn::Set(d, float(h)))));
    };

    // 2x2 bilinear taps, each tested, weights renormalised over the passing ones.
    const reproject::Footprint<D> fp = reproject::bilinear_footprint(d, w, h, hp.x, hp.y);
    const Tap<D> idx[4] = {make_tap(d, fp.i00), make_tap(d, fp.i10), make_tap(d, fp.i01),
                           make_tap(d, fp.i11)};
    const auto x0 = hn::Floor(hn::Sub(hp.x, half)), y0 = hn::Floor(hn::Sub(hp.y, half));
    hn::Mask<D> pass[4];
    for (int t = 0; t < 4; ++t) {
      const auto tx = hn::Add(x0, hn::Set(d, float(t & 1)));
      const auto ty = hn::Add(y0, hn::Set(d, float(t >> 1)));
      pass[t] = hn::And(hp.onscreen, consistent(idx[t], tx, ty, in_image(tx, ty)));
    }
    const reproject::RenormalizedWeights<D> rw =
        reproject::renormalize_weights(d, reproject::bilinear_tap_weights(d, fp.fx, fp.fy), pass);
    if (!hn::AllFalse(d, rw.any)) {
      prev = select_blended<D>(k, rw.any, blend_taps<D, 4>(d, k, idx, rw.weights.w), prev);
      ok = rw.any;
    }
    // 3x3 fallback around the pixel containing p + motion: equal weights over its consistent
    // pixels.
    const auto fallback = hn::AndNot(rw.any, hp.onscreen);
    if (!hn::AllFalse(d, fallback)) {
      const auto cx = hn::Floor(hp.x), cy = hn::Floor(hp.y);
      Tap<D> fidx[9];
      V<D> fw[9];
      auto count = zero;
      for (int t = 0; t < 9; ++t) {
        const auto tx = hn::Add(cx, hn::Set(d, float(t % 3 - 1)));
        const auto ty = hn::Add(cy, hn::Set(d, float(t / 3 - 1)));
        fidx[t] = make_tap(d, reproject::clamped_pixel_index(d, w, h, tx, ty));
        fw[t] = hn::IfThenElseZero(consistent(fidx[t], tx, ty, in_image(tx, ty)), one);
        count = hn::Add(count, fw[t]);
      }
      const auto found = hn::And(fallback, hn::Gt(count, zero));
      if (!hn::AllFalse(d, found)) {
        const auto inv = hn::Div(one, hn::Max(count, one));
        for (int t = 0; t < 9; ++t) fw[t] = hn::Mul(fw[t], inv);
        prev = select_blended<D>(k, found, blend_taps<D, 9>(d, k, fidx, fw), prev);
        ok = hn::Or(ok, found);
      }
    }
    // A non-finite history value (a corrupted state file) is dropped, never propagated.
    auto finite = hn::IsFinite(prev.n);
    for (int sg = 0; sg < k.signals; ++sg)
      finite = hn::And(
          finite, hn::And(all_finite(d, prev.c[sg]),
                          hn::And(hn::IsFinite(prev.m[sg].mean), hn::IsFinite(prev.m[sg].var))));
    if (k.fast)
      for (int sg = 0; sg < k.signals; ++sg) finite = hn::And(finite, all_finite(d, prev.f[sg]));
    const auto dropped = hn::AndNot(finite, ok);
    if (!hn::AllFalse(d, dropped)) {
      ok = hn::And(ok, finite);
      Blended<D> own;
      own.n = zero;
      for (int sg = 0; sg < k.signals; ++sg) {
        own.c[sg] = cur[sg];
        own.m[sg] = {lum[sg], zero};
        own.f[sg] = cur[sg];
      }
      prev = select_blended<D>(k, ok, prev, own);
    }
  }

  if (k.relight) {
    // A-SVGF relighting (gradient.h): the reprojected history scaled by the measured luminance
    // ratio now / prev before the blend, so a change lambda does not fully discard leaves no
    // stale bias. Luminance moments scale as l: mean by r, variance by r^2. Every signal takes
    // the one ratio (the gradient is of the pixel's total luminance), so their sum, the shown
    // color, is corrected; the fast history likewise.
    const auto r = hn::IfThenElse(ok, load(k.relight), one);
    for (int sg = 0; sg < k.signals; ++sg) {
      prev.c[sg] = scale<D>(prev.c[sg], r);
      prev.m[sg] = {hn::Mul(prev.m[sg].mean, r), hn::Mul(hn::Mul(prev.m[sg].var, r), r)};
      if (k.fast) prev.f[sg] = scale<D>(prev.f[sg], r);
    }
  }
  // 4. Accumulation with the reprojected history length.
  auto alpha = hn::IfThenElse(ok, temporal_alpha(d, prev.n, s.alpha_min), one);
  auto alpha_m = hn::IfThenElse(ok, temporal_alpha(d, prev.n, s.moments_alpha_min), one);
  auto n_prev = prev.n;
  if (k.lambda) {
    // A-SVGF (gradient.h): alpha' = (1 - lambda) alpha + lambda where the lighting changed.
    const auto lam = load(k.lambda);
    const auto keep = hn::Sub(one, lam);
    alpha = hn::IfThenElse(ok, hn::Add(hn::Mul(keep, alpha), lam), alpha);
    alpha_m = hn::IfThenElse(ok, hn::Add(hn::Mul(keep, alpha_m), lam), alpha_m);
    if (k.shorten_history) n_prev = hn::Mul(keep, n_prev);
  }
  auto n_next = hn::IfThenElse(ok, next_history_length(d, n_prev, float(s.history_cap)), one);
  auto alpha_f =
      k.fast ? hn::IfThenElse(ok, temporal_alpha(d, n_prev, k.fast_alpha_min), one) : one;
  if (k.invalid) {
    // A repaired input: history reset; its value is this frame's only (length 0, so no other
    // pixel's reprojection takes it as history next frame).
    const auto bad = hn::Gt(load(k.invalid), zero);
    alpha = hn::IfThenElse(bad, one, alpha);
    alpha_m = hn::IfThenElse(bad, one, alpha_m);
    alpha_f = hn::IfThenElse(bad, one, alpha_f);
    n_next = hn::IfThenElseZero(hn::Not(bad), n_next);
    for (int sg = 0; sg < k.signals; ++sg) {
      prev.c[sg] = select<D>(bad, cur[sg], prev.c[sg]);
      prev.m[sg] = {hn::IfThenElse(bad, lum[sg], prev.m[sg].mean),
                    hn::IfThenElseZero(hn::Not(bad), prev.m[sg].var)};
      if (k.fast) prev.f[sg] = select<D>(bad, cur[sg], prev.f[sg]);
    }
  }
  if (k.fast) {
    // Fast history with its own alpha; the long blend is left to clamp_history_to_fast_box,
    // which needs the whole fast image (its box spans neighbours).
    hn::StoreU(alpha, d, k.alpha_out + o);
    for (int sg = 0; sg < k.signals; ++sg) {
      const V<D> pc[3] = {prev.c[sg].c0, prev.c[sg].c1, prev.c[sg].c2};
      const V<D> pf[3] = {prev.f[sg].c0, prev.f[sg].c1, prev.f[sg].c2};
      const V<D> cc[3] = {cur[sg].c0, cur[sg].c1, cur[sg].c2};
      for (int ch = 0; ch < 3; ++ch) {
        hn::StoreU(accumulate(d, pf[ch], cc[ch], alpha_f), d, k.fast_acc[3 * sg + ch] + o);
        hn::StoreU(pc[ch], d, k.long_prev[3 * sg + ch] + o);
        hn::StoreU(cc[ch], d, k.acc[3 * sg + ch] + o);
      }
      const Moments<D> m = accumulate_moments(d, prev.m[sg], lum[sg], alpha_m);
      hn::StoreU(m.mean, d, k.mean[sg] + o);
      hn::StoreU(m.var, d, k.var[sg] + o);
    }
    hn::StoreU(n_next, d, k.length + o);
    return needs_sanitize;
  }
  for (int sg = 0; sg < k.signals; ++sg) {
    hn::StoreU(accumulate(d, prev.c[sg].c0, cur[sg].c0, alpha), d, k.acc[3 * sg] + o);
    hn::StoreU(accumulate(d, prev.c[sg].c1, cur[sg].c1, alpha), d, k.acc[3 * sg + 1] + o);
    hn::StoreU(accumulate(d, prev.c[sg].c2, cur[sg].c2, alpha), d, k.acc[3 * sg + 2] + o);
    const Moments<D> m = accumulate_moments(d, prev.m[sg], lum[sg], alpha_m);
    hn::StoreU(m.mean, d, k.mean[sg] + o);
    hn::StoreU(m.var, d, k.var[sg] + o);
  }
  hn::StoreU(n_next, d, k.length + o);
  return needs_sanitize;
}

// A 3-plane input of the frame, or null when absent.
const ImageF* optional3(const Frame& f, Channel c) {
  return f.has(c) ? f.plane_set(c) : nullptr;
}

void check_shape(const ImageF& img, int planes, int w, int h, const char* name, int frame) {
  if (img.empty()) return;
  if (img.channels() != planes || img.width() != w || img.height() != h)
    throw InputError(fmt::format("svgf: frame {}: {} is {}x{}x{}, expected {}x{}x{}", frame, name,
                                 img.width(), img.height(), img.channels(), w, h, planes));
}

// True if any value is not finite (or, with `positive`, not > 0). The row's flags are or-ed
// as integers, which the compiler vectorises; a double sum of them (before) was a scalar
// chain, ~4% of the filter's CPU time at 1080p (perf).
bool any_bad(const ImageF& img, bool positive, const Exec& ex) {
  return parallel_sum_rows(ex, img.height(), [&](int y) {
           unsigned bad = 0;
           for (int c = 0; c < img.channels(); ++c) {
             const float* r = img.row(c, y);
             if (positive) {
               for (int x = 0; x < img.width(); ++x)
                 bad |= unsigned(!(std::abs(r[x]) <= FLT_MAX)) | unsigned(!(r[x] > 0.0f));
             } else {
               for (int x = 0; x < img.width(); ++x) bad |= unsigned(!(std::abs(r[x]) <= FLT_MAX));
             }
           }
           return double(bad);
         }) > 0;
}

}  // namespace

SvgfDenoiser::SvgfDenoiser(const SvgfSettings& settings, Exec exec, std::string label)
    : settings_(settings), exec_(exec), label_(std::move(label)) {
  settings_.validate();
}

ChannelSet SvgfDenoiser::required_channels() const {
  return {Channel::color, Channel::depth, Channel::normal, Channel::motion};
}

ChannelSet SvgfDenoiser::used_channels() const {
  return {Channel::color,   Channel::depth,    Channel::normal,  Channel::motion,
          Channel::albedo,  Channel::emission, Channel::diffuse, Channel::specular,
          Channel::direct,  Channel::indirect, Channel::id,      Channel::depth_gradient,
          Channel::gradient};
}

void SvgfDenoiser::reset() {
  valid_ = false;
  frames_ = 0;
  loaded_from_.clear();
}

Frame SvgfDenoiser::process(const Frame& f) {
  const auto t_start = std::chrono::steady_clock::now();
  const SvgfSettings& s = settings_;
  if (!f.has_color()) throw InputError(fmt::format("svgf: frame {}: no color channel", f.index));
  const int w = f.color.width(), h = f.color.height();
  for (Channel c : {Channel::depth, Channel::normal, Channel::motion})
    if (!f.has(c))
      throw InputError(fmt::format("svgf: frame {}: no {} channel", f.index, channel_info(c).name));
  check_shape(f.depth, 1, w, h, "depth", f.index);
  check_shape(f.normal, 3, w, h, "normal", f.index);
  check_shape(f.motion, 2, w, h, "motion", f.index);
  for (Channel c : {Channel::albedo, Channel::emission, Channel::diffuse, Channel::specular,
                    Channel::direct, Channel::indirect})
    if (f.has(c)) check_shape(*f.plane_set(c), 3, w, h, channel_info(c).name, f.index);
  if (f.has(Channel::depth_gradient))
    check_shape(f.depth_gradient, 2, w, h, "depth_gradient", f.index);
  if (f.has(Channel::gradient)) check_shape(f.gradient, 3, w, h, "gradient", f.index);
  if (f.has_id() && (f.id.width() != w || f.id.height() != h))
    throw InputError(fmt::format("svgf: frame {}: id is {}x{}, expected {}x{}", f.index,
                                 f.id.width(), f.id.height(), w, h));

  // Signals (settings.h Split).
  const bool have_di = f.has(Channel::direct) && f.has(Channel::indirect);
  const bool have_ds = f.has(Channel::diffuse) && f.has(Channel::specular) && f.has_albedo();
  if (s.split == Split::DirectIndirect && !have_di)
    throw InputError(fmt::format(
        "svgf: frame {}: split=direct_indirect needs the direct and indirect channels", f.index));
  if (s.split == Split::DiffuseSpecular && !have_ds)
    throw InputError(fmt::format(
        "svgf: frame {}: split=diffuse_specular needs the diffuse, specular and albedo channels",
        f.index));
  Split split = s.split;
  if (split == Split::Auto)
    split = have_di ? Split::DirectIndirect : (have_ds ? Split::DiffuseSpecular : Split::Combined);
  const int S = split == Split::Combined ? 1 : 2;

  if (!loaded_from_.empty() && valid_ && (w != width_ || h != height_ || split != split_))
    throw InputError(
        fmt::format("{}: state saved at {}x{} with split {}, the sequence is {}x{} "
                    "with split {}",
                    loaded_from_, width_, height_, to_string(split_), w, h, to_string(split)));
  loaded_from_.clear();
  if (w != width_ || h != height_ || split != split_ || history_.empty()) {
    width_ = w;
    height_ = h;
    signals_ = S;
    split_ = split;
    valid_ = false;
    history_ = ImageF(w, h, 3 * S);
    moments_ = ImageF(w, h, 2 * S);
    length_ = ImageF(w, h, 1);
    prev_depth_ = ImageF(w, h, 1, kBackgroundDepth);
    prev_normal_ = ImageF(w, h, 3);
    prev_id_ = ImageU32();
    fast_ = ImageF();
  }
  if (f.camera_cut) valid_ = false;
  // A fast history missing (first frame, or a state saved without the clamp) starts as the long
  // one.
  if (s.fast_history_clamp &&
      !(fast_.width() == w && fast_.height() == h && fast_.channels() == 3 * S))
    fast_ = history_;
  // Accumulation in seconds: this frame's alphas and cap from its time step (history_clamp.h).
  frame_settings_ = settings_at_time_step(
      s, frame_time_step(f.time, valid_ ? prev_time_ : std::numeric_limits<double>::quiet_NaN(),
                         s.fallback_fps));

  // 1. Sanitise. Color-like inputs: non-finite -> finite 3x3 mean, negative -> 0, and the
  // pixel's history is reset. Depth: non-finite or <= 0 -> background; normal and gradient:
  // non-finite -> 0 (DESIGN.md §3, as the loaders repair them). The tests ride on step 4's
  // reads: the frame first runs steps 2-4 on the raw planes with accumulate_block testing them,
  // and only if one fails runs them again on sanitised copies (the separate checks read ~20
  // planes, 4% of the filter's CPU time; d8ed95f). Either way nothing unsanitised is kept:
  // steps 2-4 write only scratch and the next frame's moments and length, all rewritten.
  const Exec& ex = exec_;
  const bool di = split == Split::DirectIndirect, ds = split == Split::DiffuseSpecular;
  const ImageF* in[5] = {&f.color, optional3(f, Channel::emission), optional3(f, Channel::albedo),
                         di ? &f.direct : (ds ? &f.diffuse : nullptr),
                         di ? &f.indirect : (ds ? &f.specular : nullptr)};
  const ImageF* use[5];
  const ImageF *depth = nullptr, *normal = nullptr, *gradient = nullptr;
  Guide guide;
  // A-SVGF: the reconstructed temporal gradient (gradient.h), when asked for and present.
  const bool use_lambda = s.temporal_gradient && f.has(Channel::gradient) && valid_;
  AccumulateContext k;
  const bool keep_id = f.has_id();
  auto t0 = std::chrono::steady_clock::now();
  for (const bool sanitise : {false, true}) {
    bool any_invalid = false;
    for (int i = 0; i < 5; ++i) use[i] = in[i];
    depth = &f.depth;
    normal = &f.normal;
    gradient = f.has(Channel::depth_gradient) ? &f.depth_gradient : &gradient_;
    if (sanitise) {
      for (int i = 0; i < 5; ++i) {
        if (in[i] && sanitize_color(*in[i], sanitized_[i], invalid_parts_[i], ex)) {
          use[i] = &sanitized_[i];
          if (!any_invalid) {
            invalid_ = invalid_parts_[i];
          } else {
            for (size_t j = 0; j < invalid_.data().size(); ++j)
              invalid_.data()[j] = std::max(invalid_.data()[j], invalid_parts_[i].data()[j]);
          }
          any_invalid = true;
        }
      }
      if (any_bad(f.depth, true, ex)) {
        depth_clean_ = f.depth;
        for (float& v : depth_clean_.data())
          if (!(std::isfinite(v) && v > 0.0f)) v = kBackgroundDepth;
        depth = &depth_clean_;
      }
      if (any_bad(f.normal, false, ex)) {
        normal_clean_ = f.normal;
        for (float& v : normal_clean_.data())
          if (!std::isfinite(v)) v = 0.0f;
        normal = &normal_clean_;
      }
      if (f.has(Channel::depth_gradient) && any_bad(f.depth_gradient, false, ex)) {
        gradient_ = f.depth_gradient;
        for (float& v : gradient_.data())
          if (!std::isfinite(v)) v = 0.0f;
        gradient = &gradient_;
      }
    }
    if (!f.has(Channel::depth_gradient)) depth_gradient(*depth, gradient_, ex);
    guide = Guide{depth, normal, gradient};
    if (use_lambda) {
      ensure_shape(luminance_, w, h, 1);
      parallel_rows(ex, h, [&](int y) {
        for (int x = 0; x < w; ++x)
          luminance_.at(x, y, 0) =
              luminance(Vec3f{use[0]->at(x, y, 0), use[0]->at(x, y, 1), use[0]->at(x, y, 2)});
      });
      reconstruct_gradient(f.gradient, guide, luminance_, s, gradient_strata_, lambda_,
                           s.gradient_relight ? &relight_ : nullptr, ex);
    }
    timings_.prepare_ms = ms_since(t_start);

    // 2-4. Demodulate, reproject, accumulate.
    t0 = std::chrono::steady_clock::now();
    ensure_shape(acc_, w, h, 3 * S);
    ensure_shape(next_moments_, w, h, 2 * S);
    ensure_shape(next_length_, w, h, 1);
    ensure_shape(next_prev_depth_, w, h, 1);
    ensure_shape(next_prev_normal_, w, h, 3);
    if (keep_id && !(next_prev_id_.width() == w && next_prev_id_.height() == h))
      next_prev_id_ = ImageU32(w, h, 1);
    k = AccumulateContext{};
    k.s = &frame_settings_;
    k.w = w;
    k.h = h;
    k.signals = S;
    k.subtract_emission = split == Split::Combined;
    k.demodulate = use[2] && split != Split::DiffuseSpecular;
    for (int ch = 0; ch < 3; ++ch) {
      if (split == Split::Combined) {
        k.signal[ch] = use[0]->plane(ch);
      } else {
        k.signal[ch] = use[3]->plane(ch);
        k.signal[3 + ch] = use[4]->plane(ch);
      }
      if (use[1]) k.emission[ch] = use[1]->plane(ch);
      if (use[2]) k.albedo[ch] = use[2]->plane(ch);
    }
    k.invalid = any_invalid ? invalid_.plane(0) : nullptr;
    k.depth = depth->plane(0);
    for (int ch = 0; ch < 3; ++ch) k.normal[ch] = normal->plane(ch);
    k.id = s.id_test && f.has_id() ? f.id.plane(0) : nullptr;
    k.motion[0] = f.motion.plane(0);
    k.motion[1] = f.motion.plane(1);
    k.gradient[0] = gradient->plane(0);
    k.gradient[1] = gradient->plane(1);
    k.lambda = use_lambda ? lambda_.plane(0) : nullptr;
    k.shorten_history = s.gradient_shorten_history;
    k.relight = use_lambda && s.gradient_relight ? relight_.plane(0) : nullptr;
    k.jitter_dx = float(f.jitter.x - prev_jitter_[0]);
    k.jitter_dy = float(f.jitter.y - prev_jitter_[1]);
    k.has_history = valid_;
    k.prev_depth = prev_depth_.plane(0);
    for (int ch = 0; ch < 3; ++ch) k.prev_normal[ch] = prev_normal_.plane(ch);
    k.prev_id = prev_id_.empty() ? nullptr : prev_id_.plane(0);
    k.prev_length = length_.plane(0);
    for (int sg = 0; sg < S; ++sg) {
      for (int ch = 0; ch < 3; ++ch) {
        k.prev_color[3 * sg + ch] = history_.plane(3 * sg + ch);
        k.acc[3 * sg + ch] = acc_.plane(3 * sg + ch);
      }
      k.prev_mean[sg] = moments_.plane(2 * sg);
      k.prev_var[sg] = moments_.plane(2 * sg + 1);
      k.mean[sg] = next_moments_.plane(2 * sg);
      k.var[sg] = next_moments_.plane(2 * sg + 1);
    }
    k.length = next_length_.plane(0);
    k.keep_depth = next_prev_depth_.plane(0);
    for (int ch = 0; ch < 3; ++ch) k.keep_normal[ch] = next_prev_normal_.plane(ch);
    if (keep_id) {
      k.keep_id_from = f.id.plane(0);
      k.keep_id = next_prev_id_.plane(0);
    }
    k.check = !sanitise;
    if (k.check) {
      for (int i = 0; i < 5; ++i)
        if (in[i])
          for (int ch = 0; ch < 3; ++ch) k.check_color[k.check_colors++] = in[i]->plane(ch);
      k.check_depth = f.depth.plane(0);
      for (int ch = 0; ch < 3; ++ch) k.check_finite[k.check_finites++] = f.normal.plane(ch);
      if (f.has(Channel::depth_gradient))
        for (int ch = 0; ch < 2; ++ch)
          k.check_finite[k.check_finites++] = f.depth_gradient.plane(ch);
    }
    if (s.firefly_rank > 0) {
      // Fireflies clamped in the demodulated signal (history_clamp.h), which then enters as is.
      SignalInputs fin;
      fin.w = w;
      fin.h = h;
      fin.signals = S;
      std::copy(std::begin(k.signal), std::end(k.signal), std::begin(fin.signal));
      fin.subtract_emission = k.subtract_emission;
      fin.demodulate = k.demodulate;
      std::copy(std::begin(k.emission), std::end(k.emission), std::begin(fin.emission));
      std::copy(std::begin(k.albedo), std::end(k.albedo), std::begin(fin.albedo));
      fin.albedo_epsilon = s.albedo_epsilon;
      demodulate_and_clamp_fireflies(fin, s.firefly_rank, firefly_, firefly_lum_, ex);
      for (int ch = 0; ch < 3 * S; ++ch) k.signal[ch] = firefly_.plane(ch);
      k.subtract_emission = false;
      k.demodulate = false;
    }
    if (s.fast_history_clamp) {
      ensure_shape(next_fast_, w, h, 3 * S);
      ensure_shape(long_prev_, w, h, 3 * S);
      ensure_shape(alpha_, w, h, 1);
      k.fast = true;
      k.fast_alpha_min = s.fast_alpha_min;
      for (int ch = 0; ch < 3 * S; ++ch) {
        k.prev_fast[ch] = fast_.plane(ch);
        k.fast_acc[ch] = next_fast_.plane(ch);
        k.long_prev[ch] = long_prev_.plane(ch);
      }
      k.alpha_out = alpha_.plane(0);
    }
    // --simd off runs the blocks' plain statement (reference.h), which has the same bits.
    bool bad = false;
    if (ex.simd) {
      bad = parallel_sum_rows(ex, h, [&](int y) {
              bool row_bad = false;
              for_each_lane_block(ex, w,
                                  [&](auto d, int x) { row_bad |= accumulate_block(d, k, x, y); });
              stream_fence();
              return row_bad ? 1.0 : 0.0;
            }) > 0;
    } else {
      bad = reference::reproject_and_accumulate(k, ex);
    }
    if (!bad) break;
  }
  const bool demodulate = use[2] && split != Split::DiffuseSpecular;
  if (k.fast)
    clamp_history_to_fast_box(next_fast_, long_prev_, alpha_, s.fast_clamp_sigma,
                              s.fast_clamp_radius, acc_, ex);
  timings_.accumulate_ms = ms_since(t0);

  // 5. Variance.
  t0 = std::chrono::steady_clock::now();
  estimate_variance(guide, next_moments_, next_length_, s, variance_, ex);
  timings_.variance_ms = ms_since(t0);

  // 6-7. À-trous; iteration 0 writes the next color history and the last one remodulates (adds
  // the emission) in its store, straight into the output (filter.h
  // atrous_iteration_remodulated: one full-image pass fewer, 4% of the filter's CPU time).
  t0 = std::chrono::steady_clock::now();
  Frame out = f.header_only();
  out.color = ImageF::uninitialized(w, h, 3);
  RemodulationInputs r;
  const Remodulation by = demodulate ? Remodulation::Demodulated : Remodulation::One;
  r.factor[0] = split == Split::DiffuseSpecular ? Remodulation::Albedo : by;
  r.factor[1] = split == Split::DiffuseSpecular ? Remodulation::One : by;
  r.albedo_epsilon = s.albedo_epsilon;
  r.emission = use[1];
  r.albedo = use[2];
  r.color = use[0];
  const ImageF* c_in = &acc_;
  const ImageF* v_in = &variance_;
  ImageF* c_pong[2] = {&tmp_, &acc_};
  ImageF* v_pong[2] = {&var_a_, &var_b_};
  for (int i = 0; i < s.iterations; ++i) {
    ImageF* c_out = i == 0 ? &next_history_ : c_pong[(i - 1) % 2];
    if (i + 1 == s.iterations) {
      atrous_iteration_remodulated(guide, *c_in, *v_in, 1 << i, s, r, out.color,
                                   i == 0 ? c_out : nullptr, ex);
      break;
    }
    ImageF* v_out = v_pong[i % 2];
    atrous_iteration(guide, *c_in, *v_in, 1 << i, s, *c_out, *v_out, ex);
    c_in = c_out;
    v_in = v_out;
  }
  timings_.atrous_ms = ms_since(t0);

  // This frame's G-buffer for the next one was written by accumulate_block.
  t0 = std::chrono::steady_clock::now();
  // The normalised temporal change travels with the output, so a TAA pass afterwards can
  // shorten its own history where the shading changed (taa/resolver.h step 7).
  if (use_lambda) out.temporal_change = lambda_;
  std::swap(history_, next_history_);
  std::swap(moments_, next_moments_);
  std::swap(length_, next_length_);
  if (k.fast) std::swap(fast_, next_fast_);
  std::swap(prev_depth_, next_prev_depth_);
  std::swap(prev_normal_, next_prev_normal_);
  if (keep_id) {
    std::swap(prev_id_, next_prev_id_);
  } else {
    prev_id_ = ImageU32();
  }
  prev_jitter_[0] = f.jitter.x;
  prev_jitter_[1] = f.jitter.y;
  prev_time_ = f.time;
  valid_ = true;
  ++frames_;
  timings_.remodulate_ms = ms_since(t0);
  timings_.total_ms = ms_since(t_start);
  return out;
}

// ------------------------------------------------------------------------------------------
// State file: core/state_file.h kind "svgf", version 1. Sections: i64 width, height, split
// (settings.h Split: 1 signal for combined, else 2), valid, frames; f64 prev_jitter (2); when width
// > 0: f32 history (3S planes), moments (2S), length (1), prev_depth (1), prev_normal (3) and u32
// prev_id (1) when the frame had ids; optional (history_clamp.h): f32 fast_history (3S) when the
// fast-history clamp ran, f64 prev_time (1) when the last frame had a finite time.
// ------------------------------------------------------------------------------------------

namespace {
constexpr const char* kStateKind = "svgf";
constexpr uint32_t kStateVersion = 1;
}  // namespace

void SvgfDenoiser::save_state(const std::string& path) const {
  const bool have = !history_.empty();
  StateWriter wr(kStateKind, kStateVersion);
  wr.put_i64("width", have ? width_ : 0);
  wr.put_i64("height", have ? height_ : 0);
  wr.put_i64("split", have ? int64_t(split_) : 0);
  wr.put_i64("valid", have && valid_ ? 1 : 0);
  wr.put_i64("frames", frames_);
  wr.put("prev_jitter", std::span<const double>(prev_jitter_, 2));
  if (have) {
    wr.put("history", history_);
    wr.put("moments", moments_);
    wr.put("length", length_);
    wr.put("prev_depth", prev_depth_);
    wr.put("prev_normal", prev_normal_);
    if (!prev_id_.empty()) wr.put("prev_id", prev_id_);
    if (fast_.width() == width_ && fast_.height() == height_ && fast_.channels() == 3 * signals_)
      wr.put("fast_history", fast_);
  }
  if (std::isfinite(prev_time_)) wr.put_f64("prev_time", prev_time_);
  wr.save(path);
}

void SvgfDenoiser::load_state(const std::string& path) {
  const StateReader rd(path, kStateKind, kStateVersion);
  const auto [w, h] = rd.get_size("width", "height");
  const int64_t split = rd.get_count("split");
  const bool valid = rd.get_flag("valid");
  const int64_t frames = rd.get_count("frames");
  const std::vector<double> jitter = rd.get<double>("prev_jitter");
  if (jitter.size() != 2 || !std::isfinite(jitter[0]) || !std::isfinite(jitter[1]))
    throw InputError(fmt::format("{}: not a valid svgf state file (prev_jitter)", path));
  if (w > 0 && !(split >= int64_t(Split::Combined) && split <= int64_t(Split::DirectIndirect)))
    throw InputError(fmt::format("{}: not a valid svgf state file (split {})", path, split));
  const int S = split == int64_t(Split::Combined) ? 1 : 2;
  // Parse into temporaries; the denoiser changes only if everything is valid.
  ImageF hist, mom, len, pdepth, pnormal, fast;
  ImageU32 pid;
  double prev_time = std::numeric_limits<double>::quiet_NaN();
  if (rd.has("prev_time")) {
    const std::vector<double> t = rd.get<double>("prev_time");
    if (t.size() != 1 || !std::isfinite(t[0]))
      throw InputError(fmt::format("{}: not a valid svgf state file (prev_time)", path));
    prev_time = t[0];
  }
  if (w > 0) {
    hist = rd.get_image<float>("history", w, h, 3 * S);
    mom = rd.get_image<float>("moments", w, h, 2 * S);
    len = rd.get_image<float>("length", w, h, 1);
    pdepth = rd.get_image<float>("prev_depth", w, h, 1);
    pnormal = rd.get_image<float>("prev_normal", w, h, 3);
    if (rd.has("prev_id")) pid = rd.get_image<uint32_t>("prev_id", w, h, 1);
    if (rd.has("fast_history")) fast = rd.get_image<float>("fast_history", w, h, 3 * S);
  }
  width_ = int(w);
  height_ = int(h);
  signals_ = w > 0 ? S : 0;
  split_ = w > 0 ? Split(split) : Split::Auto;
  valid_ = valid && w > 0;
  frames_ = frames;
  prev_jitter_[0] = jitter[0];
  prev_jitter_[1] = jitter[1];
  history_ = std::move(hist);
  moments_ = std::move(mom);
  length_ = std::move(len);
  prev_depth_ = std::move(pdepth);
  prev_normal_ = std::move(pnormal);
  prev_id_ = std::move(pid);
  fast_ = std::move(fast);
  prev_time_ = prev_time;
  loaded_from_ = path;
}

}  // namespace afterimage::svgf
