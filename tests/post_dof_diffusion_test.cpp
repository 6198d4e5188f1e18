// Depth of field by simulated diffusion (issue 12; Kass, Lefohn, Owens 2006): the line solver
// against a dense solve, and the properties of the heat equation the pass must keep — a
// constant image and an in-focus image are unchanged, the sum (energy) is conserved, a point
// spreads with the variance the CoC asks for (growing with it), and an in-focus pixel is an
// insulator (no blur crosses it; the near layer is what lets a near blur spread over it).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "camera/camera.h"
#include "core/error.h"
#include "post/dof.h"
#include "post/dof_diffusion.h"

namespace afterimage {
namespace {

using post::DofMode;
using post::DofSettings;

// 50 mm on a 36 mm sensor, f/2 focused at 3 m by default (as tests/post_dof_test.cpp).
ThinLens lens(double f_number = 2.0, double focus = 3.0) {
  ThinLens l;
  l.focal_length_mm = 50.0;
  l.f_number = f_number;
  l.focus_distance = focus;
  return l;
}

DofSettings diffusion() {
  DofSettings s;
  s.mode = DofMode::diffusion;
  return s;
}

Frame frame(int w, int h, float depth) {
  Frame f = Frame::allocate(w, h);
  f.lens = lens();
  for (float& d : f.depth.data()) d = depth;
  return f;
}

// The depth behind the focus plane of `l` whose CoC radius is r pixels on an image w wide.
double depth_for_radius(const ThinLens& l, double r, int w) {
  double lo = l.focus_distance, hi = 1e6;
  for (int i = 0; i < 200; ++i) {
    const double mid = std::sqrt(lo * hi);
    (0.5 * circle_of_confusion_px(l, mid, w) < r ? lo : hi) = mid;
  }
  return lo;
}

double plane_sum(const ImageF& im, int c) {
  double s = 0;
  for (int y = 0; y < im.height(); ++y)
    for (int x = 0; x < im.width(); ++x) s += im.at(x, y, c);
  return s;
}

TEST(PostDofDiffusion, LineSolveMatchesADenseSolve) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int n = 23;
  std::vector<double> g(n), x(n), y(n), scratch(2 * n);
  for (int i = 0; i < n; ++i) {
    g[size_t(i)] = i % 5 == 2 ? 0.0 : 30.0 * u(rng) * u(rng);
    x[size_t(i)] = u(rng);
  }
  post::solve_heat_line(g.data(), x.data(), y.data(), n, scratch.data());
  // Dense matrix of the same system, solved by Gaussian elimination with partial pivoting.
  std::vector<std::vector<double>> a(n, std::vector<double>(n + 1, 0.0));
  for (int i = 0; i < n; ++i) {
    const double gl = i > 0 ? g[size_t(i - 1)] : 0.0, gr = i + 1 < n ? g[size_t(i)] : 0.0;
    a[i][i] = 1.0 + gl + gr;
    if (i > 0) a[i][i - 1] = -gl;
    if (i + 1 < n) a[i][i + 1] = -gr;
    a[i][n] = x[size_t(i)];
  }
  for (int c = 0; c < n; ++c) {
    int p = c;
    for (int r = c + 1; r < n; ++r)
      if (std::abs(a[r][c]) > std::abs(a[p][c])) p = r;
    std::swap(a[c], a[p]);
    for (int r = 0; r < n; ++r) {
      if (r == c) continue;
      const double f = a[r][c] / a[c][c];
      for (int k = c; k <= n; ++k) a[r][k] -= f * a[c][k];
    }
  }
  double sum_x = 0, sum_y = 0;
  for (int i = 0; i < n; ++i) {
    EXPECT_NEAR(y[size_t(i)], a[i][n] / a[i][i], 1e-12) << i;
    sum_x += x[size_t(i)];
    sum_y += y[size_t(i)];
  }
  EXPECT_NEAR(sum_y, sum_x, 1e-12);  // columns sum to 1: energy conserved
  // In place (y aliasing x) gives the same.
  std::vector<double> z = x;
  post::solve_heat_line(g.data(), z.data(), z.data(), n, scratch.data());
  for (int i = 0; i < n; ++i) EXPECT_DOUBLE_EQ(z[size_t(i)], y[size_t(i)]);
}

TEST(PostDofDiffusion, SettingsAndConductivity) {
  DofSettings s;
  s.set_assignment("mode=diffusion");
  EXPECT_EQ(s.mode, DofMode::diffusion);
  EXPECT_THROW(s.set_assignment("mode=scatter"), SettingsError);
  EXPECT_THROW(s.set_assignment("diffusion_steps=0"), SettingsError);
  EXPECT_FLOAT_EQ(post::diffusion_conductivity(0.49f, 1.0f), 0.0f);  // focus field: insulator
  EXPECT_FLOAT_EQ(post::diffusion_conductivity(4.0f, 1.0f), 2.0f);   // r^2 / 8
  EXPECT_FLOAT_EQ(post::pair_conductance(0.0f, 5.0f), 0.0f);
  EXPECT_FLOAT_EQ(post::pair_conductance(3.0f, 5.0f), 3.0f);
}

// Depths in front of and behind the focus plane, the focus plane itself, and sky.
Frame mixed_depths(int w, int h) {
  Frame f = frame(w, h, 3.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int k = (x / 11 + 2 * (y / 7)) % 5;
      f.depth.at(x, y, 0) = k == 0 ? 1.2f : k == 1 ? 3.0f : k == 2 ? 8.0f : k == 3 ? 40.0f : 1e10f;
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = float((x * 3 + y * 5 + c) % 9) * 0.25f;
    }
  f.lens.f_number = 1.0;
  return f;
}

TEST(PostDofDiffusion, ConstantAndInFocusImagesAreUnchanged) {
  Frame f = mixed_depths(83, 47);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x)
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = 0.3f + 0.2f * c;
  for (const bool near_layer : {false, true}) {
    DofSettings s = diffusion();
    s.diffusion_near_layer = near_layer;
    const ImageF out = post::depth_of_field(f, f.color, s);
    for (int c = 0; c < 3; ++c)
      for (int y = 0; y < f.height; ++y)
        for (int x = 0; x < f.width; ++x)
          ASSERT_NEAR(out.at(x, y, c), 0.3f + 0.2f * c, 2e-6f) << x << "," << y;
  }
  // Everything on the focus plane, a textured image: returned exactly.
  Frame g = frame(64, 32, 3.0f);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 64; ++x) g.color.at(x, y, 1) = float((x * 5 + y) % 7);
  EXPECT_EQ(post::depth_of_field(g, g.color, diffusion()), g.color);
}

