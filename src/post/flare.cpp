#include "post/flare.h"

#include <fmt/format.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <exception>
#include <memory>
#include <numeric>

#include "core/error.h"
#include "core/simd.h"
#include "post/bloom.h"

namespace afterimage::post {

const ParamTable<FlareSettings>& FlareSettings::params() {
  static const ParamTable<FlareSettings> kTable = [] {  // immutable once built
    using S = FlareSettings;
    ParamTable<S> t("flare");
    t.add_float("threshold", &S::threshold, 0.0f, 65504.0f,
                "bright pixels: max(R,G,B) above this (scene-referred; lights and ghosts)");
    t.add_int("max_lights", &S::max_lights, 0, 64,
              "brightest 8-connected bright components that get sprites and glare");
    t.add_int("downsample", &S::downsample, 1, 16,
              "the bright pass and the streaks are computed at 1/downsample per axis");
    t.add_int("falloff", &S::falloff, 0, 16,
              "exponent k of the fade (1 - d)^k with the distance d to the centre (of the half "
              "diagonal)");
    t.add_float("sprite_intensity", &S::sprite_intensity, 0.0f, 1.0f,
                "King's sprites: energy fraction of the light in the whole sprite table (0 = off)");
    t.add_float("ghost_intensity", &S::ghost_intensity, 0.0f, 1.0f,
                "Chapman's ghosts: energy fraction of the bright pass per ghost (0 = off)");
    t.add_int("ghost_count", &S::ghost_count, 0, 16, "number of ghosts");
    t.add_int("ghost_downsample", &S::ghost_downsample, 1, 32,
              "ghosts and halo are computed (and blurred) at 1/ghost_downsample per axis");
    t.add_float("ghost_spacing", &S::ghost_spacing, -2.0f, 2.0f,
                "ghost i shows the bright pass scaled about the centre by -(1 - i spacing)");
    t.add_float("halo_intensity", &S::halo_intensity, 0.0f, 1.0f,
                "Chapman's halo ring: energy fraction of the bright pass per halo image (a light "
                "inside the halo radius has two; 0 = off)");
    t.add_float("halo_radius", &S::halo_radius, 0.0f, 1.0f,
                "halo ring radius, fraction of the half diagonal");
    t.add_float("chromatic", &S::chromatic, 0.0f, 0.2f,
                "lateral chromatic aberration of ghosts and halo: channel c (R, G, B) magnified "
                "by 1 + (c - 1) chromatic, halo radius by 1 - (c - 1) chromatic (red outside)");
    t.add_int("ghost_blur", &S::ghost_blur, 0, 8,
              "mip levels of the bloom blur over the ghost buffer (0 = none)");
    t.add_float("streak_intensity", &S::streak_intensity, 0.0f, 1.0f,
                "streaks: energy fraction of the bright pass in all rays (0 = off)");
    t.add_int("streak_lines", &S::streak_lines, 1, 8,
              "streak lines through each bright pixel (two rays each, evenly spaced)");
    t.add_float("streak_angle", &S::streak_angle, -360.0f, 360.0f,
                "angle of the first streak line in degrees, from +x towards +y (down)");
    t.add_float("streak_length", &S::streak_length, 0.005f, 1.0f,
                "1/e length of a streak ray, fraction of the image height");
    t.add_float("glare_intensity", &S::glare_intensity, 0.0f, 1.0f,
                "Spencer et al. 1995 glare (lenticular halo + ciliary corona) at each light: "
                "energy fraction (0 = off)");
    t.add_float("glare_fov", &S::glare_fov, 1.0f, 179.0f,
                "vertical field of view of the image in degrees (glare angles to pixels)");
    t.add_int("glare_spikes", &S::glare_spikes, 0, 1024, "radial lines of the ciliary corona");
    return t;
  }();
  return kTable;
}

namespace {

void check_input(const ImageF& img) {
  if (img.empty() || img.width() <= 0 || img.height() <= 0 || img.channels() != 3)
    throw InputError(fmt::format("flare: expected a non-empty RGB image, got {}x{}x{}", img.width(),
                                 img.height(), img.channels()));
}

// ---- Bright pass and light detection ---------------------------------------------------

// A horizontal run of bright pixels [x0, x1] of row y, with its sums (double, in x order).
struct Run {
  int y = 0, x0 = 0, x1 = 0;
  double w = 0, wx = 0, wy = 0;  // sum of (max - threshold), and times the pixel centre
  std::array<double, 3> rgb{};   // sum of the bright-pass color
};

// Bilinear resampling between full resolution and 1/f along one axis (texel i's centre at
// (i + 0.5) f): full-resolution pixel x sits at low coordinate u = (x + 0.5) / f - 0.5 and
// pairs with texels i0 = floor(u) (weight 1 - a) and i0 + 1 (weight a), clamped to the image.
// Upsampling interpolates with these weights; the bright pass is downsampled by splatting
// with the same weights (the adjoint), which keeps each pixel's energy and its position (the
// first moment: (1 - a) (i0 + 0.5) f + a (i0 + 1.5) f = x + 0.5 inside the image), so a
// light's centroid survives the low resolution exactly instead of snapping to texel centres.
struct AxisResample {
  std::vector<int> i0, i1;
  std::vector<float> a;
  // Maximal runs of consecutive pixels with the same texel pair (i0 is non-decreasing), so
  // upsampling is v0 + a (v1 - v0) over contiguous pixels: {first pixel, end} per run.
  std::vector<std::pair<int, int>> runs;
  // Runs 1 .. interior_runs are f pixels each with texels i, i + 1 (i consecutive) and the
  // same weights (0 if that does not hold, for tiny images).
  int interior_runs = 0;
  AxisResample(int n, int f) : AxisResample(n, (n + f - 1) / f, 1.0f / float(f)) {}
  // General: n destination samples of size `ratio` source texels each (x at source coordinate
  // (x + 0.5) ratio - 0.5), m source texels.
  AxisResample(int n, int m, float ratio) : i0(size_t(n)), i1(size_t(n)), a(size_t(n)) {
    const int f = int(std::lround(1.0f / ratio));  // run length of the interior (upsampling)
    for (int x = 0; x < n; ++x) {
      const float u = (float(x) + 0.5f) * ratio - 0.5f, fl = std::floor(u);
      a[size_t(x)] = u - fl;
      i0[size_t(x)] = std::clamp(int(fl), 0, m - 1);
      i1[size_t(x)] = std::clamp(int(fl) + 1, 0, m - 1);
      if (x == 0 || i0[size_t(x)] != i0[size_t(x - 1)] || i1[size_t(x)] != i1[size_t(x - 1)])
        runs.push_back({x, x + 1});
      else
        runs.back().second = x + 1;
    }
    int k = 1;
    for (; k + 1 < int(runs.size()); ++k) {
      const auto [first, end] = runs[size_t(k)];
      const auto [first1, end1] = runs[1];
      bool same = end - first == f && i1[size_t(first)] == i0[size_t(first)] + 1 &&
                  i0[size_t(first)] == i0[size_t(first1)] + (k - 1);
      for (int j = 0; same && j < f; ++j) same = a[size_t(first + j)] == a[size_t(first1 + j)];
      if (!same) break;
    }
    interior_runs = k - 1;
  }
};

// The interior runs of upsample_row for a run length F known at compile time: unrolled for
// the vectoriser, no per-run table reads.
template <int F>
void upsample_interior(const float* v, const float* a, int first, int i0, int runs, float* o) {
  float wt[F];
  for (int j = 0; j < F; ++j) wt[j] = a[first + j];
  for (int k = 0; k < runs; ++k) {
    const float v0 = v[i0 + k], d = v[i0 + k + 1] - v0;
    float* q = o + first + F * k;
    for (int j = 0; j < F; ++j) q[j] = v0 + wt[j] * d;
  }
}

// One low-resolution row brought to a finer grid along x (bilinear, run by run).
void upsample_row(const float* v, const AxisResample& ax, float* o) {
  const float* a = ax.a.data();
  auto run = [&](size_t r) {
    const auto [first, end] = ax.runs[r];
    const float v0 = v[ax.i0[size_t(first)]], d = v[ax.i1[size_t(first)]] - v0;
    for (int x = first; x < end; ++x) o[x] = v0 + a[x] * d;
  };
  const int n = ax.interior_runs;
  const int len = n > 0 ? ax.runs[1].second - ax.runs[1].first : 0;
  if (len == 2 || len == 4 || len == 8) {
    // Runs 1 .. n: `len` pixels each, texels i, i + 1 for consecutive i, the same weights.
    run(0);
    const int first = ax.runs[1].first, i0 = ax.i0[size_t(first)];
    if (len == 2) upsample_interior<2>(v, a, first, i0, n, o);
    if (len == 4) upsample_interior<4>(v, a, first, i0, n, o);
    if (len == 8) upsample_interior<8>(v, a, first, i0, n, o);
    for (size_t r = size_t(n) + 1; r < ax.runs.size(); ++r) run(r);
  } else {
    for (size_t r = 0; r < ax.runs.size(); ++r) run(r);
  }
}

struct BrightPass {
  std::vector<std::vector<Run>> rows;  // runs per row, in x order (empty if not requested)
  std::vector<char> low_lit;           // per row of `low`: any light
  ImageF low;  // bright pass splatted to 1/f, as radiance (empty if not requested)
};

// The bright pass row by row: each row's bright runs and its splat along x to 1/f (a buffer
// for rows with bright pixels only), then bright_pass_low gathers the splats along y. Rows are
// independent (each written by one call), so they may come from any task in any order: from
// bright_pass's own loop, or handed over by the pass that reads the image anyway
// (lens_flare_row_pass's input_row).
struct BrightRows {
  float threshold;
  int w, h, f, lw, lh;
  bool want_low, want_runs;
  AxisResample ax, ay;
  std::vector<std::vector<Run>> rows;     // (want_runs)
  std::vector<std::vector<float>> split;  // 3 x lw per bright row (want_low)
  BrightRows(int w_, int h_, float threshold_, int f_, bool want_low_, bool want_runs_)
      : threshold(threshold_),
        w(w_),
        h(h_),
        f(f_),
        lw((w_ + f_ - 1) / f_),
        lh((h_ + f_ - 1) / f_),
        want_low(want_low_),
        want_runs(want_runs_),
        ax(want_low_ ? w_ : 0, f_),
        ay(want_low_ ? h_ : 0, f_),
        rows(want_runs_ ? size_t(h_) : 0),
        split(want_low_ ? size_t(h_) : 0) {}
  // Row y of `hdr` (w x h, 3 planes).
  void add_row(const ImageF& hdr, int y, const Exec& exec) {
    const float* r = hdr.row(0, y);
    const float* g = hdr.row(1, y);
    const float* b = hdr.row(2, y);
    // Most rows hold no bright pixel: a branch-free scan first (NaN compares false).
    // On full-width lanes (GCC had used half-width vectors): the same comparisons.
    bool bright = false;
    for_each_lane_block(exec, w, [&](auto d, int x) {
      const auto t = hn::Set(d, threshold);
      bright = bright ||
               !hn::AllFalse(
                   d, hn::Or(hn::Or(hn::Gt(hn::LoadU(d, r + x), t), hn::Gt(hn::LoadU(d, g + x), t)),
                             hn::Gt(hn::LoadU(d, b + x), t)));
    });
    if (!bright) return;
    Run run;
    bool open = false;
    auto close = [&] {
      if (open) rows[size_t(y)].push_back(run);
      open = false;
    };
    for (int x = 0; x < w; ++x) {
      const float m = std::max(std::max(r[x], g[x]), b[x]);
      // NaN compares false; a non-finite channel sends no light (nor joins a light).
      if (!(m > threshold) || !std::isfinite(r[x]) || !std::isfinite(g[x]) ||
          !std::isfinite(b[x])) {
        if (want_runs) close();
        continue;
      }
      const float k = (m - threshold) / m;  // hue-keeping hard bright pass
      const float v[3] = {std::max(r[x], 0.0f) * k, std::max(g[x], 0.0f) * k,
                          std::max(b[x], 0.0f) * k};
      if (want_low) {
        std::vector<float>& row = split[size_t(y)];
        if (row.empty()) row.assign(size_t(3) * size_t(lw), 0.0f);
        const float t = ax.a[size_t(x)];
        for (int c = 0; c < 3; ++c) {
          float* o = row.data() + size_t(c) * size_t(lw);
          o[ax.i0[size_t(x)]] += (1.0f - t) * v[c];
          o[ax.i1[size_t(x)]] += t * v[c];
        }
      }
      if (want_runs) {
        if (!open) {
          run = Run{};
          run.y = y;
          run.x0 = x;
          open = true;
        }
        run.x1 = x;
        const double wt = double(m) - double(threshold);
        run.w += wt;
        run.wx += wt * (x + 0.5);
        run.wy += wt * (y + 0.5);
        for (int c = 0; c < 3; ++c) run.rgb[size_t(c)] += double(v[c]);
      }
    }
    if (want_runs) close();
  }
};

// The bright pass of every row in `b` (add_row) gathered along y into `low` (rows in ascending
// order), and the runs moved out.
BrightPass bright_pass_of_rows(BrightRows& b, const Exec& exec) {
  BrightPass bp;
  bp.rows = std::move(b.rows);
  if (!b.want_low) return bp;
  const int f = b.f, h = b.h, lw = b.lw, lh = b.lh;
  bp.low = ImageF(lw, lh, 3, 0.0f);
  bp.low_lit.assign(size_t(lh), 0);
  const float inv_area = 1.0f / float(f * f);  // energy per texel -> radiance
  parallel_rows(exec, lh, [&](int j) {
    // Rows whose vertical pair contains texel row j: within [f (j - 1), f (j + 2)).
    for (int y = std::max(0, f * (j - 1)); y < std::min(h, f * (j + 2)); ++y) {
      const std::vector<float>& row = b.split[size_t(y)];
      if (row.empty()) continue;
      const float wy = (b.ay.i0[size_t(y)] == j ? 1.0f - b.ay.a[size_t(y)] : 0.0f) +
                       (b.ay.i1[size_t(y)] == j ? b.ay.a[size_t(y)] : 0.0f);
      if (wy == 0.0f) continue;
      bp.low_lit[size_t(j)] = 1;  // the row's brightest channel of a bright pixel is > 0
      for (int c = 0; c < 3; ++c) {
        const float* in = row.data() + size_t(c) * size_t(lw);
        float* o = bp.low.row(c, j);
        for (int i = 0; i < lw; ++i) o[i] += wy * in[i];
      }
    }
    for (int c = 0; c < 3; ++c) {
      float* o = bp.low.row(c, j);
      for (int i = 0; i < lw; ++i) o[i] *= inv_area;
    }
  });
  return bp;
}

// One read of the image: the bright runs of every row and the bright pass splatted to 1/f
// (what `b`, made for hdr's size, asks for).
BrightPass bright_pass(const ImageF& hdr, BrightRows b, const Exec& exec) {
  parallel_rows(exec, hdr.height(), [&](int y) { b.add_row(hdr, y, exec); });
  return bright_pass_of_rows(b, exec);
}

// Union-find with the smaller index as root: the root of a component is its first run in
// raster order, whatever the order of the unions.
int find_root(std::vector<int>& parent, int i) {
  while (parent[size_t(i)] != i) {
    parent[size_t(i)] = parent[size_t(parent[size_t(i)])];
    i = parent[size_t(i)];
  }
  return i;
}
void unite(std::vector<int>& parent, int a, int b) {
  a = find_root(parent, a);
  b = find_root(parent, b);
  if (a == b) return;
  if (a < b)
    parent[size_t(b)] = a;
  else
    parent[size_t(a)] = b;
}

// 8-connected components of the runs (two runs of adjacent rows touch when their x ranges
// overlap or meet diagonally), summed in raster order, the `max_lights` largest by energy.
std::vector<BrightLight> components(const std::vector<std::vector<Run>>& rows, int max_lights) {
  std::vector<const Run*> runs;
  std::vector<size_t> start(rows.size() + 1, 0);
  for (size_t y = 0; y < rows.size(); ++y) {
    start[y] = runs.size();
    for (const Run& r : rows[y]) runs.push_back(&r);
  }
  start[rows.size()] = runs.size();
  std::vector<int> parent(runs.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (size_t y = 1; y < rows.size(); ++y) {
    size_t i = start[y - 1], k = start[y];
    while (i < start[y] && k < start[y + 1]) {
      const Run& a = *runs[i];
      const Run& b = *runs[k];
      if (a.x0 <= b.x1 + 1 && b.x0 <= a.x1 + 1) unite(parent, int(i), int(k));
      if (a.x1 < b.x1)
        ++i;
      else
        ++k;
    }
  }
  std::vector<int> index(runs.size(), -1);  // root run -> component
  std::vector<BrightLight> comps;
  std::vector<Vec2d> weighted;
  for (size_t i = 0; i < runs.size(); ++i) {
    const int root = find_root(parent, int(i));
    if (index[size_t(root)] < 0) {
      index[size_t(root)] = int(comps.size());
      comps.emplace_back();
      weighted.emplace_back();
    }
    const Run& r = *runs[i];
    BrightLight& l = comps[size_t(index[size_t(root)])];
    Vec2d& wp = weighted[size_t(index[size_t(root)])];
    l.energy += r.w;
    wp = wp + Vec2d{r.wx, r.wy};
    for (size_t c = 0; c < 3; ++c) l.color[c] += r.rgb[c];
    l.pixels += r.x1 - r.x0 + 1;
  }
  for (size_t k = 0; k < comps.size(); ++k)
    comps[k].position = comps[k].energy > 0.0 ? Vec2d{weighted[k].x / comps[k].energy,
                                                      weighted[k].y / comps[k].energy}
                                              : Vec2d{};
  // Components are numbered in raster order of their first run: a stable sort keeps that
  // order among equal energies.
  std::stable_sort(comps.begin(), comps.end(),
                   [](const BrightLight& a, const BrightLight& b) { return a.energy > b.energy; });
  if (comps.size() > size_t(max_lights)) comps.resize(size_t(max_lights));
  return comps;
}

// ---- Sampling ---------------------------------------------------------------------------

// Bilinear sample of a low-resolution plane at full-resolution position (X, Y) (texel i's
// centre at (i + 0.5) f); taps outside the image read 0.
inline float sample_zero(const float* plane, int w, int h, float X, float Y, float inv_f) {
  const float u = X * inv_f - 0.5f, v = Y * inv_f - 0.5f;
  const float fu = std::floor(u), fv = std::floor(v);
  const int i0 = int(fu), j0 = int(fv);
  const float a = u - fu, b = v - fv;
  if (i0 >= 0 && j0 >= 0 && i0 + 1 < w && j0 + 1 < h) {  // inside: no per-tap checks
    const float* r0 = plane + size_t(j0) * size_t(w) + size_t(i0);
    const float* r1 = r0 + w;
    return (1.0f - b) * ((1.0f - a) * r0[0] + a * r0[1]) + b * ((1.0f - a) * r1[0] + a * r1[1]);
  }
  if (i0 < -1 || j0 < -1 || i0 >= w || j0 >= h) return 0.0f;
  auto tap = [&](int i, int j) {
    return (i < 0 || j < 0 || i >= w || j >= h) ? 0.0f : plane[size_t(j) * size_t(w) + size_t(i)];
  };
  return (1.0f - b) * ((1.0f - a) * tap(i0, j0) + a * tap(i0 + 1, j0)) +
         b * ((1.0f - a) * tap(i0, j0 + 1) + a * tap(i0 + 1, j0 + 1));
}

float length_of(Vec2f v) {
  return std::sqrt(v.x * v.x + v.y * v.y);
}

// `src` (texel size g) bilinearly at the texel centres of a w x h grid of texel size f (clamp to
// edge), ratio = f / g: the ghost grid brought to the streaks' grid.
ImageF resample_bilinear(const ImageF& src, int w, int h, float ratio, const Exec& exec) {
  const AxisResample ax(w, src.width(), ratio), ay(h, src.height(), ratio);
  ImageF rows = ImageF::uninitialized(w, src.height(), src.channels());  // along x first
  parallel_rows(exec, src.height(), [&](int j) {
    for (int c = 0; c < src.channels(); ++c) upsample_row(src.row(c, j), ax, rows.row(c, j));
  });
  ImageF out = ImageF::uninitialized(w, h, src.channels());
  parallel_rows(exec, h, [&](int y) {
    const float fy = ay.a[size_t(y)];
    for (int c = 0; c < src.channels(); ++c) {
      const float* r0 = rows.row(c, ay.i0[size_t(y)]);
      const float* r1 = rows.row(c, ay.i1[size_t(y)]);
      float* o = out.row(c, y);
      for (int x = 0; x < w; ++x) o[x] = r0[x] + fy * (r1[x] - r0[x]);
    }
  });
  return out;
}

// ---- Chapman's ghosts and halo over the low-resolution bright pass -------------------------

// Taps and weights of one axis of an affine resampling: output texel i (centre (i + 0.5) g
// at full resolution) reads the 1/f plane (n_in texels) at full-resolution coordinate
// center + scale ((i + 0.5) g - center), bilinearly, 0 outside: texels t0, t1 (clamped) with
// weights w0, w1 (0 for taps outside).
struct AxisTaps {
  std::vector<int> t0, t1;
  std::vector<float> w0, w1;
  AxisTaps(int n_out, int g, int n_in, int f, float center, float scale)
      : t0(size_t(n_out)), t1(size_t(n_out)), w0(size_t(n_out)), w1(size_t(n_out)) {
    for (int i = 0; i < n_out; ++i) {
      const float X = center + scale * ((float(i) + 0.5f) * float(g) - center);
      const float u = X / float(f) - 0.5f, fl = std::floor(u), a = u - fl;
      const int k = int(fl);
      const bool in0 = k >= 0 && k < n_in, in1 = k + 1 >= 0 && k + 1 < n_in;
      t0[size_t(i)] = in0 ? k : 0;
      t1[size_t(i)] = in1 ? k + 1 : 0;
      w0[size_t(i)] = in0 ? 1.0f - a : 0.0f;
      w1[size_t(i)] = in1 ? a : 0.0f;
    }
  }
};

// Chapman's ghosts and halo at the bright pass's resolution. Ghost g shows the bright pass
// scaled about C by m = ghost_magnification(g) (mirrored for m < 0), channel c by
// m (1 + (c - 1) chromatic): the chromatic offset as lateral chromatic aberration, a per-
// wavelength magnification, so red's image lies further out than blue's, each on the line
// through the light and C. A scaling is separable, so each (ghost, channel) is a table of taps
// per column and per row, and output rows whose source rows hold no light are skipped. The
// halo (not separable) samples C + halo_source_scale(r, R_c) v per texel, its ring radius
// R_c = R (1 - (c - 1) chromatic) per channel (red outside, like the ghosts).
// `bright` is at 1/f with `row_lit` flags; the output at 1/g (g = ghost_downsample).
ImageF chapman_ghosts(const ImageF& bright, const std::vector<char>& row_lit, int w, int h, int f,
                      const FlareSettings& s, const Exec& exec) {
  const int lw = bright.width(), lh = bright.height(), g = s.ghost_downsample;
  const int gw = (w + g - 1) / g, gh = (h + g - 1) / g;
  const Vec2f center{0.5f * float(w), 0.5f * float(h)};
  const float half_diag = length_of(center), inv_f = 1.0f / float(f);
  const int ghosts = s.ghost_intensity > 0.0f ? s.ghost_count : 0;
  struct GhostChannel {
    AxisTaps x, y;
    float gain;  // m_c^2: a ghost magnified by 1/|m| spreads the same energy over 1/m^2 the area
  };
  std::vector<GhostChannel> gc;
  std::vector<float> ghost_m;
  for (int k = 0; k < ghosts; ++k) {
    const float m = ghost_magnification(k, s.ghost_spacing);
    ghost_m.push_back(m);
    for (int c = 0; c < 3; ++c) {
      const float mc = m * (1.0f + float(c - 1) * s.chromatic);
      gc.push_back({AxisTaps(gw, g, lw, f, center.x, mc), AxisTaps(gh, g, lh, f, center.y, mc),
                    mc * mc * kGhostTints[size_t(k) % kGhostTints.size()][size_t(c)]});
    }
  }
  ImageF out(gw, gh, 3, 0.0f);
  parallel_rows(exec, gh, [&](int j) {
    const float vy = (float(j) + 0.5f) * float(g) - center.y;
    std::vector<float> r(static_cast<size_t>(gw)), fade(static_cast<size_t>(gw));
    for (int i = 0; i < gw; ++i) {
      const float vx = (float(i) + 0.5f) * float(g) - center.x;
      r[size_t(i)] = std::sqrt(vx * vx + vy * vy);
    }
    for (int k = 0; k < ghosts; ++k) {
      // Every channel fades with the base magnification: the ghost's source is at |m| r.
      const float am = std::abs(ghost_m[size_t(k)]);
      bool faded = false;  // fade computed lazily: most rows read no light
      for (int c = 0; c < 3; ++c) {
        const GhostChannel& t = gc[size_t(k) * 3 + size_t(c)];
        const int s0 = t.y.t0[size_t(j)], s1 = t.y.t1[size_t(j)];
        const float wy0 = t.y.w0[size_t(j)], wy1 = t.y.w1[size_t(j)];
        if (!((wy0 > 0.0f && row_lit[size_t(s0)]) || (wy1 > 0.0f && row_lit[size_t(s1)]))) continue;
        if (!faded)
          for (int i = 0; i < gw; ++i)
            fade[size_t(i)] =
                s.ghost_intensity * flare_fade(am * r[size_t(i)] / half_diag, s.falloff);
        faded = true;
        const float* r0 = bright.row(c, s0);
        const float* r1 = bright.row(c, s1);
        float* o = out.row(c, j);
        for (int i = 0; i < gw; ++i) {
          const int a = t.x.t0[size_t(i)], b = t.x.t1[size_t(i)];
          const float wx0 = t.x.w0[size_t(i)], wx1 = t.x.w1[size_t(i)];
          const float v = wy0 * (wx0 * r0[a] + wx1 * r0[b]) + wy1 * (wx0 * r1[a] + wx1 * r1[b]);
          o[i] += fade[size_t(i)] * t.gain * v;
        }
      }
    }
    if (s.halo_intensity > 0.0f)
      for (int c = 0; c < 3; ++c) {
        const float R = s.halo_radius * half_diag * (1.0f - float(c - 1) * s.chromatic);
        float* o = out.row(c, j);
        for (int i = 0; i < gw; ++i) {
          const float ri = r[size_t(i)];
          if (!(ri > 0.0f)) continue;
          // The radial map from the mirrored point (at r) to the source (at |R - r|) has
          // Jacobian |R - r| / r: with it each of its two branches (r < R, r > R) carries the
          // energy it samples (see halo_source).
          const float k = halo_source_scale(ri, R), sy = center.y + k * vy;
          // Both source rows dark (or outside): nothing to sample.
          const int sj = int(std::floor(sy * inv_f - 0.5f));
          if ((sj < 0 || sj >= lh || !row_lit[size_t(sj)]) &&
              (sj + 1 < 0 || sj + 1 >= lh || !row_lit[size_t(sj + 1)]))
            continue;
          const float to = std::abs(R - ri);
          const float wgt = s.halo_intensity * kHaloTint[size_t(c)] * (to / ri) *
                            flare_fade(to / half_diag, s.falloff);
          if (wgt <= 0.0f) continue;
          const float vx = (float(i) + 0.5f) * float(g) - center.x;
          o[i] += wgt * sample_zero(bright.plane(c), lw, lh, center.x + k * vx, sy, inv_f);
        }
      }
  });
  return out;
}

// ---- Streaks: exponentially decaying rays by a recursive filter ---------------------------

// True when every value of in[0 .. n) is 0 (a NaN is not), on full-width lanes: the streaks'
// scan for their first light (the scalar loop was ~30% of the rays' samples at 1080p).
bool all_zero(const float* in, int n, const Exec& exec) {
  bool zero = true;
  for_each_lane_block(exec, n, [&](auto d, int x) {
    zero = zero && hn::AllTrue(d, hn::Eq(hn::LoadU(d, in + x), hn::Zero(d)));
  });
  return zero;
}

// The previous row's coordinate for column q, q - slope = q + o + t (o whole, t in [0, 1]).
struct StreakStep {
  int o;
  float t;
  explicit StreakStep(float slope) {
    const float back = -slope;
    o = int(std::floor(back));
    t = back - float(o);
  }
  // The lerp reads column q itself with weight 1: slope 0 (the lines along the axes), or a
  // slope so small and positive that t rounds to 1 with o = -1.
  bool straight() const { return (o == 0 && t == 0.0f) || (o == -1 && t == 1.0f); }
};

// A ray in direction u steps by delta = u / max(|u.x|, |u.y|) (one pixel along the major
// axis, a fraction along the minor one), each step of length |delta| decaying by
// a = exp(-|delta| / length). The ray's light Y(p) = sum_{k >= 1} a^k B(p - k delta) is
// Y(p) = a * lerp(B + Y)(p - delta): one pass over the image along the major axis, the
// previous line linearly interpolated across the minor axis (0 outside).
// The march runs over the rows of a w x h row-major plane (rays whose major axis is y); rays
// whose major axis is x run over the transposed plane, so every line is contiguous.
// `slope`: minor (x) step per row, in [-1, 1]; `down`: rows in increasing order. Adds gain * Y
// to `acc` (w x h, row-major, non-negative): the ray's light goes straight into the sum of the
// rays, with no w x h buffer of its own (writing and re-reading one per ray and channel was
// most of the streaks' time). Rows before the first light add gain * 0 = +0, a no-op on
// non-negative sums, so they are skipped.
// A straight ray (StreakStep::straight) steps straight back, v = a p (the lerp's other texel
// has weight 0 and is not read: the same value for any finite one), so its columns are
// independent: [q_begin, q_end) marches those columns alone (a task each; any other ray needs
// the whole row: q_begin 0, q_end w).
void add_streak_ray(const float* bright, int w, int h, float slope, bool down, float length,
                    float gain, float* acc, const Exec& exec, int q_begin, int q_end) {
  const float a = streak_decay(std::sqrt(1.0f + slope * slope), length);
  if (StreakStep(slope).straight()) {
    const int n = q_end - q_begin;
    std::vector<float> prev(size_t(n), 0.0f);  // B + Y of the columns' previous texels
    bool dark = true;
    for (int step = 0; step < h; ++step) {
      const int row = down ? step : h - 1 - step;
      const float* in = bright + size_t(row) * size_t(w) + size_t(q_begin);
      float* out = acc + size_t(row) * size_t(w) + size_t(q_begin);
      if (dark) {
        dark = all_zero(in, n, exec);
        if (dark) continue;
      }
      if (step == 0) {
        std::copy(in, in + n, prev.begin());
        continue;
      }
      // v = a p0, out += gain v, next = in + v (in place: column q reads only its own texel).
      for_each_lane_block(exec, n, [&](auto d, int q) {
        const auto v = hn::Mul(hn::Set(d, a), hn::LoadU(d, prev.data() + q));
        hn::StoreU(hn::Add(hn::LoadU(d, out + q), hn::Mul(hn::Set(d, gain), v)), d, out + q);
        hn::StoreU(hn::Add(hn::LoadU(d, in + q), v), d, prev.data() + q);
      });
    }
    return;
  }
  AI_CHECK(q_begin == 0 && q_end == w);
  const StreakStep st(slope);
  const int o = st.o;
  const float t = st.t;
  std::vector<float> prev(size_t(w), 0.0f), cur(size_t(w), 0.0f);  // B + Y of a row
  bool dark = true;                                                // no light met yet: Y stays 0
  for (int step = 0; step < h; ++step) {
    const int row = down ? step : h - 1 - step;
    const float* in = bright + size_t(row) * size_t(w);
    float* out = acc + size_t(row) * size_t(w);
    if (dark) {
      dark = all_zero(in, w, exec);
      if (dark) continue;
    }
    if (step == 0) {
      for (int q = 0; q < w; ++q) cur[size_t(q)] = in[q];
    } else {
      // Column q (on the lanes of d) from its two previous-row texels p0, p1:
      // v = a lerp(p0, p1, t), out += gain v, next = in + v.
      const auto step_at = [&](auto d, int q, auto p0, auto p1) {
        const auto v = hn::Mul(
            hn::Set(d, a), hn::Add(hn::Mul(hn::Set(d, 1.0f - t), p0), hn::Mul(hn::Set(d, t), p1)));
        hn::StoreU(hn::Add(hn::LoadU(d, out + q), hn::Mul(hn::Set(d, gain), v)), d, out + q);
        hn::StoreU(hn::Add(hn::LoadU(d, in + q), v), d, cur.data() + q);
      };
      const auto at_edge = [&](int q) {  // texels outside the row are 0
        const int q0 = q + o, q1 = q0 + 1;
        const OneTag d1;
        step_at(d1, q, hn::Set(d1, (q0 >= 0 && q0 < w) ? prev[size_t(q0)] : 0.0f),
                hn::Set(d1, (q1 >= 0 && q1 < w) ? prev[size_t(q1)] : 0.0f));
      };
      // Columns whose two previous-row texels are both inside: no bounds tests, full-width
      // lanes (GCC had vectorised the scalar loop at half width).
      const int lo = std::min(w, std::max(0, -o)), hi = std::max(lo, std::min(w, w - 1 - o));
      for (int q = 0; q < lo; ++q) at_edge(q);
      for_each_lane_block(exec, hi - lo, [&](auto d, int i) {
        const int q = lo + i;
        step_at(d, q, hn::LoadU(d, prev.data() + q + o), hn::LoadU(d, prev.data() + q + o + 1));
      });
      for (int q = hi; q < w; ++q) at_edge(q);
    }
    std::swap(prev, cur);
  }
}

// dst(x, y) (+)= src(y, x) for every channel, by 32 x 32 tiles (both sides stay in cache);
// dst is src.height() x src.width(). One task per band of 32 dst rows.
void transpose_into(const ImageF& src, ImageF& dst, bool add, const Exec& exec) {
  constexpr int kTile = 32;
  const int sw = src.width(), sh = src.height();
  parallel_rows(exec, (sw + kTile - 1) / kTile, [&](int band) {
    const int x0 = band * kTile, x1 = std::min(sw, x0 + kTile);  // dst rows = src columns
    for (int c = 0; c < src.channels(); ++c)
      for (int y0 = 0; y0 < sh; y0 += kTile) {
        const int y1 = std::min(sh, y0 + kTile);
        for (int x = x0; x < x1; ++x) {
          float* o = dst.row(c, x);
          const float* in = src.plane(c) + x;
          if (add)
            for (int y = y0; y < y1; ++y) o[y] += in[size_t(y) * size_t(sw)];
          else
            for (int y = y0; y < y1; ++y) o[y] = in[size_t(y) * size_t(sw)];
        }
      }
  });
}

// A straight ray along x (the default lines' 0 and 180 degrees) over one row of `bright`
// (lw texels, plane row `in`): add_streak_ray's march of that row as a column of the transposed
// plane, the same operations in the same order on each texel, added into r (lw floats).
void add_straight_row_ray(const float* in, int lw, bool down, float a, float gain, float* r) {
  const OneTag d;
  // B + Y of the previous texel; from +0, the first texel's step adds gain * 0 = +0 and
  // keeps its B, as add_streak_ray's copy of the first row does.
  float prev = 0.0f;
  bool dark = true;  // no light met yet: Y stays 0 (adding gain * 0 = +0 changes no sum)
  for (int step = 0; step < lw; ++step) {
    const int x = down ? step : lw - 1 - step;
    if (dark) {
      dark = in[x] == 0.0f;
      if (dark) continue;
    }
    const auto v = hn::Mul(hn::Set(d, a), hn::Set(d, prev));
    r[x] = hn::GetLane(hn::Add(hn::Set(d, r[x]), hn::Mul(hn::Set(d, gain), v)));
    prev = hn::GetLane(hn::Add(hn::Set(d, in[x]), v));
  }
}

ImageF streaks(const ImageF& bright, int h_full, int f, const FlareSettings& s, const Exec& exec,
               StreakLayout layout = StreakLayout::automatic) {
  const int lw = bright.width(), lh = bright.height();
  const int rays = 2 * s.streak_lines;
  const float length = s.streak_length * float(h_full) / float(f);  // in low pixels
  struct Ray {
    bool along_x;  // major axis x: marched over the transposed plane
    float slope, gain;
    bool down;
  };
  std::vector<Ray> ray(static_cast<size_t>(rays));
  bool any_x = false, any_y = false;
  for (int k = 0; k < rays; ++k) {
    const double deg =
        double(s.streak_angle) + 180.0 * double(k / 2) / s.streak_lines + (k % 2 ? 180.0 : 0.0);
    const double ang = deg * kPi / 180.0;
    double ux = std::cos(ang), uy = std::sin(ang);
    // Along an axis exactly (the default lines at 0, 90, 180 and 270 degrees): cos and sin of
    // the rounded radians left ~1e-16 on the minor axis, a lerp weight that leaked 1e-16 of
    // each column into the next (denormals a few rows later: the rays took 12-26% less time
    // with flush-to-zero set as a probe) and kept the ray off the straight path (add_streak_ray).
    const double turns = deg / 90.0;
    if (turns == std::floor(turns)) {
      const int q = int(std::fmod(std::fmod(turns, 4.0) + 4.0, 4.0));
      ux = q == 0 ? 1.0 : q == 2 ? -1.0 : 0.0;
      uy = q == 1 ? 1.0 : q == 3 ? -1.0 : 0.0;
    }
    Ray& r = ray[size_t(k)];
    r.along_x = std::abs(ux) >= std::abs(uy);
    const double maj = r.along_x ? ux : uy, mn = r.along_x ? uy : ux;
    r.slope = float(mn / std::abs(maj));
    r.down = maj >= 0.0;
    const double a = double(streak_decay(std::sqrt(1.0f + r.slope * r.slope), length));
    // sum_{k >= 1} a^k = a / (1 - a): each ray carries 1/rays of the streak energy.
    r.gain = a > 0.0 ? float(double(s.streak_intensity) / rays * (1.0 - a) / a) : 0.0f;
    (r.along_x ? any_x : any_y) = true;
  }
  // Straight rays along x keep their light in its row, so only the rows with light have any.
  // Where those are few (the bench frame's four small lights: ~8 of 270 texel rows), each is
  // marched along x on its own (add_straight_row_ray), without the two transposes of every
  // plane and the zero-filled sum (~2% of the 1080p post chain's CPU); otherwise the rays run
  // over the transposed plane, a column per row on the lanes. The same values either way
  // (Flare.StreaksAreTheSameByRowsAndTransposed).
  bool x_straight = any_x;
  for (const Ray& r : ray)
    if (r.along_x && !StreakStep(r.slope).straight()) x_straight = false;
  std::vector<int> lit_rows;
  if (x_straight && layout != StreakLayout::transposed)
    for (int j = 0; j < lh; ++j)
      for (int c = 0; c < 3; ++c)
        if (!all_zero(bright.row(c, j), lw, exec)) {
          lit_rows.push_back(j);
          break;
        }
  const bool by_rows =
      x_straight && (layout == StreakLayout::rows || (layout == StreakLayout::automatic &&
                                                      size_t(4) * lit_rows.size() <= size_t(lh)));
  if (by_rows) any_x = false;  // the transposed layout's work below is left out
  ImageF bt;
  if (any_x) {
    bt = ImageF::uninitialized(lh, lw, 3);
    transpose_into(bright, bt, false, exec);
  }
  // One task per layout, channel and band of columns: its rays in ray order, each added into
  // the layout's sum (o = 0, then o += gain_k Y_k for k in order), then the transposed sum into
  // the output. A layout whose rays are all straight (the default lines at 0 and 90 degrees)
  // splits its columns into bands (add_streak_ray), so 2 threads share 6 x ~6 tasks instead of
  // 6 unequal ones; other slopes take the whole width.
  ImageF acc_y = any_y ? ImageF(lw, lh, 3, 0.0f) : ImageF(),
         acc_x = any_x ? ImageF(lh, lw, 3, 0.0f) : ImageF();
  constexpr int kBandColumns = 64;
  const auto bands_of = [&](bool along_x) {
    const int width = along_x ? lh : lw;
    for (const Ray& r : ray)
      if (r.along_x == along_x && !StreakStep(r.slope).straight())
        return std::vector<std::pair<int, int>>{{0, width}};
    std::vector<std::pair<int, int>> bands;
    for (int q = 0; q < width; q += kBandColumns)
      bands.push_back({q, std::min(width, q + kBandColumns)});
    return bands;
  };
  struct Task {
    bool along_x;
    int c, q_begin, q_end;
  };
  std::vector<Task> tasks;
  for (const bool along_x : {false, true}) {
    if (!(along_x ? any_x : any_y)) continue;
    const auto bands = bands_of(along_x);
    for (int c = 0; c < 3; ++c)
      for (const auto& [q0, q1] : bands) tasks.push_back({along_x, c, q0, q1});
  }
  parallel_rows(exec, int(tasks.size()), [&](int k) {
    const Task& t = tasks[size_t(k)];
    for (const Ray& r : ray) {
      if (r.along_x != t.along_x) continue;
      if (t.along_x)
        add_streak_ray(bt.plane(t.c), lh, lw, r.slope, r.down, length, r.gain, acc_x.plane(t.c),
                       exec, t.q_begin, t.q_end);
      else
        add_streak_ray(bright.plane(t.c), lw, lh, r.slope, r.down, length, r.gain, acc_y.plane(t.c),
                       exec, t.q_begin, t.q_end);
    }
  });
  ImageF out = any_y ? std::move(acc_y) : ImageF(lw, lh, 3, 0.0f);
  if (any_x) transpose_into(acc_x, out, true, exec);
  if (by_rows)
    parallel_rows(exec, int(lit_rows.size()), [&](int i) {
      const int j = lit_rows[size_t(i)];
      std::vector<float> sum(static_cast<size_t>(lw));
      for (int c = 0; c < 3; ++c) {
        std::fill(sum.begin(), sum.end(), 0.0f);  // the rays' sum in ray order, from +0
        for (const Ray& r : ray)
          if (r.along_x)
            add_straight_row_ray(bright.row(c, j), lw, r.down,
                                 streak_decay(std::sqrt(1.0f + r.slope * r.slope), length), r.gain,
                                 sum.data());
        float* o = out.row(c, j);
        for (int x = 0; x < lw; ++x)
          o[x] = hn::GetLane(hn::Add(hn::Set(OneTag(), o[x]), hn::Set(OneTag(), sum[size_t(x)])));
      }
    });
  return out;
}

// ---- Spencer et al. 1995 glare stamp ----------------------------------------------------

uint64_t mix64(uint64_t z) {  // splitmix64 finaliser
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}
double hash01(uint64_t a, uint64_t b) {
  return double(mix64(mix64(a + 0x9e3779b97f4a7c15ULL) ^ b) >> 11) * 0x1.0p-53;
}

// Angular pattern of the ciliary corona: a faint floor plus `spikes` thin radial lines at
// hashed angles and strengths (fixed: the same pattern every frame), mean 1.
constexpr int kSpikeBins = 2048;
std::vector<float> corona_pattern(int spikes) {
  std::vector<double> p(kSpikeBins, 0.25);
  const double sigma = 0.006;  // radians: ~1 px wide at 170 px from the light
  const double bin = 2.0 * kPi / kSpikeBins;
  for (int k = 0; k < spikes; ++k) {
    const double phi = 2.0 * kPi * hash01(uint64_t(k), 1), amp = 0.3 + 0.7 * hash01(uint64_t(k), 2);
    const int c = int(phi / bin), reach = int(std::ceil(4.0 * sigma / bin));
    for (int d = -reach; d <= reach; ++d) {
      const double e = (c + d + 0.5) * bin - phi;
      p[size_t(((c + d) % kSpikeBins + kSpikeBins) % kSpikeBins)] +=
          amp * std::exp(-0.5 * e * e / (sigma * sigma));
    }
  }
  const double mean = std::accumulate(p.begin(), p.end(), 0.0) / kSpikeBins;
  std::vector<float> out(kSpikeBins);
  for (int i = 0; i < kSpikeBins; ++i) out[size_t(i)] = float(p[size_t(i)] / mean);
  return out;
}

constexpr double kCoronaRadiusDeg = 6.0;  // the corona's rays reach past the halo (seed 004)
constexpr double kHaloShare = 0.3;        // of the glare energy in the lenticular halo

// The glare of one light as a small image (3 planes) with its top-left pixel at (x0, y0):
// halo (per channel at its wavelength's radius) and corona, each normalised by its discrete
// sum over the stamp so that channel c carries exactly glare_intensity * color[c].
struct Stamp {
  int x0 = 0, y0 = 0;
  ImageF img;
};
Stamp glare_stamp(const BrightLight& l, int w, int h, const FlareSettings& s,
                  const std::vector<float>& pattern, const Exec& exec) {
  const double ppd = double(h) / double(s.glare_fov);  // pixels per degree
  const double reach =
      std::max(kCoronaRadiusDeg, spencer_halo_radius_deg(kPrimaryWavelengthNm[0]) + 0.8) * ppd;
  Stamp st;
  st.x0 = std::max(0, int(std::floor(l.position.x - reach)));
  st.y0 = std::max(0, int(std::floor(l.position.y - reach)));
  const int x1 = std::min(w, int(std::ceil(l.position.x + reach)) + 1);
  const int y1 = std::min(h, int(std::ceil(l.position.y + reach)) + 1);
  if (x1 <= st.x0 || y1 <= st.y0) return st;
  const int sw = x1 - st.x0, sh = y1 - st.y0;
  // Planes 0-2: halo per channel; plane 3: corona. Normalised below.
  ImageF k(sw, sh, 4, 0.0f);
  std::vector<std::array<double, 4>> row_sum(static_cast<size_t>(sh));
  parallel_rows(exec, sh, [&](int j) {
    std::array<double, 4> sum{};
    for (int i = 0; i < sw; ++i) {
      const double dx = st.x0 + i + 0.5 - l.position.x, dy = st.y0 + j + 0.5 - l.position.y;
      const double r = std::sqrt(dx * dx + dy * dy) / ppd;
      for (int c = 0; c < 3; ++c) {
        // The ring's profile beyond 5 sigma (0.8 degrees) is below 4e-6 of its peak: left 0.
        const double e = r - spencer_halo_radius_deg(kPrimaryWavelengthNm[size_t(c)]);
        if (std::abs(e) > 0.8) continue;
        const float v = float(spencer_halo_profile(r, kPrimaryWavelengthNm[size_t(c)]));
        k.at(i, j, c) = v;
        sum[size_t(c)] += v;
      }
      float corona = 0.0f;
      if (r < kCoronaRadiusDeg) {
        const double u = r / kCoronaRadiusDeg, edge = (1.0 - u * u) * (1.0 - u * u);
        double phi = std::atan2(dy, dx) / (2.0 * kPi) * kSpikeBins - 0.5;
        phi -= std::floor(phi / kSpikeBins) * kSpikeBins;
        const int b0 = int(phi) % kSpikeBins, b1 = (b0 + 1) % kSpikeBins;
        const double fr = phi - std::floor(phi);
        const double spike = (1.0 - fr) * pattern[size_t(b0)] + fr * pattern[size_t(b1)];
        corona = float(spike * spencer_corona_profile(r) * edge);
      }
      k.at(i, j, 3) = corona;
      sum[3] += corona;
    }
    row_sum[size_t(j)] = sum;
  });
  std::array<double, 4> total{};
  for (const auto& rs : row_sum)
    for (size_t c = 0; c < 4; ++c) total[c] += rs[c];
  st.img = ImageF(sw, sh, 3, 0.0f);
  float halo_gain[3], corona_gain[3];
  for (int c = 0; c < 3; ++c) {
    const double e = double(s.glare_intensity) * l.color[size_t(c)];
    halo_gain[c] = total[size_t(c)] > 0.0 ? float(e * kHaloShare / total[size_t(c)]) : 0.0f;
    corona_gain[c] = total[3] > 0.0 ? float(e * (1.0 - kHaloShare) / total[3]) : 0.0f;
  }
  parallel_rows(exec, sh, [&](int j) {
    for (int c = 0; c < 3; ++c)
      for (int i = 0; i < sw; ++i)
        st.img.at(i, j, c) = halo_gain[c] * k.at(i, j, c) + corona_gain[c] * k.at(i, j, 3);
  });
  return st;
}

// ---- King's sprites -----------------------------------------------------------------------

struct SpriteInstance {
  SpriteShape shape;
  Vec2f at;
  float r = 0;                         // drawn radius (pixels)
  std::array<float, 3> radiance{};     // per channel
  int x0 = 0, x1 = 0, y0 = 0, y1 = 0;  // pixel bounds, inclusive
};

std::vector<SpriteInstance> king_sprites(const std::vector<BrightLight>& lights, int w, int h,
                                         const FlareSettings& s) {
  std::vector<SpriteInstance> out;
  const Vec2f center{0.5f * float(w), 0.5f * float(h)};
  const float half_diag = length_of(center);
  for (const BrightLight& l : lights) {
    const Vec2f L{float(l.position.x), float(l.position.y)};
    const float d = length_of(L - center) / half_diag;
    const float fade = flare_fade(d, s.falloff), size = sprite_size_factor(d);
    if (fade <= 0.0f) continue;
    for (const FlareSprite& sp : kFlareSprites) {
      SpriteInstance si;
      si.shape = sp.shape;
      si.at = sprite_position(L, center, sp.t);
      const float r0 = sp.radius * float(h);
      si.r = r0 * size;
      // Radiance: the sprite's share of the light over its area at d = 0, times the fade.
      const float k = s.sprite_intensity * sp.share * fade / sprite_area(sp.shape, r0);
      for (size_t c = 0; c < 3; ++c) si.radiance[c] = k * sp.tint[c] * float(l.color[c]);
      si.x0 = std::max(0, int(std::floor(si.at.x - si.r - 1.0f)));
      si.x1 = std::min(w - 1, int(std::ceil(si.at.x + si.r + 1.0f)));
      si.y0 = std::max(0, int(std::floor(si.at.y - si.r - 1.0f)));
      si.y1 = std::min(h - 1, int(std::ceil(si.at.y + si.r + 1.0f)));
      if (si.x0 <= si.x1 && si.y0 <= si.y1) out.push_back(si);
    }
  }
  return out;
}

inline float sprite_coverage(const SpriteInstance& si, float x, float y) {
  const float dx = x - si.at.x, dy = y - si.at.y;
  switch (si.shape) {
    case SpriteShape::Disc:
      return sprite_disc_coverage(std::sqrt(dx * dx + dy * dy), si.r);
    case SpriteShape::Ring:
      return sprite_ring_coverage(std::sqrt(dx * dx + dy * dy), si.r, kRingInner * si.r);
    case SpriteShape::Hexagon:
      return sprite_hexagon_coverage(dx, dy, si.r);
  }
  return 0.0f;
}

// ---- The pass -------------------------------------------------------------------------------

bool any_intensity(const FlareSettings& s) {
  return s.sprite_intensity > 0.0f || (s.ghost_intensity > 0.0f && s.ghost_count > 0) ||
         s.halo_intensity > 0.0f || s.streak_intensity > 0.0f || s.glare_intensity > 0.0f;
}

// The flare's light of one image, everything but the composite: the low-resolution light
// (blurred ghosts + halo, plus streaks), the sprites and the glare stamps. Read-only once made,
// so the tasks of any pass add it to their rows concurrently (FlareRowAdder).
struct FlareLight {
  int w = 0, h = 0;
  ImageF low;                       // at 1 / downsample (empty: no ghost, halo or streak)
  AxisResample ax{0, 1}, ay{0, 1};  // bilinear upsampling of `low` (clamp to edge)
  std::vector<char> low_row_lit;    // per texel row of `low`: any light
  std::vector<SpriteInstance> sprites;
  std::vector<Stamp> glare;
};

bool wants_lights(const FlareSettings& s) {
  return s.max_lights > 0 && (s.sprite_intensity > 0.0f || s.glare_intensity > 0.0f);
}
bool wants_ghosts(const FlareSettings& s) {
  return (s.ghost_intensity > 0.0f && s.ghost_count > 0) || s.halo_intensity > 0.0f;
}
// The bright pass rows make_flare_light needs of a w x h image.
BrightRows flare_bright_rows(int w, int h, const FlareSettings& s) {
  return BrightRows(w, h, s.threshold, s.downsample, wants_ghosts(s) || s.streak_intensity > 0.0f,
                    wants_lights(s));
}

// `rows`: the bright pass of every row of hdr already made (flare_bright_rows, add_row), else
// null (made here).
FlareLight make_flare_light(const ImageF& hdr, const FlareSettings& s, const Exec& exec,
                            BrightRows* rows = nullptr) {
  s.validate();
  check_input(hdr);
  FlareLight fl;
  const int w = hdr.width(), h = hdr.height(), f = s.downsample;
  fl.w = w;
  fl.h = h;
  const bool want_lights = wants_lights(s);
  const bool want_ghosts = wants_ghosts(s);
  const bool want_streaks = s.streak_intensity > 0.0f;
  BrightPass bp =
      rows ? bright_pass_of_rows(*rows, exec) : bright_pass(hdr, flare_bright_rows(w, h, s), exec);
  const std::vector<BrightLight> lights =
      want_lights ? components(bp.rows, s.max_lights) : std::vector<BrightLight>{};

  ImageF& low = fl.low;
  if (want_ghosts) {
    ImageF ghosts = chapman_ghosts(bp.low, bp.low_lit, w, h, f, s, exec);
    if (s.ghost_blur > 0) {
      BloomSettings bs;
      bs.levels = s.ghost_blur;
      ghosts = bloom_blur(ghosts, bs, exec);
    }
    low = s.ghost_downsample == f ? std::move(ghosts)
                                  : resample_bilinear(ghosts, bp.low.width(), bp.low.height(),
                                                      float(f) / float(s.ghost_downsample), exec);
  }
  if (want_streaks) {
    ImageF st = streaks(bp.low, h, f, s, exec);
    if (low.empty())
      low = std::move(st);
    else
      parallel_rows(exec, low.height(), [&](int j) {
        for (int c = 0; c < 3; ++c) {
          float* o = low.row(c, j);
          const float* a = st.row(c, j);
          for (int i = 0; i < low.width(); ++i) o[i] += a[i];
        }
      });
  }

  if (s.sprite_intensity > 0.0f) fl.sprites = king_sprites(lights, w, h, s);
  if (s.glare_intensity > 0.0f && !lights.empty()) {
    const std::vector<float> pattern = corona_pattern(s.glare_spikes);
    for (const BrightLight& l : lights) fl.glare.push_back(glare_stamp(l, w, h, s, pattern, exec));
  }

  if (!low.empty()) {
    fl.ax = AxisResample(w, f);
    fl.ay = AxisResample(h, f);
  }
  // Texel rows with any light: the composite skips full-resolution rows between dark ones.
  fl.low_row_lit.assign(static_cast<size_t>(low.height()), 0);
  parallel_rows(exec, low.height(), [&](int j) {
    for (int c = 0; c < 3 && !fl.low_row_lit[size_t(j)]; ++c)
      for (int i = 0; i < low.width(); ++i)
        if (low.at(i, j, c) != 0.0f) {
          fl.low_row_lit[size_t(j)] = 1;
          break;
        }
  });
  return fl;
}

// One task's composite of a FlareLight: out = base + light (add_base) or light, row by row. A
// row's light is the vertical lerp of two texel rows upsampled along x, which the adder keeps
// for the next rows that read the same pair (the rows of a band of `ay`).
class FlareRowAdder {
 public:
  explicit FlareRowAdder(const FlareLight& l) : l_(l) {}
  // Pixels x0 .. x0 + n - 1 of row y's 3 planes (base[c], out[c] point at pixel x0; base may
  // be out). A row comes in pieces in increasing x0, its first at x0 = 0, which readies the
  // row's light (the upsampled texel rows, or the whole light where sprites or glare stamp it).
  void add(int y, int x0, int n, const float* const* base, float* const* out, bool add_base,
           const Exec& exec) {
    if (x0 == 0) ready_row(y);
    for (int c = 0; c < 3; ++c) {
      float* o = out[c];
      const float* in = base[c];
      const size_t at = size_t(c) * size_t(l_.w) + size_t(x0);
      // On full-width lanes (GCC vectorised the scalar loops with half-width vectors); the
      // same operations in order.
      if (stamped_) {  // the light of the row, summed at its first piece
        const float* l = light_.data() + at;
        if (add_base) {
          for_each_lane_block(exec, n, [&](auto d, int x) {
            hn::StoreU(hn::Add(hn::LoadU(d, in + x), hn::LoadU(d, l + x)), d, o + x);
          });
        } else {
          std::copy(l, l + n, o);
        }
      } else if (!lit_ && add_base) {
        for_each_lane_block(exec, n, [&](auto d, int x) {  // as hdr + light: -0 -> +0
          hn::StoreU(hn::Add(hn::LoadU(d, in + x), hn::Zero(d)), d, o + x);
        });
      } else if (!lit_) {
        std::fill(o, o + n, 0.0f);
      } else {  // the common row: the upsampled buffer alone, added directly
        const float* a = h0_.data() + at;
        const float* b = h1_.data() + at;
        for_each_lane_block(exec, n, [&](auto d, int x) {
          const auto va = hn::LoadU(d, a + x);
          const auto light =
              hn::Add(va, hn::Mul(hn::Set(d, fy_), hn::Sub(hn::LoadU(d, b + x), va)));
          hn::StoreU(add_base ? hn::Add(hn::LoadU(d, in + x), light) : light, d, o + x);
        });
      }
    }
  }

 private:
  // Row y's texel rows upsampled along x (h0_, h1_, their weight fy_), and where a sprite or
  // a glare stamp covers the row, its whole light in light_ (stamped_).
  void ready_row(int y) {
    const int w = l_.w;
    const size_t n = size_t(3) * size_t(w);
    const bool has_low = !l_.low.empty();
    const int j0 = has_low ? l_.ay.i0[size_t(y)] : 0, j1 = has_low ? l_.ay.i1[size_t(y)] : 0;
    lit_ = has_low && (l_.low_row_lit[size_t(j0)] || l_.low_row_lit[size_t(j1)]);
    if (lit_ && (j0 != j0_ || j1 != j1_)) {
      h0_.resize(n);  // written below (DefaultInitAllocator: no fill)
      h1_.resize(n);
      // Going down the rows, the next pair's first texel row is the last pair's second: its
      // upsampled row is kept (the same values), so each texel row is upsampled once a task.
      const bool shift = j0 == j1_ && j0 != j0_;
      if (shift) std::swap(h0_, h1_);
      for (int c = 0; c < 3; ++c) {
        if (!shift) upsample_row(l_.low.row(c, j0), l_.ax, h0_.data() + size_t(c) * size_t(w));
        upsample_row(l_.low.row(c, j1), l_.ax, h1_.data() + size_t(c) * size_t(w));
      }
      j0_ = j0;
      j1_ = j1;
    }
    fy_ = lit_ ? l_.ay.a[size_t(y)] : 0.0f;
    stamped_ = false;
    for (const SpriteInstance& si : l_.sprites) stamped_ |= y >= si.y0 && y <= si.y1;
    for (const Stamp& st : l_.glare)
      stamped_ |= !st.img.empty() && y >= st.y0 && y < st.y0 + st.img.height();
    if (!stamped_) return;
    light_.resize(n);
    if (lit_)
      for (size_t k = 0; k < n; ++k) light_[k] = h0_[k] + fy_ * (h1_[k] - h0_[k]);
    else
      std::fill(light_.begin(), light_.end(), 0.0f);
    for (const SpriteInstance& si : l_.sprites) {
      if (y < si.y0 || y > si.y1) continue;
      for (int x = si.x0; x <= si.x1; ++x) {
        const float cov = sprite_coverage(si, float(x) + 0.5f, float(y) + 0.5f);
        if (cov <= 0.0f) continue;
        for (int c = 0; c < 3; ++c)
          light_[size_t(c) * size_t(w) + size_t(x)] += cov * si.radiance[size_t(c)];
      }
    }
    for (const Stamp& st : l_.glare) {
      const int j = y - st.y0;
      if (st.img.empty() || j < 0 || j >= st.img.height()) continue;
      for (int c = 0; c < 3; ++c) {
        const float* g = st.img.row(c, j);
        float* o = light_.data() + size_t(c) * size_t(w) + size_t(st.x0);
        for (int i = 0; i < st.img.width(); ++i) o[i] += g[i];
      }
    }
  }

  const FlareLight& l_;
  int j0_ = -1, j1_ = -1;               // the texel rows h0_, h1_ hold
  bool lit_ = false, stamped_ = false;  // the current row's (ready_row)
  float fy_ = 0.0f;
  // Scratch rows (3 planes each), fully written before use.
  std::vector<float, DefaultInitAllocator<float>> h0_, h1_, light_;
};

// The flare's light, added to `hdr` when add_base (one task per band of output rows, the light
// of a pixel summed in a fixed order and added last, so hdr + lens_flare_light == lens_flare);
// `then` (if any) on each output row after its last write. own: hdr itself, given up by the
// caller, the output written over it (add_base only): the light is made from hdr before any
// row is written, and each task makes its RowFn before its first write (post/row_pass.h).
ImageF flare(const ImageF& hdr, const FlareSettings& s, const Exec& exec, bool add_base,
             const RowPass& then = {}, ImageF* own = nullptr) {
  const FlareLight fl = make_flare_light(hdr, s, exec);
  const int w = fl.w, h = fl.h;
  // Bands of full-resolution rows that read the same two texel rows (runs of ay): each task
  // upsamples those two rows along x once, then every row of the band is a vertical lerp.
  std::vector<std::pair<int, int>> bands;
  if (fl.low.empty())
    for (int y = 0; y < h; y += 8) bands.push_back({y, std::min(h, y + 8)});
  else
    bands = fl.ay.runs;
  ImageF out = own && add_base ? ImageF() : ImageF::uninitialized(w, h, 3);
  ImageF& dst = own && add_base ? *own : out;
  parallel_rows(exec, int(bands.size()), [&](int band) {
    FlareRowAdder adder(fl);
    // The row pass fused after this one, on a row still in the cache.
    const RowFn fn = then ? then() : RowFn{};
    for (int y = bands[size_t(band)].first; y < bands[size_t(band)].second; ++y)
      for_each_row_piece(w, [&](int x0, int n) {
        const float* const in[3] = {hdr.row(0, y) + x0, hdr.row(1, y) + x0, hdr.row(2, y) + x0};
        float* const o[3] = {dst.row(0, y) + x0, dst.row(1, y) + x0, dst.row(2, y) + x0};
        adder.add(y, x0, n, in, o, add_base, exec);  // o may be in (FlareRowAdder::add)
        if (fn) fn(y, x0, o, n);
      });
  });
  if (own && add_base) return std::move(*own);
  return out;  // moved (a conditional expression would copy it)
}

}  // namespace

std::vector<BrightLight> detect_bright_lights(const ImageF& hdr, float threshold, int max_lights,
                                              const Exec& exec) {
  check_input(hdr);
  if (!(threshold >= 0.0f) || max_lights < 0)
    throw SettingsError(
        fmt::format("flare: threshold {} and max_lights {} must be >= 0", threshold, max_lights));
  const BrightPass bp =
      bright_pass(hdr, BrightRows(hdr.width(), hdr.height(), threshold, 8, false, true), exec);
  return components(bp.rows, max_lights);
}

ImageF lens_flare_light(const ImageF& hdr, const FlareSettings& s, const Exec& exec) {
  return flare(hdr, s, exec, false);
}

ImageF lens_flare(const ImageF& hdr, const FlareSettings& s, const Exec& exec) {
  s.validate();
  check_input(hdr);
  if (!any_intensity(s)) return hdr;
  return flare(hdr, s, exec, true);
}

namespace {
// The FlareLight of a RowPass, made while the pass it is fused into (bloom) works. That pass
// hands over each row of the radiance as it reads it (add_row: the bright pass of the row, while
// it is in the cache, instead of a second read of the frame: ~0.6 ms of the 1080p chain's 2
// threads), then says it is done (rows_done); with more than one thread the rest of the light
// (the bright lights, ghosts at 1 / downsample, their blur, streaks: small loops that leave a
// thread idle at times, as do bloom's mips beside them) is then made in a task of its own.
// Neither reads what the other writes, so the values are the same whatever the interleaving,
// and the same whether or not the rows came (if not all did, the light makes its own bright
// pass). get() (each RowFn's first call) makes the light if no thread has begun to, else waits
// for it. The making runs isolated: a thread waiting in its loops takes none of the caller's
// tasks, which may themselves be waiting in get() (a plain task_group wait had run a bloom task
// that called get() again on the same thread: a hang).
class PendingFlareLight {
 public:
  PendingFlareLight(const ImageF& radiance, const FlareSettings& s, const Exec& exec)
      : radiance_(radiance),
        s_(s),
        exec_(exec),
        rows_(flare_bright_rows(radiance.width(), radiance.height(), s)),
        seen_(size_t(radiance.height())) {}
  PendingFlareLight(const PendingFlareLight&) = delete;
  PendingFlareLight& operator=(const PendingFlareLight&) = delete;
  ~PendingFlareLight() { group_.wait(); }  // the task reads the radiance: finished before
  // Row y of the radiance, from any task (RowPass::input_row); a repeat is ignored.
  void add_row(int y) {
    if (y < 0 || y >= radiance_.height() || seen_[size_t(y)].exchange(1)) return;  // once
    rows_.add_row(radiance_, y, exec_);
    rows_added_.fetch_add(1, std::memory_order_relaxed);
  }
  // After the last add_row (RowPass::input_done), before any get().
  void rows_done() {
    rows_complete_ = rows_added_.load(std::memory_order_relaxed) == radiance_.height();
    if (exec_.threads != 1) group_.run([this] { make(); });
  }
  const FlareLight& get() {
    make();
    for (int st = state_.load(std::memory_order_acquire); st != kDone;
         st = state_.load(std::memory_order_acquire))
      state_.wait(st, std::memory_order_acquire);
    if (error_) std::rethrow_exception(error_);
    return light_;
  }

