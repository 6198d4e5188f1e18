#include "svgf/reference.h"

#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/neighborhood.h"
#include "core/simd.h"

namespace afterimage::svgf::reference {

float exp_neg(float e) {
  const float magic = 12582912.0f;  // 1.5 * 2^23
  const float t = e * -1.44269504088896341f;
  const float r = t + magic;
  const float f = t - (r - magic);
  float p = 0.0550066829f;
  p = std::fma(p, f, 0.242206424f);
  p = std::fma(p, f, 0.693282664f);
  p = std::fma(p, f, 1.0f);
  const int32_t n = std::bit_cast<int32_t>(r) - 0x4B400000;
  return p * std::bit_cast<float>(uint32_t(n + 127) << 23);
}

GeometryTerms geometry_terms(const Guide& g, const SvgfSettings& s, int x, int y, int ox, int oy,
                             float exp_offset) {
  const int qx = x + ox, qy = y + oy;
  const float zp = g.depth->at(x, y, 0);
  const float ez =
      depth_exponent(zp, g.depth->at(qx, qy, 0), g.gradient->at(x, y, 0), g.gradient->at(x, y, 1),
                     ox, oy, s.sigma_z, depth_eps(zp, s.depth_epsilon));
  const float np[3] = {g.normal->at(x, y, 0), g.normal->at(x, y, 1), g.normal->at(x, y, 2)};
  const float nq[3] = {g.normal->at(qx, qy, 0), g.normal->at(qx, qy, 1), g.normal->at(qx, qy, 2)};
  const float dot = normal_dot(np, nq);
  if (s.normal_exp) return {ez + normal_exponent(dot, float(s.sigma_n), exp_offset), 1.0f};
  return {ez, normal_weight(dot, s.sigma_n)};
}

float variance_at(const Guide& g, const ImageF& moments, const ImageF& length,
                  const SvgfSettings& s, int x, int y, int sg) {
  const int w = moments.width(), h = moments.height();
  const float vp = moments.at(x, y, 2 * sg + 1);
  if (!(length.at(x, y, 0) < float(s.temporal_variance_frames))) return vp;  // temporal
  const float mp = moments.at(x, y, 2 * sg);
  float sw = 1.0f, s1 = 0.0f, s2 = vp;  // the center: weight 1, deviation 0
  const int r = s.spatial_radius;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      const int qx = x + dx, qy = y + dy;
      if ((dx == 0 && dy == 0) || qx < 0 || qx >= w || qy < 0 || qy >= h) continue;
      const GeometryTerms t = geometry_terms(g, s, x, y, dx, dy);
      const float wt = s.normal_exp ? edge_stopping_weight_exp(t.exponent, 0.0f)
                                    : edge_stopping_weight(t.exponent, 0.0f, t.w_normal);
      sw += wt;
      const float dm = moments.at(qx, qy, 2 * sg) - mp;
      s1 = std::fma(wt, dm, s1);
      s2 = std::fma(wt, std::fma(dm, dm, moments.at(qx, qy, 2 * sg + 1)), s2);
    }
  const float inv = 1.0f / sw;
  const float m1 = s1 * inv;
  return max_ps(0.0f, std::fma(-m1, m1, s2 * inv));
}

float prefiltered_variance_at(const ImageF& variance, int x, int y, int sg) {
  const int w = variance.width(), h = variance.height();
  float gv = 0.0f, gw = 0.0f;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int qx = x + dx, qy = y + dy;
      if (qx < 0 || qx >= w || qy < 0 || qy >= h) continue;
      const float wt = gauss3_weight(dx, dy);
      gw += wt;
      gv = std::fma(wt, variance.at(qx, qy, sg), gv);
    }
  return gv / gw;
}

