#include "taau/upscaler.h"

#include <fmt/format.h>

#include <algorithm>
#include <limits>
#include <string_view>
#include <utility>

#include "core/error.h"
#include "core/lanes.h"
#include "core/prefetch.h"
#include "core/sanitize.h"
#include "core/state_file.h"
#include "reproject/gather.h"
#include "reproject/history.h"
#include "taa/taa_kernels.h"
#include "taau/upscale_kernels.h"

namespace afterimage::taau {

namespace {

// Planes of the per-input-pixel pre-pass, read at the nearest sample: neighbour 0.
enum PrePlane { kPreMx, kPreMy, kPreBox, kPreConf = kPreBox + 6, kPreRelax, kPrePlanes };
static_assert(kNeighborDx[0] == 0 && kNeighborDy[0] == 0, "neighbour 0 is the center");

// Everything one frame's kernel reads and writes. Plain pointers: rows are independent.
struct UpscaleContext {
  const TaauSettings* s = nullptr;
  const taa::TaaSettings* rect = nullptr;
  int w = 0, h = 0;  // input size
  int W = 0, H = 0;  // output size
  float sx = 1, sy = 1, isx = 1, isy = 1;
  float jx = 0, jy = 0;
  float weight_param = 1;
  const float* cur[3] = {};  // sanitized current color (input size)
  const float* depth = nullptr;
  const float* motion[2] = {};
  bool has_history = false;
  reproject::Planes<3> history;  // output size
  const float* weight = nullptr;
  // Per input pixel (input size, prepass_block): the dilated motion (2 planes), when
  // `box_planes` the neighbourhood box (6 planes: lo, hi in the rectification's color space),
  // and with history confidence its confidence and box relaxation (2 planes).
  float* pre[kPrePlanes] = {};
  bool box_planes = false;
  float* out[3] = {};
  float* out_weight = nullptr;
  // History confidence, per input pixel (input size): the luma moments of the raw samples and
  // their derived spreads (taa/taa_kernels.h), last frame's and this frame's; the weight of
  // this frame's sample in them while the history is young.
  reproject::Planes<taa::kLumaMomentPlanes> moments;
  const float* spreads[taa::kSpreadPlanes] = {};
  float* out_moments[taa::kLumaMomentPlanes] = {};
  float* out_spreads[taa::kSpreadPlanes] = {};
  float young_alpha = 1;
  float* result[3] = {};  // the returned image: the history's values, stored from registers
};

// History confidence of input pixel (x, y), as TAA computes it for its own pixels
// (taa/taa_kernels.h history_confidence, the confidence_* settings at TAA's defaults) on the
// low-resolution stream: the raw sample against the pixel's luma moments, read at its history
// position in input pixels, the neighbours' change and drift, motion in input pixels. Stores
// the confidence and the box relaxation for the output pixels whose nearest sample this is,
// and the updated moments. TAAU has no depth / id tests, so no geometry rule.
template <class D, class Load>
HWY_INLINE void prepass_confidence(D d, const UpscaleContext& k, int x, int y,
                                   const Color3<D> (&nb)[9], const taa::DilatedMotion<D>& dm,
                                   V<D> speed_nb, Load&& load) {
  const taa::TaaSettings& r = *k.rect;
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  V<D> lumas[9];
  for (int i = 0; i < 9; ++i) lumas[i] = luminance(d, nb[i]);
  const auto luma_x = lumas[0];
  const auto sigma_spatial = hn::Sqrt(taa::neighborhood_luma_variance(d, lumas, 9));
  taa::LumaMoments<D> moments{luma_x, zero, luma_x, zero, zero, speed_nb, zero};
  auto conf = zero, keep = zero;
  auto sigma_alias = zero;  // aliasing_sigma of the moments: 0 where they restart
  if (k.has_history) {
    const reproject::HistoryPosition<D> hp =
        reproject::history_position(d, x, y, dm.mx, dm.my, k.w, k.h);
    hn::Mask<D> m_ok;
    moments = taa::fetch_luma_moments(d, k.moments, hp.x, hp.y, luma_x, hp.onscreen, m_ok);
    keep = hn::IfThenElseZero(m_ok, one);
    const taa::NeighborEvidence<D> nbe = taa::neighbor_evidence(
        d, lumas, load, k.moments.p[0], k.moments.p[6], k.spreads[0], k.spreads[1]);
    conf = taa::history_confidence(d, luma_x, moments, m_ok, sigma_spatial, nbe, speed_nb, r);
    // The z score's (CSE'd); unneeded where every lane's confidence is +0 (resolver.cpp).
    if (!hn::AllTrue(d, hn::Eq(conf, zero))) sigma_alias = taa::aliasing_sigma(d, moments);
  }
  const size_t o = size_t(y) * size_t(k.w) + size_t(x);
  hn::StoreU(conf, d, k.pre[kPreConf] + o);
  hn::StoreU(taa::box_relaxation(d, sigma_alias, conf, r.confidence_box_sigma), d,
             k.pre[kPreRelax] + o);
  // The moments' weight: a plain mean while the history is young, then moments_alpha_min;
  // they restart where no history was found.
  const auto a_m = hn::IfThenElse(hn::Gt(keep, zero),
                                  hn::Set(d, std::max(r.moments_alpha_min, k.young_alpha)), one);
  const taa::LumaMoments<D> m = taa::update_luma_moments(
      d, moments, luma_x, hn::Mul(sigma_spatial, sigma_spatial), a_m, r.confidence_drift_alpha);
  taa::store_luma_moments(d, m, moments.recent_motion, k.out_moments, k.out_spreads, o, r);
}

// What every output pixel whose nearest sample is input pixel (x, y) shares, computed once per
// input pixel instead of once per output pixel (4 times at 2x): the velocity dilation over the
// input 3x3 and the rectification box of the 3x3 samples (taa::neighborhood_box). The same
// operations on the same samples in the same order (clamped at the borders like the output
// pass's), so the output is bit-identical to computing them per output pixel.
template <class D>
HWY_INLINE void prepass_block(D d, const UpscaleContext& k, int x, int y) {
  const std::array<size_t, 3> rows = neighborhood_rows(y, k.w, k.h);
  auto load = [&](const float* plane, int i) {
    return load_neighbor(d, plane, rows, x, i, 1, k.w);
  };
  const bool confidence = k.s->confidence;
  auto max_speed2 = hn::Zero(d);  // largest squared speed of the 3x3 (confidence)
  const taa::DilatedMotion<D> dm = taa::dilate_velocity_streamed(
      d, k.s->dilation,
      [&](int i, V<D>& de, V<D>& mx, V<D>& my) {
        de = sanitize_depth(d, load(k.depth, i), kBackgroundDepth);
        mx = load(k.motion[0], i);
        my = load(k.motion[1], i);
        if (confidence) {
          const auto l2 = hn::MulAdd(mx, mx, hn::Mul(my, my));
          max_speed2 = hn::Max(max_speed2, hn::IfThenElseZero(hn::IsFinite(l2), l2));
        }
      },
      [](int, hn::Mask<D>) {});
  const size_t o = size_t(y) * size_t(k.w) + size_t(x);
  hn::StoreU(dm.mx, d, k.pre[kPreMx] + o);
  hn::StoreU(dm.my, d, k.pre[kPreMy] + o);
  if (!k.box_planes && !confidence) return;
  Color3<D> nb[9];
  for (int i = 0; i < 9; ++i) nb[i] = {load(k.cur[0], i), load(k.cur[1], i), load(k.cur[2], i)};
  if (k.box_planes) {
    const Aabb<D> box = taa::neighborhood_box(d, *k.rect, nb);
    const V<D> planes[6] = {box.lo.c0, box.lo.c1, box.lo.c2, box.hi.c0, box.hi.c1, box.hi.c2};
    for (int c = 0; c < 6; ++c) hn::StoreU(planes[c], d, k.pre[kPreBox + c] + o);
  }
  if (confidence) prepass_confidence(d, k, x, y, nb, dm, hn::Sqrt(max_speed2), load);
}

// The input columns an output block samples, as one vector-wide window of its row: at TAAU
// scales (>= 1) the 3 columns around the lanes' output centers span about Lanes / scale + 2
// input pixels, so for 16 lanes at 2x (or 8 at 1.5x) one load of the row holds every sample
// and a lane permute picks them, instead of a gather per sample and plane (the gathers were
// the hottest instructions of the upscale).
template <class D>
struct SampleWindow {
  bool in_register = false;
  size_t base = 0;  // first column of the window
  decltype(hn::IndicesFromVec(D(), hn::Zero(hn::RebindToSigned<D>()))) lane[3]{};
};
template <class D>
HWY_INLINE SampleWindow<D> sample_window(D d, const V<D> (&colc)[3], int w) {
  SampleWindow<D> r;
  const int n = int(hn::Lanes(d));
  if (n < 4 || w < n) return r;  // narrow lanes or a narrow image: gathers
  const hn::RebindToSigned<D> di;
  const int lo = int(hn::GetLane(hn::MinOfLanes(d, colc[0]))),
            hi = int(hn::GetLane(hn::MaxOfLanes(d, colc[2])));
  const int base = std::min(lo, w - n);  // the window stays inside the row
  if (hi - base >= n) return r;
  r.in_register = true;
  r.base = size_t(base);
  for (int c = 0; c < 3; ++c)
    r.lane[c] = hn::IndicesFromVec(d, hn::Sub(hn::ConvertTo(di, colc[c]), hn::Set(di, base)));
  return r;
}

// One lane block of output row Y (see the steps in upscaler.h).
template <class D>
HWY_INLINE void upscale_block(D d, const UpscaleContext& k, int X, int Y) {
  const TaauSettings& s = *k.s;
  const hn::RebindToSigned<D> di;
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f), half = hn::Set(d, 0.5f);

