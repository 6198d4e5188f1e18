// post/flare: light detection against synthetic blobs of known centroid, the geometry of King's
// sprites and Chapman's ghosts (on the line through the light and the centre, following the
// light across frames) with wrong geometries that the same bounds reject, each component's
// energy, Spencer's halo colors, the identity at intensity 0, the NaN policy, tiny sizes,
// thread-count bit-identity, and `afterimage run --pipeline flare`.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "cli_util.h"
#include "core/error.h"
#include "core/params.h"
#include "io/io.h"
#include "post/bloom.h"
#include "post/flare.h"
#include "test_util.h"

using namespace afterimage;
using namespace afterimage::post;

namespace {

bool bit_equal(const ImageF& a, const ImageF& b) {
  return a.same_shape(b) &&
         std::memcmp(a.data().data(), b.data().data(), a.data().size() * sizeof(float)) == 0;
}

// A dim RGB background with additive Gaussian blobs (peak `peak` at a sub-pixel centre).
struct Blob {
  double x, y, sigma, peak;
};
ImageF blob_image(int w, int h, const std::vector<Blob>& blobs, float background = 0.2f) {
  ImageF img(w, h, 3, background);
  for (const Blob& b : blobs)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const double dx = x + 0.5 - b.x, dy = y + 0.5 - b.y;
        const float v = float(b.peak * std::exp(-0.5 * (dx * dx + dy * dy) / (b.sigma * b.sigma)));
        for (int c = 0; c < 3; ++c) img.at(x, y, c) += v * (c == 2 ? 0.8f : 1.0f);
      }
  return img;
}

// A square light of side 3 centred on pixel (px, py) (centroid at its centre +0.5).
ImageF light_image(int w, int h, int px, int py, float value = 2000.0f) {
  ImageF img(w, h, 3, 0.05f);
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
      for (int c = 0; c < 3; ++c) img.at(px + dx, py + dy, c) = value;
  return img;
}

FlareSettings only(const char* component) {
  FlareSettings s;
  s.sprite_intensity = s.ghost_intensity = s.halo_intensity = s.streak_intensity = 0.0f;
  s.glare_intensity = 0.0f;
  const std::string c = component;
  if (c == "sprites") s.sprite_intensity = 0.02f;
  if (c == "ghosts") s.ghost_intensity = 0.004f;
  if (c == "halo") s.halo_intensity = 0.004f;
  if (c == "streaks") s.streak_intensity = 0.01f;
  if (c == "glare") s.glare_intensity = 0.05f;
  return s;
}

// Where the added light lies relative to the line through `light` and `center`: the
// energy-weighted (sum of channels) mean |perpendicular distance|, the centroid, and the
// centroid's signed position along the line (from the centre towards the light).
struct LineStats {
  double mean_abs_perp = 0, energy = 0, along = 0, perp = 0;
  Vec2d centroid;
};
LineStats line_stats(const ImageF& light, Vec2d L, Vec2d C) {
  const double len = std::hypot(L.x - C.x, L.y - C.y);
  const Vec2d u{(L.x - C.x) / len, (L.y - C.y) / len}, n{-u.y, u.x};
  LineStats st;
  double sx = 0, sy = 0, sp = 0;
  for (int y = 0; y < light.height(); ++y)
    for (int x = 0; x < light.width(); ++x) {
      const double e = double(light.at(x, y, 0)) + light.at(x, y, 1) + light.at(x, y, 2);
      const double px = x + 0.5 - C.x, py = y + 0.5 - C.y;
      st.energy += e;
      sp += e * std::abs(px * n.x + py * n.y);
      sx += e * (x + 0.5);
      sy += e * (y + 0.5);
    }
  st.mean_abs_perp = sp / st.energy;
  st.centroid = {sx / st.energy, sy / st.energy};
  st.along = (st.centroid.x - C.x) * u.x + (st.centroid.y - C.y) * u.y;
  st.perp = (st.centroid.x - C.x) * n.x + (st.centroid.y - C.y) * n.y;
  return st;
}

// The flare light of `img` computed as if the image were padded by `pad` black rows at the top:
// a flare mirrored through the wrong point (C - (0, pad / 2)).
ImageF light_with_wrong_center(const ImageF& img, const FlareSettings& s, int pad) {
  ImageF padded(img.width(), img.height() + pad, 3, 0.0f);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x) padded.at(x, y + pad, c) = img.at(x, y, c);
  const ImageF l = lens_flare_light(padded, s);
  ImageF out(img.width(), img.height(), 3);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x) out.at(x, y, c) = l.at(x, y + pad, c);
  return out;
}