namespace {
template <int R>
Filtered atrous_with_radius(const Guide& g, const ImageF& color, const ImageF& variance, int step,
                            const SvgfSettings& s, int x, int y, int sg) {
  const int w = color.width(), h = color.height();
  const auto lum = [&](int qx, int qy) {
    return luminance(color.at(qx, qy, 3 * sg), color.at(qx, qy, 3 * sg + 1),
                     color.at(qx, qy, 3 * sg + 2));
  };
  const float inv_phi = luminance_inv_phi(prefiltered_variance_at(variance, x, y, sg), s.sigma_l);
  const float lp = lum(x, y), h0 = atrous_weight<R>(0, 0);
  float sw = h0, sc[3], sv = (h0 * h0) * variance.at(x, y, sg);
  for (int ch = 0; ch < 3; ++ch) sc[ch] = h0 * color.at(x, y, 3 * sg + ch);
  for (int j = -R; j <= R; ++j)
    for (int i = -R; i <= R; ++i) {
      const int qx = x + i * step, qy = y + j * step;
      if ((i == 0 && j == 0) || qx < 0 || qx >= w || qy < 0 || qy >= h) continue;
      // normal_exp: h(q) enters the exponent as -ln h(q), so the weight is one exp.
      const GeometryTerms t =
          geometry_terms(g, s, x, y, i * step, j * step, atrous_neg_log<R>(i, j));
      const float el = luminance_exponent(lp, lum(qx, qy), inv_phi);
      const float wt =
          s.normal_exp  // h(q) w(p, q)
              ? edge_stopping_weight_exp(t.exponent, el)
              : edge_stopping_weight(t.exponent, el, t.w_normal * atrous_weight<R>(i, j));
      sw += wt;
      for (int ch = 0; ch < 3; ++ch) sc[ch] = std::fma(wt, color.at(qx, qy, 3 * sg + ch), sc[ch]);
      sv = std::fma(wt * wt, variance.at(qx, qy, sg), sv);
    }
  const float inv = 1.0f / sw;
  return {{sc[0] * inv, sc[1] * inv, sc[2] * inv}, sv * (inv * inv)};
}
}  // namespace

Filtered atrous_at(const Guide& g, const ImageF& color, const ImageF& variance, int step,
                   const SvgfSettings& s, int x, int y, int sg) {
  return atrous_radius(s) == 1 ? atrous_with_radius<1>(g, color, variance, step, s, x, y, sg)
                               : atrous_with_radius<2>(g, color, variance, step, s, x, y, sg);
}

void remodulate_at(const RemodulationInputs& r, int signals, const float* filtered, int x, int y,
                   float (&out)[3]) {
  bool finite = true;
  for (int ch = 0; ch < 3; ++ch) {
    float sum = r.emission ? r.emission->at(x, y, ch) : 0.0f;
    for (int sg = 0; sg < signals; ++sg) {
      float v = filtered[3 * sg + ch];
      if (r.factor[sg] == Remodulation::Albedo) v = v * r.albedo->at(x, y, ch);
      if (r.factor[sg] == Remodulation::Demodulated)
        v = v * demodulation_factor(r.albedo->at(x, y, ch), r.albedo_epsilon);
      sum = sum + v;
    }
    out[ch] = sum;
    finite = finite && std::isfinite(sum);
  }
  if (!finite)
    for (int ch = 0; ch < 3; ++ch) out[ch] = r.color->at(x, y, ch);
}

void gradient_atrous_at(const ImageF& src, ImageF& dst, const SvgfSettings& s, int px, int py,
                        int step) {
  constexpr int kS = kGradientStratumSize;
  const int sw = src.width(), sh = src.height();
  const float zp = src.at(px, py, kZ), lp = src.at(px, py, kLum);
  const float np[3] = {src.at(px, py, kNx), src.at(px, py, kNy), src.at(px, py, kNz)};
  const float gxp = src.at(px, py, kGx), gyp = src.at(px, py, kGy);
  const float eps = depth_eps(zp, s.depth_epsilon);
  float sum_h = 0.0f, sum_c = 0.0f, sum_d = 0.0f, sum_m = 0.0f, sum_p = 0.0f;
  for (int oy = -2; oy <= 2; ++oy) {
    const int qy = py + oy * step;
    if (qy < 0 || qy >= sh) continue;
    for (int ox = -2; ox <= 2; ++ox) {
      const int dxs = ox * step, qx = px + dxs;
      const int cx = qx < 0 ? 0 : (qx >= sw ? sw - 1 : qx);
      auto at = [&](int plane) { return src.at(cx, qy, plane); };
      float wgt = b3_weight(ox, oy);
      if (ox != 0 || oy != 0) {
        const float ez =
            depth_exponent(zp, at(kZ), gxp, gyp, dxs * kS, oy * step * kS, s.sigma_z, eps);
        const float nq[3] = {at(kNx), at(kNy), at(kNz)};
        const float lq = at(kLum);
        const float el = std::fabs(lp - lq) / std::fma(s.sigma_l * 0.5f, lp + lq, 1e-4f);
        wgt = wgt * edge_stopping_weight(ez, el, normal_weight(normal_dot(np, nq), s.sigma_n));
      }
      if (qx < 0 || qx >= sw) wgt = 0.0f;
      const float wc = wgt * at(kConf);
      sum_h = sum_h + wgt;
      sum_c = sum_c + wc;
      sum_d = std::fma(wc, at(kDelta), sum_d);
      sum_m = std::fma(wc, at(kMax), sum_m);
      sum_p = std::fma(wc, at(kPrev), sum_p);
    }
  }
  const bool has_c = sum_c > 0.0f, has_h = sum_h > 0.0f;
  dst.at(px, py, kDelta) = has_c ? sum_d / sum_c : 0.0f;
  dst.at(px, py, kMax) = has_c ? sum_m / sum_c : 0.0f;
  dst.at(px, py, kPrev) = has_c ? sum_p / sum_c : 0.0f;
  dst.at(px, py, kConf) = has_h ? sum_c / sum_h : 0.0f;
}