  // Output centers in input pixels and the input pixel of the nearest sample: per lane along
  // x, one for the row along y (upscale_kernels.h nearest_sample_index).
  const auto cx = pixel_center_x(d, X);
  const auto qx = hn::Mul(cx, hn::Set(d, k.isx));
  const float cy = float(Y) + 0.5f;
  const int cj = nearest_sample_index(cy * k.isy, k.jy, k.h);
  const auto last_col = hn::Set(d, float(k.w - 1));
  const auto ci = hn::Min(hn::Max(hn::Floor(hn::Sub(qx, hn::Set(d, k.jx))), zero), last_col);

  // 1. The 3x3 samples (kNeighborDx/Dy order: the nearest first), splatted with weights of
  // their true distance; neighbours beyond the border (clamped duplicates) weigh 0. The
  // Gaussian is separable, exp(-(x^2 + y^2) / 2s^2) = exp(-x^2 / 2s^2) exp(-y^2 / 2s^2): 3
  // column weights per lane and 3 row weights per row instead of 9 exponentials per pixel.
  const bool separable = s.kernel == SplatKernel::Gaussian;
  V<D> wcol[3];
  float wrow[3] = {};
  if (separable)
    for (int c = 0; c < 3; ++c) {
      const auto col = hn::Min(hn::Max(hn::Add(ci, hn::Set(d, float(c - 1))), zero), last_col);
      const auto ox =
          hn::Sub(hn::Mul(hn::Add(hn::Add(col, half), hn::Set(d, k.jx)), hn::Set(d, k.sx)), cx);
      wcol[c] = gaussian_weight(d, hn::Mul(ox, ox), k.weight_param);
      const int rowc = std::clamp(cj + c - 1, 0, k.h - 1);
      const float oy = (float(rowc) + 0.5f + k.jy) * k.sy - cy;
      wrow[c] = std::exp(-oy * oy * k.weight_param);
    }
  // The samples' clamped columns (dx = -1, 0, 1) and rows (dy = -1, 0, 1).
  V<D> colc[3];
  for (int c = 0; c < 3; ++c)
    colc[c] = hn::Min(hn::Max(hn::Add(ci, hn::Set(d, float(c - 1))), zero), last_col);
  size_t row_offset[3];
  for (int r = 0; r < 3; ++r) row_offset[r] = size_t(std::clamp(cj + r - 1, 0, k.h - 1)) * k.w;
  const SampleWindow<D> window = sample_window(d, colc, k.w);
  // Lanes of `plane` at sample i (kNeighborDx/Dy order): an in-register permute of one load
  // of its row when the window holds the block's columns, else a gather; the same values.
  auto fetch = [&](const float* plane, int i) {
    const size_t row = row_offset[kNeighborDy[i] + 1];
    const int c = kNeighborDx[i] + 1;
    if (window.in_register)
      return hn::TableLookupLanes(hn::LoadU(d, plane + row + window.base), window.lane[c]);
    return hn::GatherIndex(d, plane, hn::Add(hn::ConvertTo(di, colc[c]), hn::Set(di, int(row))));
  };
  Color3<D> nb[9];
  Splat<D> acc = splat_empty(d);
  for (int i = 0; i < 9; ++i) {
    const auto col = hn::Add(ci, hn::Set(d, float(kNeighborDx[i])));
    const auto inside_x = hn::And(hn::Ge(col, zero), hn::Le(col, last_col));
    const auto colc_i = colc[kNeighborDx[i] + 1];
    const int row = cj + kNeighborDy[i];
    const bool inside_y = row >= 0 && row < k.h;
    const int rowc = std::clamp(row, 0, k.h - 1);
    nb[i] = {fetch(k.cur[0], i), fetch(k.cur[1], i), fetch(k.cur[2], i)};
    V<D> wi;
    if (separable) {
      wi = hn::Mul(wcol[kNeighborDx[i] + 1], hn::Set(d, wrow[kNeighborDy[i] + 1]));
    } else {
      // Offset of the sample from the output center, in output pixels.
      const auto ox =
          hn::Sub(hn::Mul(hn::Add(hn::Add(colc_i, half), hn::Set(d, k.jx)), hn::Set(d, k.sx)), cx);
      const float oy = (float(rowc) + 0.5f + k.jy) * k.sy - cy;
      wi = sample_weight(d, s.kernel, hn::MulAdd(ox, ox, hn::Set(d, oy * oy)), k.weight_param);
    }
    wi = inside_y ? hn::IfThenElseZero(inside_x, wi) : zero;
    acc = splat_add(acc, nb[i], wi);
  }
  // 2. This frame's color, clamped to the samples' min/max (deringing), and its weight.
  Color3<D> current = splat_color(d, acc, nb[0]);
  if (s.deringing) current = taa::clamp_to_aabb(minmax_box(nb, 9), current);
  const auto w_cur = hn::Max(acc.weight, zero);