TEST(PostDofDiffusion, EnergyIsConserved) {
  // Far field only (no near layer involved): the sum of every channel is kept.
  Frame f = frame(96, 64, 3.0f);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 4.0f);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      f.depth.at(x, y, 0) = (x / 16 + y / 16) % 3 == 0 ? 3.0f : (x / 16) % 2 ? 9.0f : 60.0f;
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = u(rng);
    }
  for (const int steps : {1, 3}) {
    DofSettings s = diffusion();
    s.diffusion_steps = steps;
    const ImageF out = post::depth_of_field(f, f.color, s);
    EXPECT_NE(out, f.color);
    for (int c = 0; c < 3; ++c) {
      const double a = plane_sum(f.color, c), b = plane_sum(out, c);
      EXPECT_NEAR(b / a, 1.0, 1e-6) << "steps " << steps << " channel " << c;
    }
  }
}

// A single bright pixel in a region of one CoC radius r: its spread along x has the variance
// r^2 / 4 of the thin lens's disc (the variance match of dof_diffusion.h), so its width grows
// with the CoC; more implicit steps keep the variance and reduce the tails.
TEST(PostDofDiffusion, APointSpreadsWithTheWidthOfItsCoc) {
  const int w = 320, h = 160, cx = 160, cy = 80;
  const ThinLens l = lens(1.0, 1.0);  // f/1 focused at 1 m: up to 11.7 px of CoC radius
  double last_var = 0;
  for (const double r : {2.0, 4.0, 8.0}) {
    Frame f = frame(w, h, float(depth_for_radius(l, r, w)));
    f.lens = l;
    const double radius = 0.5 * circle_of_confusion_px(l, f.depth.at(0, 0, 0), w);
    ASSERT_NEAR(radius, r, 1e-3);
    f.color.at(cx, cy, 0) = 1000.0f;
    for (const int steps : {1, 4}) {
      DofSettings s = diffusion();
      s.diffusion_steps = steps;
      const ImageF out = post::depth_of_field(f, f.color, s);
      double m0 = 0, m2x = 0, m2y = 0, tail = 0;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const double v = out.at(x, y, 0);
          m0 += v;
          m2x += v * (x - cx) * (x - cx);
          m2y += v * (y - cy) * (y - cy);
          if (std::hypot(x - cx, y - cy) > 2 * r) tail += v;
        }
      const double var_x = m2x / m0, var_y = m2y / m0;
      std::printf(
          "r %.0f px, %d step(s): variance x %.3f y %.3f (disc r^2/4 = %.3f), beyond 2r %.3f\n", r,
          steps, var_x, var_y, r * r / 4, tail / m0);
      EXPECT_NEAR(m0, 1000.0, 1e-2);
      EXPECT_NEAR(var_x, r * r / 4, 0.01 * r * r / 4) << r;
      EXPECT_NEAR(var_y, r * r / 4, 0.01 * r * r / 4) << r;
      if (steps == 1) {
        EXPECT_GT(var_x, 3.5 * last_var);  // width grows with the CoC
        last_var = var_x;
      }
    }
  }
}