float demodulated(const SignalInputs& in, int sg, int ch, size_t o) {
  float c = in.signal[3 * sg + ch][o];
  if (in.subtract_emission && in.emission[ch]) c = max_ps(c - in.emission[ch][o], 0.0f);
  if (in.demodulate) c = c / demodulation_factor(in.albedo[ch][o], in.albedo_epsilon);
  return c;
}

void sort8(float (&v)[8]) {
  for (const auto& p : kSort8Pairs) {
    const float lo = min_ps(v[p[0]], v[p[1]]);
    v[p[1]] = max_ps(v[p[0]], v[p[1]]);
    v[p[0]] = lo;
  }
}

namespace {
// Index i mirrored at the border of [0, n) without repeating the edge (-1 -> 1, n -> n - 2);
// clamped for 1-pixel images.
int mirror(int i, int n) {
  if (i < 0) i = -i;
  if (i > n - 1) i = 2 * (n - 1) - i;
  return i < 0 ? 0 : (i > n - 1 ? n - 1 : i);
}
}  // namespace

float kth_largest_neighbour(const ImageF& lum, int sg, int x, int y, int k) {
  const int w = lum.width(), h = lum.height();
  float nb[8];
  for (int i = 1; i < 9; ++i)  // kNeighborDx/Dy order
    nb[i - 1] = lum.at(mirror(x + kNeighborDx[i], w), mirror(y + kNeighborDy[i], h), sg);
  sort8(nb);
  return nb[8 - k];
}

float fast_box_clamped(const ImageF& fast, const ImageF& long_prev, float alpha, float cur,
                       float sigma, int radius, int x, int y, int p) {
  const int w = fast.width(), h = fast.height(), r = radius > 0 ? radius : 0;
  const float inv_n = 1.0f / float((2 * r + 1) * (2 * r + 1));
  auto at = [&](int dx, int dy) {
    const int qx = x + dx, qy = y + dy;
    return fast.at(qx < 0 ? 0 : (qx >= w ? w - 1 : qx), qy < 0 ? 0 : (qy >= h ? h - 1 : qy), p);
  };
  float sum = 0.0f;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) sum = sum + at(dx, dy);
  const float mean = sum * inv_n;
  float dev = 0.0f;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      const float e = at(dx, dy) - mean;
      dev = std::fma(e, e, dev);
    }
  const float box = sigma * std::sqrt(dev * inv_n);
  const float prev = min_ps(max_ps(long_prev.at(x, y, p), mean - box), mean + box);
  return alpha >= 1.0f ? cur : accumulate(prev, cur, alpha);
}

bool tap_consistent(const AccumulateContext& k, const Surface& p, const HistoryPosition& hp,
                    int idx, float tx, float ty) {
  const SvgfSettings& s = *k.s;
  const float dx = (tx + 0.5f) - hp.x, dy = (ty + 0.5f) - hp.y;
  const float distance = std::sqrt(std::fma(dx, dx, dy * dy));
  const float pn[3] = {k.prev_normal[0][idx], k.prev_normal[1][idx], k.prev_normal[2][idx]};
  return inside_image(tx, ty, k.w, k.h) &&
         depth_consistent(k.prev_depth[idx], p.z, s.depth_tolerance, s.depth_slope,
                          p.gradient_length, distance) &&
         normal_consistent(pn, p.n, s.normal_cos) &&
         (!k.id || !k.prev_id || k.prev_id[idx] == p.id) && k.prev_length[idx] > 0.0f;
}