// The light flipped about the horizontal centre line: what an implementation mirroring only x
// (uv' = (1 - u, v)) would add.
ImageF flipped_y(const ImageF& img) {
  ImageF out(img.width(), img.height(), 3);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x) out.at(x, y, c) = img.at(x, img.height() - 1 - y, c);
  return out;
}

// King's sprites of a light at distance d (of the half diagonal) from the centre: the
// energy-weighted mean |perpendicular distance| of their shapes from the line through their
// centres (disc 4r / (3 pi); ring of inner radius 0.8 r: that times (1 - 0.8^3) / (1 - 0.8^2);
// hexagon at most 0.41 r in any direction), for an image of height h.
double sprite_mean_abs_perp(double d, int h) {
  double num = 0, den = 0;
  for (const auto& sp : kFlareSprites) {
    const double e = sp.share * (sp.tint[0] + sp.tint[1] + sp.tint[2]);
    const double r = sp.radius * h * sprite_size_factor(float(d));
    const double k = sp.shape == SpriteShape::Disc ? 4.0 / (3.0 * kPi)
                     : sp.shape == SpriteShape::Ring
                         ? 4.0 / (3.0 * kPi) * (1.0 - 0.512) / (1.0 - 0.64)
                         : 0.41;
    num += e * k * r;
    den += e;
  }
  return num / den;
}

}  // namespace

TEST(Flare, SettingsTable) {
  EXPECT_EQ(aggregate_member_count<FlareSettings>(), FlareSettings::params().size());
  FlareSettings s;
  EXPECT_NO_THROW(s.validate());
  FlareSettings::params().set_assignment(s, "ghost_count=6");
  EXPECT_EQ(s.ghost_count, 6);
  EXPECT_THROW(FlareSettings::params().set_assignment(s, "ghosts=6"), SettingsError);
  EXPECT_THROW(FlareSettings::params().set_assignment(s, "downsample=0"), SettingsError);
  s.glare_fov = 0.0f;
  EXPECT_THROW(lens_flare(ImageF(8, 8, 3, 0.0f), s), SettingsError);
  EXPECT_THROW(lens_flare(ImageF(8, 8, 1, 0.0f), FlareSettings{}), InputError);
  EXPECT_THROW(lens_flare(ImageF(), FlareSettings{}), InputError);
}

TEST(Flare, PureGeometry) {
  const Vec2f C{50.0f, 30.0f}, L{80.0f, 10.0f};
  // t = -1 and ghost 0 (m = -1) are the light mirrored through the centre.
  EXPECT_EQ(sprite_position(L, C, -1.0f), (Vec2f{20.0f, 50.0f}));
  EXPECT_EQ(sprite_position(L, C, 1.0f), L);
  EXPECT_FLOAT_EQ(ghost_magnification(0, 0.3f), -1.0f);
  EXPECT_FLOAT_EQ(ghost_magnification(2, 0.3f), -0.4f);
  EXPECT_EQ(ghost_source(Vec2f{20.0f, 50.0f}, C, -1.0f), L);
  // Ghost m shows L at C + (L - C) / m: there the source is L again.
  const Vec2f g = C + (L - C) * (1.0f / -0.4f), src = ghost_source(g, C, -0.4f);
  EXPECT_NEAR(src.x, L.x, 1e-4);
  EXPECT_NEAR(src.y, L.y, 1e-4);
  // Halo: output at radius |L - C| + R on the mirrored side samples L.
  const float R = 12.0f, d = std::hypot(L.x - C.x, L.y - C.y);
  const Vec2f u{(L.x - C.x) / d, (L.y - C.y) / d};
  const Vec2f p = C - u * (d + R), h = halo_source(p, C, R);
  EXPECT_NEAR(h.x, L.x, 1e-3);
  EXPECT_NEAR(h.y, L.y, 1e-3);
  // King's falloff: full at the centre, gone at the corner; size halves.
  EXPECT_FLOAT_EQ(flare_fade(0.0f, 2), 1.0f);
  EXPECT_FLOAT_EQ(flare_fade(0.5f, 2), 0.25f);
  EXPECT_FLOAT_EQ(flare_fade(0.5f, 0), 1.0f);
  EXPECT_FLOAT_EQ(flare_fade(1.5f, 2), 0.0f);
  EXPECT_FLOAT_EQ(sprite_size_factor(1.0f), 0.5f);
  // Shapes: hexagon of circumradius 10 (vertex on +x): inside at the apothem minus a pixel,
  // outside one pixel past the vertex.
  EXPECT_FLOAT_EQ(sprite_hexagon_coverage(0.0f, 7.66f, 10.0f), 1.0f);
  EXPECT_FLOAT_EQ(sprite_hexagon_coverage(0.0f, 9.67f, 10.0f), 0.0f);
  EXPECT_FLOAT_EQ(sprite_hexagon_coverage(9.0f, 0.0f, 10.0f), 1.0f);
  EXPECT_FLOAT_EQ(sprite_hexagon_coverage(11.0f, 0.0f, 10.0f), 0.0f);
  EXPECT_FLOAT_EQ(sprite_ring_coverage(9.0f, 10.0f, 8.0f), 1.0f);
  EXPECT_FLOAT_EQ(sprite_ring_coverage(5.0f, 10.0f, 8.0f), 0.0f);
  // Sprite shares sum to 1 (sprite_intensity is the table's energy fraction).
  float shares = 0.0f;
  for (const auto& sp : kFlareSprites) shares += sp.share;
  EXPECT_NEAR(shares, 1.0f, 1e-6);
  // Spencer's lenticular halo: red outside, violet inside, ~3 degrees.
  EXPECT_GT(spencer_halo_radius_deg(kPrimaryWavelengthNm[0]),
            spencer_halo_radius_deg(kPrimaryWavelengthNm[1]));
  EXPECT_GT(spencer_halo_radius_deg(kPrimaryWavelengthNm[1]),
            spencer_halo_radius_deg(kPrimaryWavelengthNm[2]));
  EXPECT_NEAR(spencer_halo_radius_deg(568.0), 3.0, 1e-12);
  EXPECT_DOUBLE_EQ(spencer_halo_profile(3.0, 568.0), 1.0);
}