  // 3. Velocity dilation over the input 3x3 (the nearest sample's, from the pre-pass), motion
  // in output pixels, history position.
  const auto mx = hn::Mul(fetch(k.pre[kPreMx], 0), hn::Set(d, k.sx)),
             my = hn::Mul(fetch(k.pre[kPreMy], 0), hn::Set(d, k.sy));
  const reproject::HistoryPosition<D> hp = reproject::history_position(d, X, Y, mx, my, k.W, k.H);

  auto keep = k.has_history ? hn::IfThenElse(hp.onscreen, one, zero) : zero;
  Color3<D> hist = current;
  auto n_hist = zero;
  if (k.has_history) {
    reproject::PixelBox<D, 3> ring;
    const bool bicubic = s.history != taa::HistorySampler::Bilinear;
    reproject::PixelBox<D, 3>* ring_out = s.anti_ringing && bicubic ? &ring : nullptr;
    hist = reproject::as_color3(reproject::sample_history(d, taa::history_filter(s.history, false),
                                                          k.history, hp.x, hp.y, ring_out));
    if (ring_out) hist = taa::clamp_to_aabb(reproject::as_aabb(ring), hist);
    const auto fin = all_finite(d, hist);
    keep = hn::IfThenElse(fin, keep, zero);
    hist = select<D>(fin, hist, current);
    n_hist = hn::Mul(reproject::gather_plane(
                         d, k.weight, reproject::nearest_pixel_index(d, k.W, k.H, hp.x, hp.y)),
                     keep);
  }