History own_history(const float (&cur)[kMaxSignals][3], const float (&lum)[kMaxSignals],
                    int signals) {
  History r{};
  r.n = 0.0f;
  for (int sg = 0; sg < signals; ++sg) {
    for (int ch = 0; ch < 3; ++ch) r.c[sg][ch] = r.f[sg][ch] = cur[sg][ch];
    r.m[sg] = {lum[sg], 0.0f};
  }
  return r;
}

template <int N>
History blended_history(const AccumulateContext& k, const int (&idx)[N], const float (&w)[N]) {
  History r{};
  r.n = 0.0f;
  for (int t = 0; t < N; ++t) r.n = std::fma(w[t], k.prev_length[idx[t]], r.n);
  for (int sg = 0; sg < k.signals; ++sg) {
    for (int ch = 0; ch < 3; ++ch) {
      float c = 0.0f, f = 0.0f;
      for (int t = 0; t < N; ++t) c = std::fma(w[t], k.prev_color[3 * sg + ch][idx[t]], c);
      if (k.fast)
        for (int t = 0; t < N; ++t) f = std::fma(w[t], k.prev_fast[3 * sg + ch][idx[t]], f);
      r.c[sg][ch] = c;
      r.f[sg][ch] = f;
    }
    float mean[N], var[N];
    for (int t = 0; t < N; ++t) {
      mean[t] = k.prev_mean[sg][idx[t]];
      var[t] = k.prev_var[sg][idx[t]];
    }
    r.m[sg] = blend_moments(w, mean, var);
  }
  return r;
}
template History blended_history<4>(const AccumulateContext&, const int (&)[4], const float (&)[4]);
template History blended_history<9>(const AccumulateContext&, const int (&)[9], const float (&)[9]);

bool history_finite(const AccumulateContext& k, const History& hist) {
  bool finite = std::isfinite(hist.n);
  for (int sg = 0; sg < k.signals; ++sg) {
    for (int ch = 0; ch < 3; ++ch)
      finite =
          finite && std::isfinite(hist.c[sg][ch]) && (!k.fast || std::isfinite(hist.f[sg][ch]));
    finite = finite && std::isfinite(hist.m[sg].mean) && std::isfinite(hist.m[sg].var);
  }
  return finite;
}

History reprojected_history(const AccumulateContext& k, int x, int y, const History& own,
                            bool& ok) {
  const int w = k.w, h = k.h;
  const size_t o = size_t(y) * size_t(w) + size_t(x);
  ok = false;
  const float gx = k.gradient[0][o], gy = k.gradient[1][o];
  const Surface p{k.depth[o],
                  {k.normal[0][o], k.normal[1][o], k.normal[2][o]},
                  std::sqrt(std::fma(gx, gx, gy * gy)),
                  k.id ? k.id[o] : 0u};
  // The current sample sits at p + jitter; motion is for unjittered positions and the previous
  // pixel q's sample at q + 0.5 + its jitter (DESIGN.md §3).
  const HistoryPosition hp =
      history_position(x, y, k.motion[0][o] + k.jitter_dx, k.motion[1][o] + k.jitter_dy, w, h);
  if (!hp.onscreen) return own;
  History r = own;
  // 2x2 bilinear taps, each tested, the weights renormalised over the passing ones.
  const float x0 = std::floor(hp.x - 0.5f), y0 = std::floor(hp.y - 0.5f);
  float wt[4];
  bilinear_tap_weights((hp.x - 0.5f) - x0, (hp.y - 0.5f) - y0, wt);
  int idx[4];
  bool pass[4];
  for (int t = 0; t < 4; ++t) {
    const float tx = x0 + float(t & 1), ty = y0 + float(t >> 1);
    idx[t] = clamped_pixel_index(tx, ty, w, h);
    pass[t] = tap_consistent(k, p, hp, idx[t], tx, ty);
  }
  if (renormalize_weights(wt, pass)) {
    r = blended_history(k, idx, wt);
    ok = true;
  } else {
    // 3x3 around the pixel containing the position: equal weights over its consistent pixels.
    const float cx = std::floor(hp.x), cy = std::floor(hp.y);
    int fidx[9];
    float fw[9], count = 0.0f;
    for (int t = 0; t < 9; ++t) {
      const float tx = cx + float(t % 3 - 1), ty = cy + float(t / 3 - 1);
      fidx[t] = clamped_pixel_index(tx, ty, w, h);
      fw[t] = tap_consistent(k, p, hp, fidx[t], tx, ty) ? 1.0f : 0.0f;
      count = count + fw[t];
    }
    if (count > 0.0f) {
      const float inv = 1.0f / max_ps(count, 1.0f);
      for (int t = 0; t < 9; ++t) fw[t] = fw[t] * inv;
      r = blended_history(k, fidx, fw);
      ok = true;
    }
  }
  if (ok && !history_finite(k, r)) {
    ok = false;
    r = own;
  }
  return r;
}