TEST(Flare, DetectsBlobCentroidsToSubPixelAccuracy) {
  const std::vector<Blob> blobs = {
      {20.3, 15.7, 1.5, 300.0}, {61.81, 40.26, 1.0, 120.0}, {80.55, 9.2, 2.0, 40.0}};
  const ImageF img = blob_image(96, 64, blobs);
  const std::vector<BrightLight> lights = detect_bright_lights(img, 10.0f, 8);
  ASSERT_EQ(lights.size(), 3u);
  // Sorted by energy: sum over the pixels above the threshold of (max - threshold), computed
  // here from the image independently.
  double prev = std::numeric_limits<double>::infinity();
  for (const BrightLight& l : lights) {
    EXPECT_LT(l.energy, prev);
    prev = l.energy;
  }
  for (const Blob& b : blobs) {
    const BrightLight* found = nullptr;
    for (const BrightLight& l : lights)
      if (std::hypot(l.position.x - b.x, l.position.y - b.y) < 3.0) found = &l;
    ASSERT_NE(found, nullptr) << b.x << "," << b.y;
    // Sub-pixel: the sampled, thresholded Gaussian is symmetric about its centre.
    EXPECT_NEAR(found->position.x, b.x, 0.03) << b.peak;
    EXPECT_NEAR(found->position.y, b.y, 0.03) << b.peak;
    std::printf("blob (%.2f, %.2f) sigma %.1f: centroid error (%.4f, %.4f) px\n", b.x, b.y, b.sigma,
                found->position.x - b.x, found->position.y - b.y);
    double e = 0;
    int n = 0;
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x) {
        const float m = std::max({img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2)});
        if (m > 10.0f && std::hypot(x + 0.5 - b.x, y + 0.5 - b.y) < 8) e += m - 10.0, ++n;
      }
    EXPECT_NEAR(found->energy, e, 1e-6 * e);
    EXPECT_EQ(found->pixels, n);
  }
  // Keep the N brightest.
  const auto two = detect_bright_lights(img, 10.0f, 2);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two[0].position, lights[0].position);
  EXPECT_EQ(two[1].position, lights[1].position);
  // Deterministic for any thread count.
  const auto one_thread = detect_bright_lights(img, 10.0f, 8, Exec{1});
  for (size_t k = 0; k < lights.size(); ++k) EXPECT_EQ(one_thread[k].position, lights[k].position);
}