  // History confidence: the nearest sample's (prepass_confidence).
  const auto conf = s.confidence ? fetch(k.pre[kPreConf], 0) : zero;
  const auto relax = s.confidence ? fetch(k.pre[kPreRelax], 0) : zero;

  // 4. Rectification against the input neighbourhood, toward this frame's color.
  if (k.has_history && s.rectify != taa::Rectify::None) {
    if (k.box_planes) {
      const Aabb<D> box{
          {fetch(k.pre[kPreBox], 0), fetch(k.pre[kPreBox + 1], 0), fetch(k.pre[kPreBox + 2], 0)},
          {fetch(k.pre[kPreBox + 3], 0), fetch(k.pre[kPreBox + 4], 0),
           fetch(k.pre[kPreBox + 5], 0)}};
      hist = taa::rectify_with_box(d, *k.rect, box, current, hist, relax).history;
    } else {
      hist = taa::rectify_history(d, *k.rect, nb, current, hist, relax).history;
    }
  }

  // 5. Weighted running mean.
  const auto alpha = alpha_from_weights(d, n_hist, w_cur);
  hist = select<D>(hn::Gt(keep, zero), hist, current);
  Color3<D> out = taa::blend_exponential(d, current, hist, alpha);
  auto n_out =
      s.confidence
          ? hn::Min(hn::Add(n_hist, w_cur),
                    lerp<D>(hn::Set(d, s.max_weight),
                            hn::Set(d, std::max(s.max_weight, s.confident_max_weight)), conf))
          : accumulated_weight(d, n_hist, w_cur, s.max_weight);
  const auto fin = all_finite(d, out);  // e.g. overflow of huge HDR values
  out = select<D>(fin, out, current);
  n_out = hn::IfThenElse(fin, n_out, w_cur);
  const size_t o = size_t(Y) * size_t(k.W) + size_t(X);

