#include "post/dof_diffusion.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "camera/camera.h"
#include "core/error.h"

namespace afterimage::post {

namespace {

// Forward elimination of one line, shared by every plane and step: with e_i = g_i / den_i
// (the Thomas algorithm's -c'_i, positive here) and
//   den_i = 1 + g_{i-1} + g_i - g_{i-1} e_{i-1}   (>= 1: the matrix is diagonally dominant)
// the sweeps are d_i = x_i / den_i + q_i d_{i-1} with q_i = g_{i-1} / den_i, then
// y_i = d_i + e_i y_{i+1}. Reads g through `g_at(i)`.
template <class G, class Out>
void factor_line(G&& g_at, int n, Out&& out) {
  double g_prev = 0.0, e_prev = 0.0;
  for (int i = 0; i < n; ++i) {
    const double g = i + 1 < n ? g_at(i) : 0.0;
    const double inv_den = 1.0 / (1.0 + g_prev + g - g_prev * e_prev);
    const double e = g * inv_den;
    out(i, inv_den, g_prev * inv_den, e);
    g_prev = g;
    e_prev = e;
  }
}

// The factored operator of one direction, computed once for every step and plane: per pixel
// 1 / den, q and e (planes 0, 1, 2; rounded to float, the sweeps run in double), and which
// rows (horizontal) or column blocks (vertical) conduct at all.
struct Factors {
  ImageF f;
  std::vector<uint8_t> active;
};

// Columns solved together by one task of the vertical pass: the sweeps walk down the rows of
// a block, so memory is read along rows.
constexpr int kColumnBlock = 32;

// The vertical passes read a block's 128 bytes of each plane row after row, a stride of a
// whole image row that the hardware prefetchers do not follow: each row was a demand miss
// (1080p columns took 7x the time of 960x540's). They ask for the lines kRowsAhead rows on
// (a prefetch changes no value).
constexpr int kRowsAhead = 8;
template <int kForWrite = 0>
inline void prefetch_block_row(const float* row_start, int nb) {
  for (int j = 0; j < nb; j += 16) __builtin_prefetch(row_start + j, kForWrite);
}

// The conductance field of the pass: per pixel conductivity, divided by the steps; none
// between two pixels of different `layer` (when given).
struct Conductivity {
  const std::vector<float>& kappa;
  const std::vector<uint8_t>* layer;
  int w, h;
  float inv_steps;
  // Between pixel indices a and b (neighbours).
  double between(size_t a, size_t b) const {
    if (layer && (*layer)[a] != (*layer)[b]) return 0.0;
    return double(pair_conductance(kappa[a], kappa[b]) * inv_steps);
  }
};

// Rows factored together by one task: each row's factors are a chain of dependent divisions,
// so the rows of a group run side by side, one pixel of each in turn, and the core overlaps
// their chains (the same operations per row as factor_line). 1080p, one thread, laps: 23.4-24.5
// -> 17.7-19.2 ms. (The sweeps of diffuse_rows grouped so measured slower: GCC gathered the
// rows.)
constexpr int kRowGroup = 8;

// Horizontal factors: factor_line along each row (kRowGroup rows side by side).
Factors factor_rows(const Conductivity& k, const Exec& ex) {
  const int w = k.w, h = k.h;
  Factors r{ImageF(w, h, 3), std::vector<uint8_t>(size_t(h), 0)};
  parallel_rows(ex, (h + kRowGroup - 1) / kRowGroup, [&](int group) {
    const int y0 = group * kRowGroup, n = std::min(kRowGroup, h - y0);
    double g_prev[kRowGroup] = {}, e_prev[kRowGroup] = {};
    bool any[kRowGroup] = {};
    for (int i = 0; i < w; ++i)
      for (int j = 0; j < n; ++j) {
        const int y = y0 + j;
        const size_t at = size_t(y) * size_t(w) + size_t(i);
        // factor_line's step i of row y
        const double g = i + 1 < w ? k.between(at, at + 1) : 0.0;
        const double inv_den = 1.0 / (1.0 + g_prev[j] + g - g_prev[j] * e_prev[j]);
        const double e = g * inv_den;
        r.f.row(0, y)[i] = float(inv_den);
        r.f.row(1, y)[i] = float(g_prev[j] * inv_den);
        r.f.row(2, y)[i] = float(e);
        any[j] = any[j] || e != 0.0;
        g_prev[j] = g;
        e_prev[j] = e;
      }
    // A row without conduction is insulated: its step is y = x.
    for (int j = 0; j < n; ++j) r.active[size_t(y0 + j)] = any[j];
  });
  return r;
}

// Vertical factors: factor_line down each column of a block, the block's columns side by side
// (memory read along rows; each row's conductances first, then the block's independent
// divisions, which the compiler vectorises).
Factors factor_columns(const Conductivity& k, const Exec& ex) {
  const int w = k.w, h = k.h;
  const int blocks = (w + kColumnBlock - 1) / kColumnBlock;
  Factors r{ImageF(w, h, 3), std::vector<uint8_t>(size_t(blocks), 0)};
  parallel_rows(ex, blocks, [&](int b) {
    const int x0 = b * kColumnBlock, nb = std::min(kColumnBlock, w - x0);
    double g_prev[kColumnBlock] = {}, e_prev[kColumnBlock] = {}, gc[kColumnBlock] = {};
    bool any = false;
    for (int y = 0; y < h; ++y) {
      float *inv = r.f.row(0, y) + x0, *q = r.f.row(1, y) + x0, *e = r.f.row(2, y) + x0;
      if (y + kRowsAhead + 1 < h)
        prefetch_block_row(k.kappa.data() + size_t(y + kRowsAhead + 1) * size_t(w) + x0, nb);
      if (y + kRowsAhead < h)
        for (int p = 0; p < 3; ++p) prefetch_block_row<1>(r.f.row(p, y + kRowsAhead) + x0, nb);
      for (int j = 0; j < nb; ++j) {
        const size_t i = size_t(y) * size_t(w) + size_t(x0 + j);
        gc[j] = y + 1 < h ? k.between(i, i + size_t(w)) : 0.0;
        any = any || gc[j] != 0.0;
      }
      for (int j = 0; j < nb; ++j) {
        const double a = 1.0 / (1.0 + g_prev[j] + gc[j] - g_prev[j] * e_prev[j]);
        const double ej = gc[j] * a;
        inv[j] = float(a);
        q[j] = float(g_prev[j] * a);
        e[j] = float(ej);
        g_prev[j] = gc[j];
        e_prev[j] = ej;
      }
    }
    r.active[size_t(b)] = any;
  });
  return r;
}

// One implicit step along every row of `img` (all planes, at most 4), in place.
void diffuse_rows(ImageF& img, const Factors& fr, const Exec& ex) {
  const int w = img.width(), h = img.height(), nc = img.channels();
  AI_CHECK(nc <= 4);
  parallel_rows(ex, h, [&](int y) {
    if (!fr.active[size_t(y)]) return;
    const float *inv = fr.f.row(0, y), *q = fr.f.row(1, y), *e = fr.f.row(2, y);
    std::vector<double> d(size_t(w) * size_t(nc));
    float* row[4];
    for (int c = 0; c < nc; ++c) row[c] = img.row(c, y);
    double prev[4] = {0, 0, 0, 0};
    for (int i = 0; i < w; ++i)
      for (int c = 0; c < nc; ++c) {
        prev[c] = row[c][i] * double(inv[i]) + double(q[i]) * prev[c];
        d[size_t(i) * size_t(nc) + size_t(c)] = prev[c];
      }
    for (int i = w - 1; i >= 0; --i)
      for (int c = 0; c < nc; ++c) {
        prev[c] =
            d[size_t(i) * size_t(nc) + size_t(c)] + (i + 1 < w ? double(e[i]) * prev[c] : 0.0);
        row[c][i] = float(prev[c]);
      }
  });
}

// The same along every column: a block of columns walks down the rows together (memory read
// along rows), in loops over the block's columns that the compiler vectorises.
void diffuse_columns(ImageF& img, const Factors& fc, const Exec& ex) {
  const int w = img.width(), h = img.height(), nc = img.channels();
  const int blocks = (w + kColumnBlock - 1) / kColumnBlock;
  parallel_rows(ex, blocks, [&](int b) {
    if (!fc.active[size_t(b)]) return;
    const int x0 = b * kColumnBlock, nb = std::min(kColumnBlock, w - x0);
    // d of row y, channel c, column j at [(y nc + c) nb + j]
    std::vector<double> d(size_t(h) * size_t(nb) * size_t(nc));
    for (int y = 0; y < h; ++y) {
      const float *inv = fc.f.row(0, y) + x0, *q = fc.f.row(1, y) + x0;
      if (y + kRowsAhead < h) {
        for (int p = 0; p < 2; ++p) prefetch_block_row(fc.f.row(p, y + kRowsAhead) + x0, nb);
        for (int c = 0; c < nc; ++c) prefetch_block_row(img.row(c, y + kRowsAhead) + x0, nb);
      }
      for (int c = 0; c < nc; ++c) {
        const float* x = img.row(c, y) + x0;
        double* dc = d.data() + (size_t(y) * size_t(nc) + size_t(c)) * size_t(nb);
        if (y == 0) {
          for (int j = 0; j < nb; ++j) dc[j] = x[j] * double(inv[j]) + 0.0;
        } else {
          const double* up = dc - size_t(nc) * size_t(nb);
          for (int j = 0; j < nb; ++j) dc[j] = x[j] * double(inv[j]) + double(q[j]) * up[j];
        }
      }
    }
    for (int y = h - 1; y >= 0; --y) {
      const float* e = fc.f.row(2, y) + x0;
      if (y - kRowsAhead >= 0) {
        prefetch_block_row(fc.f.row(2, y - kRowsAhead) + x0, nb);
        for (int c = 0; c < nc; ++c) prefetch_block_row(img.row(c, y - kRowsAhead) + x0, nb);
      }
      for (int c = 0; c < nc; ++c) {
        float* out = img.row(c, y) + x0;
        double* dc = d.data() + (size_t(y) * size_t(nc) + size_t(c)) * size_t(nb);
        if (y + 1 < h) {
          const double* down = dc + size_t(nc) * size_t(nb);
          for (int j = 0; j < nb; ++j) dc[j] += double(e[j]) * down[j];
        }
        for (int j = 0; j < nb; ++j) out[j] = float(dc[j]);
      }
    }
  });
}

// `steps` implicit steps (rows, then columns) of `img` in place. False when nothing conducts
// (img unchanged).
bool diffuse(ImageF& img, const Conductivity& k, int steps, const Exec& ex) {
  const Factors rows = factor_rows(k, ex), columns = factor_columns(k, ex);
  const auto on = [](uint8_t v) { return v != 0; };
  if (std::none_of(rows.active.begin(), rows.active.end(), on) &&
      std::none_of(columns.active.begin(), columns.active.end(), on))
    return false;
  for (int i = 0; i < steps; ++i) {
    diffuse_rows(img, rows, ex);
    diffuse_columns(img, columns, ex);
  }
  return true;
}

}  // namespace

void solve_heat_line(const double* g, const double* x, double* y, int n, double* scratch) {
  if (n <= 0) return;
  double* e = scratch;
  double* inv_den = scratch + n;
  factor_line([&](int i) { return g[i]; }, n,
              [&](int i, double a, double, double c) {
                inv_den[i] = a;
                e[i] = c;
              });
  double prev = 0.0;
  for (int i = 0; i < n; ++i) {
    prev = (x[i] + (i > 0 ? g[i - 1] * prev : 0.0)) * inv_den[i];
    y[i] = prev;  // d'_i (x[i] is read before y[i] is written: aliasing is fine)
  }
  for (int i = n - 2; i >= 0; --i) y[i] += e[i] * y[i + 1];
}

ImageF depth_of_field_diffusion(const Frame& f, const ImageF& color, const DofSettings& s,
                                const Exec& ex) {
  const int w = color.width(), h = color.height(), k = s.max_radius;
  const size_t n = size_t(w) * size_t(h);
  // Signed CoC radius, magnitude clamped to max_radius as in the gather.
  std::vector<float> r(n), kappa(n);
  std::vector<uint8_t> near(n);
  const SignedCoc signed_coc(s, dof_lens(f.lens, s));  // coc=ranges reads no lens
  parallel_rows(ex, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      const double coc = signed_coc(f.depth.at(x, y, 0), w);
      r[i] = std::isfinite(coc) ? std::min(float(0.5 * std::abs(coc)), float(k)) : 0.0f;
      kappa[i] = diffusion_conductivity(r[i], s.diffusion_scale);
      near[i] = std::isfinite(coc) && coc < 0.0 && r[i] >= 0.5f;
    }
  });
  const bool layered =
      s.diffusion_near_layer && std::any_of(near.begin(), near.end(), [](uint8_t v) { return v; });
  const float inv_steps = 1.0f / float(s.diffusion_steps);
  // With the near layer, near and other pixels do not exchange heat here: the near field's
  // blur reaches the rest only through the layer (else it would be counted twice).
  ImageF out = color;
  if (!diffuse(out, {kappa, layered ? &near : nullptr, w, h, inv_steps}, s.diffusion_steps, ex))
    return color;  // all in focus
  if (!layered) return out;
  // Near layer: near pixels keep their radius; the others take the largest near radius of
  // the 3x3 tiles of k x k around them (how far a near disc can reach), as the gather's
  // NeighborMax.
  const int tw = (w + k - 1) / k, th = (h + k - 1) / k;
  std::vector<float> tile(size_t(tw) * size_t(th), 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      if (!near[i]) continue;
      float& t = tile[size_t(y / k) * size_t(tw) + size_t(x / k)];
      t = std::max(t, r[i]);
    }
  const std::vector<float> reach = tile_neighbor_max(tile, tw, th);
  std::vector<float> kappa_near(n);
  ImageF layer(w, h, 4);  // premultiplied color, coverage
  parallel_rows(ex, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      const float rn = near[i] ? r[i] : reach[size_t(y / k) * size_t(tw) + size_t(x / k)];
      kappa_near[i] = diffusion_conductivity(rn, s.diffusion_scale);
      const float a = near[i] ? 1.0f : 0.0f;
      for (int c = 0; c < 3; ++c) layer.at(x, y, c) = a * color.at(x, y, c);
      layer.at(x, y, 3) = a;
    }
  });
  diffuse(layer, {kappa_near, nullptr, w, h, inv_steps}, s.diffusion_steps, ex);
  parallel_rows(ex, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const float a = std::clamp(layer.at(x, y, 3), 0.0f, 1.0f);
      for (int c = 0; c < 3; ++c)
        out.at(x, y, c) = layer.at(x, y, c) + (1.0f - a) * out.at(x, y, c);
    }
  });
  return out;
}

}  // namespace afterimage::post