TEST(Flare, DetectionIsEightConnectedAndSkipsNonFinite) {
  ImageF img(16, 8, 3, 0.0f);
  auto set = [&](int x, int y, float v) {
    for (int c = 0; c < 3; ++c) img.at(x, y, c) = v;
  };
  // A diagonal chain (one light), then two pixels a gap apart (two lights).
  set(2, 2, 50.0f);
  set(3, 3, 50.0f);
  set(4, 4, 50.0f);
  set(8, 2, 30.0f);
  set(10, 2, 20.0f);
  auto lights = detect_bright_lights(img, 10.0f, 8);
  ASSERT_EQ(lights.size(), 3u);
  EXPECT_EQ(lights[0].pixels, 3);
  EXPECT_NEAR(lights[0].position.x, 3.5, 1e-12);
  EXPECT_NEAR(lights[0].position.y, 3.5, 1e-12);
  // Non-finite pixels are not lights and do not join lights.
  img.at(3, 3, 1) = std::numeric_limits<float>::quiet_NaN();
  set(12, 6, std::numeric_limits<float>::infinity());
  lights = detect_bright_lights(img, 10.0f, 8);
  ASSERT_EQ(lights.size(), 4u);
  for (const auto& l : lights) EXPECT_EQ(l.pixels, 1);
}

TEST(Flare, SpritesAndGhostsLieOnTheLineThroughTheLightAndTheCentre) {
  // A light up left of the centre, placed so that every sprite, ghost and the halo stay inside
  // the frame (a ghost clipped by the border has its centroid off the line, correctly).
  const int w = 256, h = 144;
  const Vec2d C{128.0, 72.0}, L{100.5, 60.5};
  const ImageF img = light_image(w, h, 100, 60);
  const double d = std::hypot(L.x - C.x, L.y - C.y) / std::hypot(C.x, C.y);
  // Bounds on the energy-weighted mean |distance| from the line (px): the elements' own
  // half-widths. Sprites: their shapes' (computed) plus 0.5 px for the anti-aliased edges.
  // Ghosts and halo on a 1/4 grid without blur: the light splatted to 1/4 and interpolated
  // back spans about +-4 px per axis, magnified up to 2.5x (ghost 2, m = -0.4): 6 px. With the
  // defaults (1/8 grid, bloom_blur of 2 levels: widths of 16 and 32 px): 32 px. The centroid:
  // 0.3 px, but 2 px for the defaults, whose blur folds the light that would leave the frame
  // back in near the border (bloom_blur's edge policy; its reach is 24 texels = 192 px).
  FlareSettings ghosts = only("ghosts"), halo = only("halo");
  ghosts.ghost_blur = halo.ghost_blur = 0;
  ghosts.ghost_downsample = halo.ghost_downsample = 4;
  const struct {
    const char* name;
    FlareSettings s;
    double bound, centroid_bound;
  } cases[] = {{"sprites", only("sprites"), sprite_mean_abs_perp(d, h) + 0.5, 0.3},
               {"ghosts", ghosts, 6.0, 0.3},
               {"halo", halo, 6.0, 0.3},
               {"ghosts default", only("ghosts"), 32.0, 2.0},
               {"halo default", only("halo"), 32.0, 2.0}};
  for (const auto& k : cases) {
    const ImageF light = lens_flare_light(img, k.s);
    const LineStats st = line_stats(light, L, C);
    ASSERT_GT(st.energy, 0.0) << k.name;
    EXPECT_LT(st.mean_abs_perp, k.bound) << k.name;
    // The centroid itself is on the line (symmetric elements).
    EXPECT_LT(std::abs(st.perp), k.centroid_bound) << k.name;
    // Wrong implementations fail both: mirroring through a point 20 px off the centre, or
    // mirroring x only. (Not mirroring at all would still be on the line: any scaling about
    // the centre is.)
    const LineStats off = line_stats(light_with_wrong_center(img, k.s, 40), L, C);
    EXPECT_GT(off.mean_abs_perp, k.bound) << k.name;
    EXPECT_GT(std::abs(off.perp), 2.0 * k.centroid_bound) << k.name;
    const LineStats xonly = line_stats(flipped_y(light), L, C);
    EXPECT_GT(xonly.mean_abs_perp, k.bound) << k.name;
    EXPECT_GT(std::abs(xonly.perp), 2.0 * k.centroid_bound) << k.name;
    std::printf(
        "%-15s mean |perp| %.3f px (bound %.2f; wrong centre %.2f, x-only mirror %.2f); "
        "centroid perp %.3f (bound %.2f; wrong %.2f, %.2f)\n",
        k.name, st.mean_abs_perp, k.bound, off.mean_abs_perp, xonly.mean_abs_perp, st.perp,
        k.centroid_bound, off.perp, xonly.perp);
  }
}