  hn::StoreU(out.c0, d, k.out[0] + o);
  hn::StoreU(out.c1, d, k.out[1] + o);
  hn::StoreU(out.c2, d, k.out[2] + o);
  hn::StoreU(out.c0, d, k.result[0] + o);
  hn::StoreU(out.c1, d, k.result[1] + o);
  hn::StoreU(out.c2, d, k.result[2] + o);
  hn::StoreU(n_out, d, k.out_weight + o);
}

// One output row, each full-width block first prefetching the lines the block 128 pixels on
// reads and writes (core/prefetch.h, as TAA's since 0aefc8c; 18ba3c9 here): the input
// row below the nearest sample's (colour and the pre-pass planes), the outputs for writing,
// and the history and weight at row Y + 2 (Catmull-Rom 5's lowest row at rest). No effect on
// any value.
void upscale_row(const Exec& ex, const UpscaleContext& k, int Y) {
  constexpr int kAhead = 128;
  using P = PlanePrefetch;
  PlanePrefetch p;
  for (int c = 0; c < 3; ++c) p.add(P::kRead, k.cur[c]);
  for (int c = 0; c < kPrePlanes; ++c)
    if (k.pre[c]) p.add(P::kRead, k.pre[c]);
  for (int c = 0; c < 3; ++c) p.add(P::kWrite, k.out[c]);
  for (int c = 0; c < 3; ++c) p.add(P::kWrite, k.result[c]);
  p.add(P::kWrite, k.out_weight);
  if (k.has_history) {
    for (int c = 0; c < 3; ++c) p.add(P::kPrevious, k.history.p[c]);
    p.add(P::kPrevious, k.weight);
  }
  const int cj = nearest_sample_index((float(Y) + 0.5f) * k.isy, k.jy, k.h);
  p.set_row(P::kRead, size_t(std::clamp(cj + 1, 0, k.h - 1)) * size_t(k.w));
  p.set_row(P::kWrite, size_t(Y) * size_t(k.W));
  p.set_row(P::kPrevious, size_t(std::min(Y + 2, k.H - 1)) * size_t(k.W));
  int X = 0;
  if (ex.simd) {
    const FullTag d;
    const int n = int(hn::Lanes(d));
    for (; X + n <= k.W; X += n) {
      const int xa = std::min(X + kAhead, k.W - 1);
      p.lines(size_t(std::min(int(float(xa) * k.isx), k.w - 1)), size_t(xa), size_t(xa));
      upscale_block(d, k, X, Y);
    }
  }
  const OneTag d1;
  for (; X < k.W; ++X) upscale_block(d1, k, X, Y);
}

void check_channel(const ImageF& img, int channels, int w, int h, const char* name) {
  if (img.empty()) return;
  if (img.channels() != channels || img.width() != w || img.height() != h)
    throw InputError(fmt::format("taau input frame: {} is {}x{}x{}, expected {}x{}x{}", name,
                                 img.width(), img.height(), img.channels(), w, h, channels));
}

}  // namespace

Upscaler::Upscaler(const TaauSettings& settings, Exec exec)
    : settings_(settings), rect_(settings.rectification()), exec_(exec) {
  settings_.validate();
}

void Upscaler::reset() {
  valid_ = false;
  frames_ = 0;
  loaded_from_.clear();
}