bool inputs_need_sanitize(const AccumulateContext& k, size_t o) {
  for (int i = 0; i < k.check_colors; ++i) {
    const float v = k.check_color[i][o];
    if (!(v >= 0.0f && v <= FLT_MAX)) return true;
  }
  const float z = k.check_depth[o];
  if (!(z > 0.0f && z <= FLT_MAX)) return true;
  for (int i = 0; i < k.check_finites; ++i)
    if (!(std::fabs(k.check_finite[i][o]) <= FLT_MAX)) return true;
  return false;
}

namespace {
// Step 2's inputs of k as history_clamp.h's plain ones (for demodulated), built once per pass.
SignalInputs signal_inputs(const AccumulateContext& k) {
  SignalInputs in;
  in.w = k.w;
  in.h = k.h;
  in.signals = k.signals;
  for (int i = 0; i < 3 * kMaxSignals; ++i) in.signal[i] = k.signal[i];
  in.subtract_emission = k.subtract_emission;
  in.demodulate = k.demodulate;
  for (int ch = 0; ch < 3; ++ch) {
    in.emission[ch] = k.emission[ch];
    in.albedo[ch] = k.albedo[ch];
  }
  in.albedo_epsilon = k.s->albedo_epsilon;
  return in;
}

bool accumulate_at(const AccumulateContext& k, const SignalInputs& in, int x, int y) {
  const SvgfSettings& s = *k.s;
  const size_t o = size_t(y) * size_t(k.w) + size_t(x);
  const bool needs_sanitize = k.check && inputs_need_sanitize(k, o);
  if (k.keep_depth) {
    k.keep_depth[o] = k.depth[o];
    for (int ch = 0; ch < 3; ++ch) k.keep_normal[ch][o] = k.normal[ch][o];
    if (k.keep_id) k.keep_id[o] = k.keep_id_from[o];
  }

  // 2. This frame's demodulated signals and their luminance.
  float cur[kMaxSignals][3] = {}, lum[kMaxSignals] = {};
  for (int sg = 0; sg < k.signals; ++sg) {
    for (int ch = 0; ch < 3; ++ch) cur[sg][ch] = demodulated(in, sg, ch, o);
    lum[sg] = luminance(cur[sg][0], cur[sg][1], cur[sg][2]);
  }
  const History own = own_history(cur, lum, k.signals);

  // 3. Reprojection.
  bool ok = false;
  History prev = k.has_history ? reprojected_history(k, x, y, own, ok) : own;
  if (k.relight) {
    // A-SVGF relighting (gradient.h): the history times the luminance ratio now / prev, every
    // signal by the one ratio; moments scale as l (mean by r, variance by r^2).
    const float r = ok ? k.relight[o] : 1.0f;
    for (int sg = 0; sg < k.signals; ++sg) {
      for (int ch = 0; ch < 3; ++ch) prev.c[sg][ch] = prev.c[sg][ch] * r;
      prev.m[sg] = {prev.m[sg].mean * r, (prev.m[sg].var * r) * r};
      if (k.fast)
        for (int ch = 0; ch < 3; ++ch) prev.f[sg][ch] = prev.f[sg][ch] * r;
    }
  }

  // 4. Accumulation with the reprojected history length (no history: this frame alone).
  float alpha = ok ? temporal_alpha(prev.n, s.alpha_min) : 1.0f;
  float alpha_m = ok ? temporal_alpha(prev.n, s.moments_alpha_min) : 1.0f;
  float n_prev = prev.n;
  if (k.lambda) {
    // A-SVGF (gradient.h): alpha' = (1 - lambda) alpha + lambda where the lighting changed.
    const float lam = k.lambda[o];
    if (ok) {
      alpha = gradient_alpha(alpha, lam);
      alpha_m = gradient_alpha(alpha_m, lam);
    }
    if (k.shorten_history) n_prev = shortened_history_length(n_prev, lam);
  }
  float n_next = ok ? next_history_length(n_prev, float(s.history_cap)) : 1.0f;
  float alpha_f = k.fast && ok ? temporal_alpha(n_prev, k.fast_alpha_min) : 1.0f;
  if (k.invalid && k.invalid[o] > 0.0f) {
    // A repaired input: this frame's value only, with length 0, so that no pixel's
    // reprojection takes it as history next frame.
    alpha = alpha_m = alpha_f = 1.0f;
    n_next = 0.0f;
    prev = own;
  }
  for (int sg = 0; sg < k.signals; ++sg) {
    for (int ch = 0; ch < 3; ++ch) {
      const int p = 3 * sg + ch;
      if (k.fast) {
        // The long blend is left to clamp_history_to_fast_box (its box spans neighbours).
        k.fast_acc[p][o] = accumulate(prev.f[sg][ch], cur[sg][ch], alpha_f);
        k.long_prev[p][o] = prev.c[sg][ch];
        k.acc[p][o] = cur[sg][ch];
      } else {
        k.acc[p][o] = accumulate(prev.c[sg][ch], cur[sg][ch], alpha);
      }
    }
    const Moments m = accumulate_moments(prev.m[sg], lum[sg], alpha_m);
    k.mean[sg][o] = m.mean;
    k.var[sg][o] = m.var;
  }
  if (k.fast) k.alpha_out[o] = alpha;
  k.length[o] = n_next;
  return needs_sanitize;
}
}  // namespace