TEST(Flare, FlareFollowsTheLightAcrossFrames) {
  const int w = 320, h = 180;
  const Vec2d C{160.0, 90.0};
  // King's table: a sprite's energy is share * tint * fade * size^2 * light, the same factors
  // for every sprite of a light, so the sprites' centroid is at C + t_bar (L - C).
  double num = 0, den = 0;
  for (const auto& sp : kFlareSprites) {
    const double e = sp.share * (sp.tint[0] + sp.tint[1] + sp.tint[2]);
    num += e * sp.t;
    den += e;
  }
  const double t_bar = num / den;
  // Chapman's ghosts (on a 1/4 grid without blur; three of them: the fourth, magnified 10x,
  // is clipped by the frame): every ghost samples the light itself, so all have the same fade and
  // m^2- normalised energy (times its tint); channel c of ghost i shows the light at signed
  // distance rho / (m_i (1 + (c - 1) chromatic)) from the centre along the line.
  FlareSettings gs = only("ghosts");
  gs.ghost_count = 3;
  gs.ghost_blur = 0;
  gs.ghost_downsample = 4;
  for (int k = 0; k < 6; ++k) {
    // The light moves from upper left to lower right of the centre, passing near it.
    const int px = 110 + 20 * k, py = 60 + 9 * k;
    const ImageF img = light_image(w, h, px, py);
    const Vec2d L{px + 0.5, py + 0.5};
    const double rho = std::hypot(L.x - C.x, L.y - C.y);
    const LineStats sp = line_stats(lens_flare_light(img, only("sprites")), L, C);
    const Vec2d predicted{C.x + t_bar * (L.x - C.x), C.y + t_bar * (L.y - C.y)};
    EXPECT_NEAR(sp.centroid.x, predicted.x, 0.15) << k;
    EXPECT_NEAR(sp.centroid.y, predicted.y, 0.15) << k;
    double gnum = 0, gden = 0;
    for (int i = 0; i < gs.ghost_count; ++i)
      for (int c = 0; c < 3; ++c) {
        const double tint = kGhostTints[size_t(i)][size_t(c)];
        gnum += tint * rho /
                (ghost_magnification(i, gs.ghost_spacing) * (1.0 + (c - 1) * gs.chromatic));
        gden += tint;
      }
    const LineStats gh = line_stats(lens_flare_light(img, gs), L, C);
    EXPECT_LT(std::abs(gh.perp), 0.2) << k;
    // Up to the fade's variation across each magnified ghost's footprint (pulls it inwards).
    EXPECT_NEAR(gh.along, gnum / gden, 0.6) << k;
    // Streaks: centred on the light (symmetric rays).
    const LineStats sk = line_stats(lens_flare_light(img, only("streaks")), L, C);
    EXPECT_NEAR(sk.centroid.x, L.x, 0.1) << k;
    EXPECT_NEAR(sk.centroid.y, L.y, 0.1) << k;
    std::printf(
        "frame %d light (%.1f, %.1f): sprites centroid (%.2f, %.2f) predicted (%.2f, "
        "%.2f); ghosts perp %.3f along %.2f predicted %.2f; streaks (%.2f, %.2f)\n",
        k, L.x, L.y, sp.centroid.x, sp.centroid.y, predicted.x, predicted.y, gh.perp, gh.along,
        gnum / gden, sk.centroid.x, sk.centroid.y);
  }
}