ImageF Upscaler::process(const Frame& f) {
  if (f.color.channels() != 3 || f.color.empty())
    throw InputError("taau input frame: missing color channels R G B");
  const int w = f.color.width(), h = f.color.height();
  check_channel(f.depth, 1, w, h, "depth");
  check_channel(f.motion, 2, w, h, "motion");
  // Plain ints, not a structured binding: clang 14 (fuzz and sanitizer builds) cannot capture
  // a binding in the row lambda below.
  const std::pair<int, int> out_size = settings_.output_size(w, h);
  const int W = out_size.first, H = out_size.second;

  if (!loaded_from_.empty() && valid_ && (w != in_w_ || h != in_h_ || W != out_w_ || H != out_h_))
    throw InputError(
        fmt::format("{}: state saved for {}x{} -> {}x{}, the sequence is {}x{} -> {}x{}",
                    loaded_from_, in_w_, in_h_, out_w_, out_h_, w, h, W, H));
  loaded_from_.clear();
  if (w != in_w_ || h != in_h_ || W != out_w_ || H != out_h_ || history_.empty()) {
    in_w_ = w;
    in_h_ = h;
    out_w_ = W;
    out_h_ = H;
    valid_ = false;
    history_ = ImageF(W, H, 3);
    weight_ = ImageF(W, H, 1);
  }
  if (f.camera_cut) valid_ = false;
  if (!next_history_.same_shape(history_)) {
    next_history_ = ImageF(W, H, 3);
    next_weight_ = ImageF(W, H, 1);
  }
  if (settings_.confidence) {
    // Per input pixel. Unknown moments and spreads (NaN) restart at the first sample (a state
    // saved without them, a size change).
    if (moments_.width() != w || moments_.height() != h ||
        moments_.channels() != taa::kLumaMomentPlanes)
      moments_ = ImageF(w, h, taa::kLumaMomentPlanes, std::numeric_limits<float>::quiet_NaN());
    if (spreads_.width() != w || spreads_.height() != h ||
        spreads_.channels() != taa::kSpreadPlanes)
      spreads_ = ImageF(w, h, taa::kSpreadPlanes, std::numeric_limits<float>::quiet_NaN());
    if (!next_moments_.same_shape(moments_)) next_moments_ = ImageF(w, h, taa::kLumaMomentPlanes);
    if (!next_spreads_.same_shape(spreads_)) next_spreads_ = ImageF(w, h, taa::kSpreadPlanes);
  }

  // NaN / Inf / negative inputs never enter history (core/sanitize.h).
  const ImageF* cur = sanitize_color(f.color, sanitized_, invalid_, exec_) ? &sanitized_ : &f.color;

  UpscaleContext k;
  k.s = &settings_;
  // The confidence rules run on the input stream (prepass_confidence), so their motion limit is
  // in input pixels.
  rect_.confidence_motion_px = settings_.confidence_motion_px * float(w) / float(W);
  k.rect = &rect_;
  k.w = w;
  k.h = h;
  k.W = W;
  k.H = H;
  // The exact ratio of the grids (not the nominal scale): output [0, W] covers input [0, w].
  k.sx = float(W) / float(w);
  k.sy = float(H) / float(h);
  k.isx = float(w) / float(W);
  k.isy = float(h) / float(H);
  k.jx = float(f.jitter.x);
  k.jy = float(f.jitter.y);
  k.weight_param = sample_weight_param(settings_);
  for (int c = 0; c < 3; ++c) k.cur[c] = cur->plane(c);
  if (!f.has_depth() && background_depth_.width() != w * h)
    background_depth_ = ImageF(w * h, 1, 1, kBackgroundDepth);  // one flat plane
  k.depth = f.has_depth() ? f.depth.plane(0) : background_depth_.plane(0);
  if (f.has_motion()) {
    k.motion[0] = f.motion.plane(0);
    k.motion[1] = f.motion.plane(1);
  } else {
    if (zero_motion_.width() != w * h) zero_motion_ = ImageF(w * h, 1, 1, 0.0f);
    k.motion[0] = k.motion[1] = zero_motion_.plane(0);
  }
  k.has_history = valid_;
  k.history = reproject::planes_of<3>(history_);
  k.weight = weight_.plane(0);
  for (int c = 0; c < 3; ++c) k.out[c] = next_history_.plane(c);
  k.out_weight = next_weight_.plane(0);
  if (settings_.confidence) {
    k.moments = reproject::planes_of<taa::kLumaMomentPlanes>(moments_);
    for (int c = 0; c < taa::kLumaMomentPlanes; ++c) k.out_moments[c] = next_moments_.plane(c);
    for (int c = 0; c < taa::kSpreadPlanes; ++c) {
      k.spreads[c] = spreads_.plane(c);
      k.out_spreads[c] = next_spreads_.plane(c);
    }
    // 1 / (frames of history + 1): TAA counts per pixel (its sample count); TAAU's history
    // runs since the last reset.
    k.young_alpha = valid_ ? 1.0f / float(std::min<long>(frames_since_reset_, 1 << 20) + 1) : 1.0f;
  }

  k.box_planes =
      settings_.rectify != taa::Rectify::None && settings_.rectify != taa::Rectify::ConvexHull;
  ensure_shape(pre_, w, h, kPrePlanes);
  for (int c = 0; c < kPrePlanes; ++c) k.pre[c] = pre_.plane(c);
  ImageF result = ImageF::uninitialized(W, H, 3);  // every pixel is stored by the kernel
  for (int c = 0; c < 3; ++c) k.result[c] = result.plane(c);

  parallel_rows(exec_, h, [&](int y) {
    for_each_lane_block(exec_, w, [&](auto d, int x) { prepass_block(d, k, x, y); });
  });
  parallel_rows(exec_, H, [&](int y) { upscale_row(exec_, k, y); });

  std::swap(history_, next_history_);
  std::swap(weight_, next_weight_);
  if (settings_.confidence) {
    std::swap(moments_, next_moments_);
    std::swap(spreads_, next_spreads_);
  }
  frames_since_reset_ = valid_ ? frames_since_reset_ + 1 : 1;
  valid_ = true;
  ++frames_;
  return result;
}