 private:
  static constexpr int kPending = 0, kMaking = 1, kDone = 2;
  void make() {
    int expected = kPending;
    if (!state_.compare_exchange_strong(expected, kMaking, std::memory_order_acq_rel)) return;
    tbb::this_task_arena::isolate([this] {
      try {
        light_ = make_flare_light(radiance_, s_, exec_, rows_complete_ ? &rows_ : nullptr);
      } catch (...) {
        error_ = std::current_exception();
      }
    });
    state_.store(kDone, std::memory_order_release);
    state_.notify_all();
  }
  const ImageF& radiance_;
  const FlareSettings s_;
  const Exec exec_;
  BrightRows rows_;
  std::vector<std::atomic<uint8_t>> seen_;  // per row: handed over
  std::atomic<int> rows_added_{0};
  bool rows_complete_ = false;
  std::atomic<int> state_{kPending};
  FlareLight light_;
  std::exception_ptr error_;
  tbb::task_group group_;
};

// A task's RowFn adding `fl` to each row (`owner` keeps it alive).
RowFn flare_row_fn(std::shared_ptr<const void> owner, const FlareLight& fl, const Exec& exec) {
  return [owner = std::move(owner), fl = &fl, exec, adder = FlareRowAdder(fl)](
             int y, int x0, float* const* rows, int n) mutable {
    if (y < 0 || y >= fl->h || x0 < 0 || n < 0 || n > fl->w - x0)
      throw InputError(fmt::format("flare: pixels {} .. {} of row {} outside the {}x{} light", x0,
                                   x0 + n - 1, y, fl->w, fl->h));
    adder.add(y, x0, n, rows, rows, true, exec);
  };
}
}  // namespace

RowPass lens_flare_row_pass(const ImageF& radiance, const FlareSettings& s, const Exec& exec) {
  s.validate();
  check_input(radiance);
  if (!any_intensity(s))
    return [] { return RowFn([](int, int, float* const*, int) {}); };  // adds nothing
  auto pending = std::make_shared<PendingFlareLight>(radiance, s, exec);
  RowPass pass([pending, exec]() -> RowFn { return flare_row_fn(pending, pending->get(), exec); });
  pass.input_row = [pending](int y) { pending->add_row(y); };
  pass.input_done = [pending] { pending->rows_done(); };
  return pass;
}

ImageF lens_flare(const ImageF& hdr, const FlareSettings& s, const Exec& exec,
                  const RowPass& then) {
  s.validate();
  check_input(hdr);
  if (!any_intensity(s)) return apply_row_pass(hdr, then, exec);
  return flare(hdr, s, exec, true, then);
}
ImageF lens_flare(ImageF&& hdr, const FlareSettings& s, const Exec& exec, const RowPass& then) {
  s.validate();
  check_input(hdr);
  if (!any_intensity(s)) {
    apply_row_pass_in_place(hdr, then, exec);  // not moved first, as bloom's
    return std::move(hdr);
  }
  return flare(hdr, s, exec, true, then, &hdr);
}

ImageF flare_streaks(const ImageF& bright, int full_height, const FlareSettings& s,
                     const Exec& exec, StreakLayout layout) {
  s.validate();
  check_input(bright);
  return streaks(bright, full_height, s.downsample, s, exec, layout);
}

}  // namespace afterimage::post