TEST(Flare, ComponentEnergies) {
  // A light at the centre (fade 1, size 1) and one channel-neutral color: each component's
  // added energy is its intensity times the light's (the bright pass's) energy.
  const int w = 320, h = 180;
  const ImageF img = light_image(w, h, 160, 90, 1000.0f);
  const double bright = 9.0 * (1000.0 - 10.0) * 3.0;  // sum over channels of the bright pass
  double tint = 0;
  for (const auto& sp : kFlareSprites)
    tint += sp.share * (sp.tint[0] + sp.tint[1] + sp.tint[2]) / 3.0;
  // The light's centroid is the pixel centre (160.5, 90.5), d ~ 0.004 of the half diagonal.
  const double d = std::hypot(0.5, 0.5) / std::hypot(160.0, 90.0);
  const double sprite_factor = std::pow(1 - d, 2.0) * std::pow(1 - d / 2, 2.0);
  const LineStats sprites =
      line_stats(lens_flare_light(img, only("sprites")), {0.0, 0.0}, {160.0, 90.0});
  EXPECT_NEAR(sprites.energy, 0.02 * tint * sprite_factor * bright, 0.02 * 0.02 * tint * bright);
  // Ghosts: each carries ghost_intensity of the light times its tint (m^2 normalisation; the
  // fade is 1 at the centre, ~0.94 over the 10x magnified fourth ghost), and the blur conserves
  // energy. The halo (Jacobian normalisation): a light inside the halo radius has two images,
  // here the ring's inner and outer halves, each carrying halo_intensity, up to the fade of
  // the source's distance to the centre over the light's extent and the sampling of a ring a
  // few pixels wide on the 1/8 grid (a few percent).
  const FlareSettings gs = only("ghosts");
  double ghost_tint = 0;
  for (int i = 0; i < gs.ghost_count; ++i)
    for (int c = 0; c < 3; ++c) ghost_tint += kGhostTints[size_t(i)][size_t(c)] / 3.0;
  const LineStats ghosts = line_stats(lens_flare_light(img, gs), {0.0, 0.0}, {160.0, 90.0});
  EXPECT_NEAR(ghosts.energy, 0.004 * ghost_tint * bright, 0.03 * 0.004 * ghost_tint * bright);
  const double halo_tint = (kHaloTint[0] + kHaloTint[1] + kHaloTint[2]) / 3.0;
  const LineStats halo = line_stats(lens_flare_light(img, only("halo")), {0.0, 0.0}, {160.0, 90.0});
  EXPECT_NEAR(halo.energy, 2.0 * 0.004 * halo_tint * bright,
              0.05 * 2.0 * 0.004 * halo_tint * bright);
  const LineStats streaks =
      line_stats(lens_flare_light(img, only("streaks")), {0.0, 0.0}, {160.0, 90.0});
  EXPECT_NEAR(streaks.energy, 0.01 * bright, 0.03 * 0.01 * bright);
  FlareSettings g = only("glare");
  const ImageF glare = lens_flare_light(img, g);
  const LineStats gl = line_stats(glare, {0.0, 0.0}, {160.0, 90.0});
  EXPECT_NEAR(gl.energy, 0.05 * bright, 1e-4 * 0.05 * bright);
  // Spencer's halo: the red ring is outside the blue one. Mean radius of each channel's light
  // between 1.5 and 5 degrees from the light (the halo's band; the corona is grey).
  const double ppd = h / g.glare_fov;
  double mr[3] = {0, 0, 0}, me[3] = {0, 0, 0};
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const double r = std::hypot(x + 0.5 - 160.5, y + 0.5 - 90.5) / ppd;
        if (r < 1.5 || r > 5.0) continue;
        mr[c] += r * glare.at(x, y, c);
        me[c] += glare.at(x, y, c);
      }
  EXPECT_GT(mr[0] / me[0], mr[1] / me[1] + 0.05);
  EXPECT_GT(mr[1] / me[1], mr[2] / me[2] + 0.05);
  std::printf(
      "energies: sprites %.1f (expected %.1f), ghosts %.1f (%.1f), halo %.1f (%.1f), streaks "
      "%.1f (%.1f), glare %.1f (%.1f); halo band mean radius R %.2f G %.2f B %.2f deg\n",
      sprites.energy, 0.02 * tint * sprite_factor * bright, ghosts.energy,
      0.004 * ghost_tint * bright, halo.energy, 2 * 0.004 * halo_tint * bright, streaks.energy,
      0.01 * bright, gl.energy, 0.05 * bright, mr[0] / me[0], mr[1] / me[1], mr[2] / me[2]);
}

TEST(Flare, ZeroIntensityIsTheIdentityAndNonFinitePixelsSendNoLight) {
  ImageF img = light_image(96, 54, 30, 20);
  img.at(5, 5, 1) = std::numeric_limits<float>::quiet_NaN();
  FlareSettings off = only("none");
  EXPECT_TRUE(bit_equal(lens_flare(img, off), img));
  // The default pass is exactly hdr + its light.
  const ImageF light = lens_flare_light(img, FlareSettings{});
  const ImageF out = lens_flare(img, FlareSettings{});
  ImageF sum = img;
  for (size_t i = 0; i < sum.data().size(); ++i) sum.data()[i] += light.data()[i];
  EXPECT_TRUE(bit_equal(out, sum));
  // A NaN or infinite pixel inside the light sends nothing: the light equals that of the
  // image with the pixel at 0; only that pixel of the output is non-finite.
  FlareSettings all;
  all.glare_intensity = 0.05f;
  ImageF a = light_image(96, 54, 30, 20), b = a;
  a.at(30, 20, 0) = std::numeric_limits<float>::quiet_NaN();
  a.at(31, 21, 2) = std::numeric_limits<float>::infinity();
  for (int c = 0; c < 3; ++c) b.at(30, 20, c) = b.at(31, 21, c) = 0.0f;
  EXPECT_TRUE(bit_equal(lens_flare_light(a, all), lens_flare_light(b, all)));
  const ImageF oa = lens_flare(a, all);
  int non_finite = 0;
  for (float v : oa.data()) non_finite += !std::isfinite(v);
  EXPECT_EQ(non_finite, 2);
  EXPECT_TRUE(std::isnan(oa.at(30, 20, 0)));
}