// ------------------------------------------------------------------------------------------
// State file: kind "taau", version 1. Sections: i64 in_width, in_height, width, height,
// valid, frames; when width > 0: f32 history (3 planes), weight (1 plane) and, with history
// confidence, the input-size moments (taa::kLumaMomentPlanes planes) and moment_spreads
// (taa::kSpreadPlanes), and the frames since the last reset (the moments' young weight).
// ------------------------------------------------------------------------------------------

namespace {
constexpr const char* kStateKind = "taau";
constexpr uint32_t kStateVersion = 1;
}  // namespace

void Upscaler::save_state(const std::string& path) const {
  const bool have = !history_.empty();
  StateWriter wr(kStateKind, kStateVersion);
  wr.put_i64("in_width", have ? in_w_ : 0);
  wr.put_i64("in_height", have ? in_h_ : 0);
  wr.put_i64("width", have ? out_w_ : 0);
  wr.put_i64("height", have ? out_h_ : 0);
  wr.put_i64("valid", have && valid_ ? 1 : 0);
  wr.put_i64("frames", frames_);
  if (have) {
    wr.put("history", history_);
    wr.put("weight", weight_);
    if (!moments_.empty()) wr.put("moments", moments_);
    if (!spreads_.empty()) wr.put("moment_spreads", spreads_);
    wr.put_i64("frames_since_reset", frames_since_reset_);
  }
  wr.save(path);
}

void Upscaler::load_state(const std::string& path) {
  const StateReader r(path, kStateKind, kStateVersion);
  const auto [iw, ih] = r.get_size("in_width", "in_height");
  const auto [w, h] = r.get_size("width", "height");
  if ((w == 0) != (iw == 0)) r.fail(fmt::format("impossible size {}x{} -> {}x{}", iw, ih, w, h));
  const bool valid = r.get_flag("valid");
  const int64_t frames = r.get_count("frames");
  ImageF hist, weight, moments, spreads;
  if (w > 0) {
    hist = r.get_image<float>("history", w, h, 3);
    weight = r.get_image<float>("weight", w, h, 1);
    if (r.has("moments")) moments = r.get_image<float>("moments", iw, ih, taa::kLumaMomentPlanes);
    if (r.has("moment_spreads"))
      spreads = r.get_image<float>("moment_spreads", iw, ih, taa::kSpreadPlanes);
  }
  const int64_t since_reset = r.has("frames_since_reset") ? r.get_count("frames_since_reset") : 0;
  in_w_ = int(iw);
  in_h_ = int(ih);
  out_w_ = int(w);
  out_h_ = int(h);
  valid_ = valid && w > 0;
  frames_ = long(frames);
  history_ = std::move(hist);
  weight_ = std::move(weight);
  moments_ = std::move(moments);
  spreads_ = std::move(spreads);
  frames_since_reset_ = long(since_reset);
  loaded_from_ = path;
}

}  // namespace afterimage::taau