// Left half on the focus plane, right half far behind (blurred): not a bit of the right's
// blur crosses into the left, and the right keeps its energy. A near plane on the left over
// in-focus stripes on the right: only the near layer spreads it over them.
TEST(PostDofDiffusion, AnInFocusEdgeIsAnInsulator) {
  const int w = 320, h = 32;
  Frame f = frame(w, h, 3.0f);
  f.lens.f_number = 1.0;  // 30 m: CoC radius 3.4 px
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.depth.at(x, y, 0) = x < w / 2 ? 3.0f : 30.0f;
      f.color.at(x, y, 0) = x < w / 2 ? 0.1f : float((x / 3) % 2) * 5.0f;
      f.color.at(x, y, 1) = x < w / 2 ? 0.7f : 0.2f;
    }
  DofSettings one_step = diffusion();
  one_step.diffusion_steps = 1;  // the paper's single step
  const ImageF out = post::depth_of_field(f, f.color, one_step);
  double in_right = 0, out_right = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (x < w / 2) {
        ASSERT_EQ(out.at(x, y, 0), f.color.at(x, y, 0)) << x << "," << y;
        ASSERT_EQ(out.at(x, y, 1), f.color.at(x, y, 1)) << x << "," << y;
      } else {
        in_right += f.color.at(x, y, 0);
        out_right += out.at(x, y, 0);
      }
    }
  EXPECT_NEAR(out_right / in_right, 1.0, 1e-6);
  // The stripes (contrast 5) are blurred: measured 1.6 (the single implicit step keeps more of
  // a 6 px period than a disc of radius 3.4 would).
  EXPECT_LT(std::abs(out.at(240, 16, 0) - out.at(243, 16, 0)), 2.0f);

  Frame g = frame(w, h, 3.0f);  // f/2
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool left = x < w / 2;
      g.depth.at(x, y, 0) = left ? 1.0f : 3.0f;  // near plane: CoC radius 3.75 px
      g.color.at(x, y, 0) = left ? 1.0f : 0.2f + 0.2f * float((x / 3) % 2);
      g.color.at(x, y, 1) = left ? 0.0f : g.color.at(x, y, 0);
    }
  DofSettings one_layer = diffusion();
  one_layer.diffusion_near_layer = false;
  const ImageF sharp = post::depth_of_field(g, g.color, one_layer);
  for (int x = w / 2; x < w; ++x) ASSERT_EQ(sharp.at(x, 16, 1), g.color.at(x, 16, 1)) << x;
  DofSettings two_layers = diffusion();
  two_layers.diffusion_near_layer = true;
  const ImageF layered = post::depth_of_field(g, g.color, two_layers);
  EXPECT_GT(layered.at(w / 2 + 1, 16, 0) - layered.at(w / 2 + 1, 16, 1), 0.1f);
  EXPECT_EQ(layered.at(w - 5, 16, 1), g.color.at(w - 5, 16, 1));  // beyond its reach: sharp
  // Deterministic for any thread count (both layers).
  const Frame m = mixed_depths(97, 61);
  EXPECT_EQ(post::depth_of_field(m, m.color, two_layers, Exec{1}),
            post::depth_of_field(m, m.color, two_layers, Exec{2}));
  EXPECT_EQ(post::depth_of_field(m, m.color, diffusion(), Exec{1}),
            post::depth_of_field(m, m.color, diffusion(), Exec{2}));
}

}  // namespace
}  // namespace afterimage