TEST(Flare, TinyAndOddSizesAndExtremeSettings) {
  FlareSettings s;
  s.glare_intensity = 0.05f;
  for (const auto& [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {3, 2}, {17, 5}, {5, 31}}) {
    ImageF img(w, h, 3, 0.1f);
    for (int c = 0; c < 3; ++c) img.at(w / 2, h / 2, c) = 500.0f;
    for (int f : {1, 3, 16})
      for (int g : {1, 5, 32}) {
        s.downsample = f;
        s.ghost_downsample = g;
        const ImageF out = lens_flare(img, s);
        ASSERT_TRUE(out.same_shape(img));
        for (float v : out.data()) ASSERT_TRUE(std::isfinite(v)) << w << "x" << h << " " << f;
        EXPECT_GT(out.at(w / 2, h / 2, 0), 500.0f);  // a light adds to itself (streaks, glare)
      }
  }
  // Nothing above the threshold: nothing added (bit-exact, default settings).
  ImageF dim = test::random_image(40, 30, 3, 3, 0.0f, 4.0f);
  EXPECT_TRUE(bit_equal(lens_flare(dim, FlareSettings{}), dim));
}

TEST(Flare, BitIdenticalForAnyThreadCountAndSimdFlag) {
  // An odd width: lane blocks and 1-lane tails in every row loop (the composite, the bright
  // pass's scan, the streak columns); rays along both axes (angle 17, three lines).
  // Also the default lines (0 and 90 degrees): straight rays, marched in bands of 64 columns
  // of the 1/4 grid, so that image is wide and tall enough for several bands each way.
  for (const bool straight : {false, true}) {
    const ImageF img =
        straight ? blob_image(603, 317, {{120.3, 90.1, 1.2, 800.0}, {450.7, 240.2, 2.0, 300.0}})
                 : blob_image(203, 117, {{40.3, 30.1, 1.2, 800.0}, {150.7, 80.2, 2.0, 300.0}});
    FlareSettings s;
    s.glare_intensity = 0.05f;
    if (!straight) {
      s.streak_lines = 3;
      s.streak_angle = 17.0f;
    }
    const ImageF one = lens_flare(img, s, test::scalar_exec());
    for (int threads : {0, 1, 2, 3}) {
      Exec ex;
      ex.threads = threads;
      EXPECT_TRUE(bit_equal(lens_flare(img, s, ex), one)) << threads << " straight " << straight;
    }
  }
}

TEST(Flare, StraightStreaksMatchANearlyStraightAngle) {
  // Lines at 0 and 90 degrees march each column alone in bands (add_streak_ray's straight
  // path); at 1e-4 degrees the rays take the general path, whose lerp weight is then ~2e-6
  // off the column: the two lights agree to that order, so a straight path that read the
  // wrong column, skipped a band or lost a ray would show far above it.
  // Lights on the bands' edge columns (1/4 grid x = 63 and y = 63, the transposed layout's).
  const ImageF img = blob_image(603, 317, {{254.2, 100.3, 1.2, 800.0}, {450.7, 254.6, 2.0, 300.0}});
  FlareSettings straight = only("streaks"), near = only("streaks");
  near.streak_angle = 1e-4f;
  const ImageF a = lens_flare_light(img, straight), b = lens_flare_light(img, near);
  double most = 0.0, diff = 0.0;
  for (size_t i = 0; i < a.data().size(); ++i) {
    most = std::max(most, double(a.data()[i]));
    diff = std::max(diff, std::abs(double(a.data()[i]) - double(b.data()[i])));
  }
  std::printf("streaks: max %.4g, max |straight - 1e-4 deg| %.3g\n", most, diff);
  EXPECT_GT(most, 0.0);
  EXPECT_LT(diff, 1e-4 * most);
}

