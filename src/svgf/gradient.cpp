#include "svgf/gradient.h"

#include <utility>

#include "core/error.h"

namespace afterimage::svgf {

namespace {

// Planes of the stratum image while filtering.
enum Plane { kDelta, kMax, kConf, kZ, kNx, kNy, kNz, kGx, kGy, kLum, kPlanes };

}  // namespace

void reconstruct_gradient(const ImageF& gradient, const Guide& g, const ImageF& luminance,
                          const SvgfSettings& s, ImageF& strata, ImageF& lambda, const Exec& ex) {
  const int w = gradient.width(), h = gradient.height();
  AI_CHECK(gradient.channels() == 3 && g.depth && g.normal && g.gradient);
  AI_CHECK(g.depth->width() == w && g.depth->height() == h && luminance.width() == w &&
           luminance.height() == h);
  constexpr int kS = kGradientStratumSize;
  const int sw = (w + kS - 1) / kS, sh = (h + kS - 1) / kS;

  // Stratum samples and guides.
  ImageF a(sw, sh, kPlanes), b(sw, sh, kPlanes);
  parallel_rows(ex, sh, [&](int sy) {
    for (int sx = 0; sx < sw; ++sx) {
      int gx = std::min(w - 1, sx * kS + kS / 2), gy = std::min(h - 1, sy * kS + kS / 2);
      float delta = 0.0f, max = 0.0f, conf = 0.0f;
      for (int y = sy * kS; y < std::min(h, sy * kS + kS) && conf == 0.0f; ++y)
        for (int x = sx * kS; x < std::min(w, sx * kS + kS); ++x) {
          const float d = gradient.at(x, y, 0), m = gradient.at(x, y, 1), v = gradient.at(x, y, 2);
          if (gradient_sample_usable(d, m, v)) {
            delta = d;
            max = m;
            conf = 1.0f;
            gx = x;
            gy = y;
            break;
          }
        }
      a.at(sx, sy, kDelta) = delta;
      a.at(sx, sy, kMax) = max;
      a.at(sx, sy, kConf) = conf;
      a.at(sx, sy, kZ) = g.depth->at(gx, gy, 0);
      for (int c = 0; c < 3; ++c) a.at(sx, sy, kNx + c) = g.normal->at(gx, gy, c);
      a.at(sx, sy, kGx) = g.gradient->at(gx, gy, 0);
      a.at(sx, sy, kGy) = g.gradient->at(gx, gy, 1);
      const float l = luminance.at(gx, gy, 0);
      a.at(sx, sy, kLum) = std::isfinite(l) ? std::max(0.0f, l) : 0.0f;
    }
  });
  // Guides are copied once; only delta, max and confidence change per iteration.
  for (int p = kZ; p < kPlanes; ++p)
    for (int y = 0; y < sh; ++y)
      for (int x = 0; x < sw; ++x) b.at(x, y, p) = a.at(x, y, p);

  static constexpr float kB3[5] = {1.0f / 16, 1.0f / 4, 3.0f / 8, 1.0f / 4, 1.0f / 16};
  ImageF* in = &a;
  ImageF* out = &b;
  for (int it = 0; it < s.gradient_iterations; ++it) {
    const int step = 1 << it;
    const ImageF& src = *in;
    ImageF& dst = *out;
    parallel_rows(ex, sh, [&](int py) {
      for (int px = 0; px < sw; ++px) {
        const float zp = src.at(px, py, kZ), lp = src.at(px, py, kLum);
        const float np[3] = {src.at(px, py, kNx), src.at(px, py, kNy), src.at(px, py, kNz)};
        const float gxp = src.at(px, py, kGx), gyp = src.at(px, py, kGy);
        const float eps = std::max(zp * s.depth_epsilon, 1e-30f);
        double sum_h = 0, sum_c = 0, sum_d = 0, sum_m = 0;
        for (int oy = -2; oy <= 2; ++oy) {
          const int qy = py + oy * step;
          if (qy < 0 || qy >= sh) continue;
          for (int ox = -2; ox <= 2; ++ox) {
            const int qx = px + ox * step;
            if (qx < 0 || qx >= sw) continue;
            float wgt = kB3[ox + 2] * kB3[oy + 2];
            if (ox != 0 || oy != 0) {
              // Depth (SVGF Eq. 2.2): the tolerance is the plane's change over the tap's
              // distance in full-resolution pixels.
              const float dx = float(ox * step * kS), dy = float(oy * step * kS);
              const float tol = s.sigma_z * std::abs(gxp * dx + gyp * dy) + eps;
              const float wz = std::exp(-std::abs(zp - src.at(qx, qy, kZ)) / tol);
              const float dn = np[0] * src.at(qx, qy, kNx) + np[1] * src.at(qx, qy, kNy) +
                               np[2] * src.at(qx, qy, kNz);
              const float wn = std::pow(std::max(0.0f, dn), float(s.sigma_n));
              const float lq = src.at(qx, qy, kLum);
              const float wl =
                  std::exp(-std::abs(lp - lq) / (s.sigma_l * 0.5f * (lp + lq) + 1e-4f));
              wgt *= wz * wn * wl;
            }
            const float c = src.at(qx, qy, kConf);
            sum_h += wgt;
            sum_c += double(wgt) * c;
            sum_d += double(wgt) * c * src.at(qx, qy, kDelta);
            sum_m += double(wgt) * c * src.at(qx, qy, kMax);
          }
        }
        dst.at(px, py, kDelta) = sum_c > 0 ? float(sum_d / sum_c) : 0.0f;
        dst.at(px, py, kMax) = sum_c > 0 ? float(sum_m / sum_c) : 0.0f;
        dst.at(px, py, kConf) = sum_h > 0 ? float(sum_c / sum_h) : 0.0f;
      }
    });
    std::swap(in, out);
  }

  ensure_shape(strata, sw, sh, 4);
  for (int y = 0; y < sh; ++y)
    for (int x = 0; x < sw; ++x) {
      const float d = in->at(x, y, kDelta), m = in->at(x, y, kMax);
      strata.at(x, y, 0) = d;
      strata.at(x, y, 1) = m;
      strata.at(x, y, 2) = in->at(x, y, kConf);
      strata.at(x, y, 3) = gradient_lambda(d, m, s.gradient_scale);
    }
  ensure_shape(lambda, w, h, 1);
  parallel_rows(ex, h, [&](int y) {
    for (int x = 0; x < w; ++x) lambda.at(x, y, 0) = strata.at(x / kS, y / kS, 3);
  });
}

}  // namespace afterimage::svgf