bool accumulate_pixel(const AccumulateContext& k, int x, int y) {
  return accumulate_at(k, signal_inputs(k), x, y);
}

float gradient_of(float a, float b) {
  const float fa = std::fabs(a), fb = std::fabs(b);
  const bool agree = fa <= 2.0f * fb && fb <= 2.0f * fa;
  float r = agree ? 0.5f * (a + b) : (fa < fb ? a : b);
  if (!std::isfinite(b)) r = a;
  if (!std::isfinite(a)) r = std::isfinite(b) ? b : 0.0f;
  return r;
}

void depth_gradient(const ImageF& depth, ImageF& out, const Exec& exec) {
  const int w = depth.width(), h = depth.height();
  ensure_shape(out, w, h, 2);
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const float z = depth.at(x, y, 0);
      const float right = x + 1 < w ? depth.at(x + 1, y, 0) : INFINITY;
      const float left = x > 0 ? depth.at(x - 1, y, 0) : INFINITY;
      const float below = y + 1 < h ? depth.at(x, y + 1, 0) - z : INFINITY;
      const float above = y > 0 ? z - depth.at(x, y - 1, 0) : INFINITY;
      out.at(x, y, 0) = gradient_of(right - z, z - left);
      out.at(x, y, 1) = gradient_of(below, above);
    }
  });
}

// The à-trous and the variance run with subnormals flushed (core/simd.h FlushSubnormals; a
// weight below 2^-126 against the center's changes nothing visible, and subnormal arithmetic is
// ~100x slower on Intel); the remodulation does not.

void estimate_variance(const Guide& g, const ImageF& moments, const ImageF& length,
                       const SvgfSettings& s, ImageF& variance, const Exec& exec) {
  const int w = moments.width(), h = moments.height(), S = moments.channels() / 2;
  ensure_shape(variance, w, h, S);
  parallel_rows(exec, h, [&](int y) {
    const FlushSubnormals flush;
    for (int x = 0; x < w; ++x)
      for (int sg = 0; sg < S; ++sg)
        variance.at(x, y, sg) = variance_at(g, moments, length, s, x, y, sg);
  });
}