TEST(Flare, StreaksAreTheSameByRowsAndTransposed) {
  // Straight rays along x run row by row where few rows have light, else over the transposed
  // plane (flare_streaks): bit for bit the same, with light in the first and last rows and
  // columns (the marches' ends), few lit rows and most rows lit, both directions of both lines.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> value(1.0f, 50.0f);
  std::uniform_int_distribution<int> column(0, 96);
  for (const bool most_lit : {false, true}) {
    ImageF bright(97, 41, 3, 0.0f);
    const auto light = [&](int x, int y) {
      for (int c = 0; c < 3; ++c) bright.at(x, y, c) = value(rng);
    };
    for (const auto& [x, y] : std::vector<std::pair<int, int>>{
             {0, 0}, {96, 0}, {0, 40}, {96, 40}, {48, 20}, {30, 7}, {31, 7}})
      light(x, y);
    if (most_lit)
      for (int y = 1; y < 40; ++y) light(column(rng), y);
    for (const float angle : {0.0f, 90.0f, 180.0f}) {
      FlareSettings s;
      s.streak_angle = angle;
      const ImageF rows = flare_streaks(bright, 164, s, {}, StreakLayout::rows);
      const ImageF transposed = flare_streaks(bright, 164, s, {}, StreakLayout::transposed);
      EXPECT_TRUE(bit_equal(rows, transposed)) << "angle " << angle << " most lit " << most_lit;
      EXPECT_TRUE(bit_equal(flare_streaks(bright, 164, s, {}, StreakLayout::automatic), rows));
      // The light of the corner texel (0, 0) reaches 10 texels along its row and its column.
      EXPECT_GT(rows.at(10, 0, 0), 0.0f) << angle;
      EXPECT_GT(rows.at(0, 10, 0), 0.0f) << angle;
    }
  }
}

TEST(FlareCli, RunPipelineFlareMatchesThePassAppliedByHand) {
  namespace fs = std::filesystem;
  const fs::path dir = test::fresh_temp_dir("flare_cli");
  const std::string in = (dir / "in").string();
  ASSERT_EQ(test::run("render --scene sparkle --frames 2 --size 64x36 --out " + in).code, 0);
  auto r = test::run("run --in " + in + " --out " + (dir / "flare").string() +
                     " --pipeline flare --set flare.threshold=5 --set flare.glare_intensity=0.05");
  ASSERT_EQ(r.code, 0) << r.err;
  FlareSettings s;
  s.threshold = 5.0f;
  s.glare_intensity = 0.05f;
  for (int k = 0; k < 2; ++k) {
    const Frame src = io::read_frame(io::frame_path(in, k));
    const Frame out = io::read_frame(io::frame_path((dir / "flare").string(), k));
    EXPECT_TRUE(bit_equal(out.color, lens_flare(src.color, s))) << k;
    EXPECT_FALSE(bit_equal(out.color, src.color)) << k;  // the scene's light flares
  }
  // After bloom, the flare's light is of bloom's input (the radiance entering the lens), added
  // to bloom's output.
  r = test::run("run --in " + in + " --out " + (dir / "bloom_flare").string() +
                " --pipeline bloom,flare --set flare.threshold=5");
  ASSERT_EQ(r.code, 0) << r.err;
  for (int k = 0; k < 2; ++k) {
    const Frame src = io::read_frame(io::frame_path(in, k));
    const Frame out = io::read_frame(io::frame_path((dir / "bloom_flare").string(), k));
    FlareSettings t;
    t.threshold = 5.0f;
    const ImageF bloomed = bloom(src.color, BloomSettings{});
    EXPECT_TRUE(
        bit_equal(out.color, apply_row_pass(bloomed, lens_flare_row_pass(src.color, t), {})))
        << k;
    EXPECT_FALSE(bit_equal(out.color, lens_flare(bloomed, t))) << k;
  }
  r = test::run("run --in " + in + " --out " + (dir / "chain").string() +
                " --pipeline tonemap,flare,bloom,taa --set flare.ghost_count=2");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("bloom,flare,tonemap"), std::string::npos) << r.out;
  const std::string base = "run --in " + in + " --out " + (dir / "bad").string();
  test::expect_one_line_error(test::run(base + " --pipeline flare --set flare.ghosts=2"), "ghosts");
  test::expect_one_line_error(test::run(base + " --pipeline flare --set flare.downsample=0"),
                              "downsample");
  EXPECT_FALSE(fs::exists(dir / "bad"));
}