void atrous_iteration(const Guide& g, const ImageF& color, const ImageF& variance, int step,
                      const SvgfSettings& s, ImageF& out_color, ImageF& out_variance,
                      const Exec& exec) {
  const int w = color.width(), h = color.height(), S = variance.channels();
  ensure_shape(out_color, w, h, 3 * S);
  ensure_shape(out_variance, w, h, S);
  parallel_rows(exec, h, [&](int y) {
    const FlushSubnormals flush;
    for (int x = 0; x < w; ++x)
      for (int sg = 0; sg < S; ++sg) {
        const Filtered f = atrous_at(g, color, variance, step, s, x, y, sg);
        for (int ch = 0; ch < 3; ++ch) out_color.at(x, y, 3 * sg + ch) = f.color[ch];
        out_variance.at(x, y, sg) = f.variance;
      }
  });
}

void atrous_iteration_remodulated(const Guide& g, const ImageF& color, const ImageF& variance,
                                  int step, const SvgfSettings& s, const RemodulationInputs& r,
                                  ImageF& out, ImageF* filtered, const Exec& exec) {
  const int w = color.width(), h = color.height(), S = variance.channels();
  ensure_shape(out, w, h, 3);
  if (filtered) ensure_shape(*filtered, w, h, 3 * S);
  parallel_rows(exec, h, [&](int y) {
    std::vector<float> row(size_t(3 * S) * size_t(w));  // the filtered signals, pixel-major
    {
      const FlushSubnormals flush;
      for (int x = 0; x < w; ++x)
        for (int sg = 0; sg < S; ++sg) {
          const Filtered f = atrous_at(g, color, variance, step, s, x, y, sg);
          for (int ch = 0; ch < 3; ++ch) row[size_t(3 * (S * x + sg) + ch)] = f.color[ch];
        }
    }
    for (int x = 0; x < w; ++x) {
      const float* f = &row[size_t(3 * S * x)];
      float c[3];
      remodulate_at(r, S, f, x, y, c);
      for (int ch = 0; ch < 3; ++ch) out.at(x, y, ch) = c[ch];
      if (filtered)
        for (int k = 0; k < 3 * S; ++k) filtered->at(x, y, k) = f[k];
    }
  });
}

bool reproject_and_accumulate(const AccumulateContext& k, const Exec& exec) {
  const SignalInputs in = signal_inputs(k);
  return parallel_sum_rows(exec, k.h, [&](int y) {
           bool bad = false;
           for (int x = 0; x < k.w; ++x) bad = accumulate_at(k, in, x, y) || bad;
           return bad ? 1.0 : 0.0;
         }) > 0;
}

void demodulate_and_clamp_fireflies(const SignalInputs& in, int rank, ImageF& out, ImageF& lum,
                                    const Exec& exec) {
  const int w = in.w, h = in.h, S = in.signals;
  ensure_shape(out, w, h, 3 * S);
  ensure_shape(lum, w, h, S);
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x)
      for (int sg = 0; sg < S; ++sg) {
        const size_t o = size_t(y) * size_t(w) + size_t(x);
        float c[3];
        for (int ch = 0; ch < 3; ++ch)
          out.at(x, y, 3 * sg + ch) = c[ch] = demodulated(in, sg, ch, o);
        lum.at(x, y, sg) = luminance(c[0], c[1], c[2]);
      }
  });
  if (rank <= 0) return;
  // Reads only `lum`, so `out` is scaled in place.
  const int k = rank < 1 ? 1 : (rank > 8 ? 8 : rank);
  parallel_rows(exec, h, [&](int y) {
    for (int x = 0; x < w; ++x)
      for (int sg = 0; sg < S; ++sg) {
        const float scale =
            firefly_scale(lum.at(x, y, sg), kth_largest_neighbour(lum, sg, x, y, k));
        for (int ch = 0; ch < 3; ++ch)
          out.at(x, y, 3 * sg + ch) = out.at(x, y, 3 * sg + ch) * scale;
      }
  });
}

void clamp_history_to_fast_box(const ImageF& fast, const ImageF& long_prev, const ImageF& alpha,
                               float sigma, int radius, ImageF& acc, const Exec& exec) {
  parallel_rows(exec, acc.height(), [&](int y) {
    for (int x = 0; x < acc.width(); ++x)
      for (int p = 0; p < acc.channels(); ++p)
        acc.at(x, y, p) = fast_box_clamped(fast, long_prev, alpha.at(x, y, 0), acc.at(x, y, p),
                                           sigma, radius, x, y, p);
  });
}

}  // namespace afterimage::svgf::reference
