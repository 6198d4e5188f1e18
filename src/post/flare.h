// Lens flare and glare (issue 12; seed 004 "Lens Flare and Bloom"): light that a bright source
// sends through unintended paths of the lens (camera) or of the eye, added to the HDR image.
// The pass finds the bright lights in the frame itself, so it works on any renderer's frames:
//
//   lights     pixels whose max(R, G, B) exceeds `threshold`, grouped into 8-connected
//              components; each gives its energy-weighted centroid L (weight max - threshold),
//              its energy and its size; the `max_lights` brightest are kept.
//   bright B   the hue-keeping bright pass rgb * (max - threshold) / max at 1 / `downsample`
//              per axis (bilinear splat: energy and positions kept): the light that ghosts and
//              streaks spread (ghosts on a coarser grid, 1 / `ghost_downsample`: they are soft).
//   sprites    Y. King, "2D Lens Flare" (Game Programming Gems, 2000; seed 004): per light,
//              the fixed table kFlareSprites of discs, rings and hexagons at C + t (L - C) on
//              the line from L through the screen centre C, shrinking and fading as L moves out.
//   ghosts     Chapman ("Pseudo Lens Flare", 2013): B sampled at the image mirrored through C
//              and scaled about C (ghost i shows B at C + m_i (p - C), m_i = -(1 - i spacing)),
//              each weighted by the fade of the sample's distance to C, plus a halo ring (B
//              sampled a fixed radius from the mirrored point towards C), with a per-channel
//              radial (chromatic) offset as lateral chromatic aberration (a per-channel
//              magnification, red's image outside blue's); blurred by bloom_blur (post/bloom.h).
//   streaks    from every bright pixel, `streak_lines` lines through it (2 rays each) whose
//              light decays exponentially with distance (a recursive filter along each ray).
//   glare      optional, off by default: Spencer, Shirley, Zimmerman, Greenberg, "Physically-
//              Based Glare Effects for Digital Images" (SIGGRAPH 1995) — the eye's lenticular
//              halo (a ring of constant apparent size, red outside, violet inside) and ciliary
//              corona (radial spikes, 1 / r^2 falloff) stamped at each light, scaled by its
//              energy.
//
//   output     hdr + light, light = up(up(blur(ghosts + halo)) + streaks) + sprites + glare;
//              in a pipeline after bloom, bloom's output + the light of bloom's input
//              (lens_flare_row_pass: both are paths of the light entering the lens)
//
// Every intensity is the fraction of the light's energy the component carries (for a light at
// the centre, before the fade), and every size is a fraction of the frame, so the look does not
// depend on the image size. All intensities 0 returns the input exactly. Non-finite pixels (any
// channel) and negative values send no light; the pixel keeps its value plus the flare (a NaN
// stays a NaN at that pixel only). Stateless; bit-identical for any thread count (rows are
// written by one task each; detection sums per run, then merges runs serially in raster order).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/image.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/params.h"
#include "post/row_pass.h"

namespace afterimage::post {

struct FlareSettings {
  // ---- Light detection (sprites, glare) and the bright pass (ghosts, streaks)
  float threshold = 10.0f;  // on max(R, G, B): scene-referred, diffuse white ~ 1
  int max_lights = 4;       // the brightest components that get sprites and glare
  int downsample = 4;       // bright pass and streaks at 1 / downsample per axis
  // Exponent k of the fade (1 - d)^k, d = distance to the centre / half diagonal.
  int falloff = 2;
  // ---- King's sprites
  float sprite_intensity = 0.02f;  // energy fraction of the whole sprite table
  // ---- Chapman's ghosts and halo
  float ghost_intensity = 0.004f;  // energy fraction per ghost
  int ghost_count = 4;
  int ghost_downsample = 8;       // ghosts and halo at 1 / ghost_downsample per axis
  float ghost_spacing = 0.3f;     // ghost i: magnification m_i = -(1 - i spacing) about C
  float halo_intensity = 0.004f;  // energy fraction per halo image (see halo_source)
  float halo_radius = 0.4f;       // of the half diagonal
  float chromatic = 0.02f;        // lateral chromatic aberration (per-channel magnification)
  int ghost_blur = 2;             // bloom_blur levels over the ghost buffer (0 = none)
  // ---- Streaks
  float streak_intensity = 0.01f;  // energy fraction of all rays
  int streak_lines = 2;            // lines through each bright pixel (2 rays each)
  float streak_angle = 0.0f;       // degrees of the first line from +x towards +y (down)
  float streak_length = 0.06f;     // 1/e length of a ray, of the image height
  // ---- Spencer et al. 1995 glare (off by default)
  float glare_intensity = 0.0f;  // energy fraction of halo + corona
  float glare_fov = 45.0f;       // vertical field of view of the image (degrees -> pixels)
  int glare_spikes = 96;         // radial lines of the ciliary corona

  static const ParamTable<FlareSettings>& params();
  void validate() const { params().validate(*this); }
  bool operator==(const FlareSettings&) const = default;
};

// ---------------------------------------------------------------------------------------
// Per-pixel math (pure; unit-tested).

// The fade of an element whose (light or sample) point is a fraction d of the half diagonal
// from the centre: (1 - d)^k, 1 at the centre, 0 at the corners and beyond.
inline float flare_fade(float d, int k) {
  const float u = 1.0f - std::min(std::max(d, 0.0f), 1.0f);
  float r = 1.0f;
  for (int i = 0; i < k; ++i) r *= u;
  return r;
}

// King's falloff law: as the light moves out (d from 0 to 1) each sprite's radius shrinks
// linearly to half, radius(d) = radius0 (1 - d / 2), and its radiance fades by flare_fade(d, k):
// smaller and more transparent outside, larger and more opaque inside (seed 004). A sprite's
// energy is then energy0 * fade(d) * (1 - d/2)^2.
inline float sprite_size_factor(float d) {
  return 1.0f - 0.5f * std::min(std::max(d, 0.0f), 1.0f);
}

// Where a sprite at parameter t of the line from the light L through the centre C sits:
// C + t (L - C) (t = 1 the light, 0 the centre, -1 the light mirrored through the centre).
inline Vec2f sprite_position(Vec2f light, Vec2f center, float t) {
  return center + (light - center) * t;
}

// Chapman's ghost i: the mirrored image (uv' = 1 - uv) scaled towards the centre by
// ghost_vec = (C - p') spacing per ghost, i.e. output pixel p shows the bright pass at
// C + m (p - C) with m = -(1 - i spacing). A light at L then appears at C + (L - C) / m: on the
// line through L and C (opposite side for m < 0), magnified by 1 / |m|.
inline float ghost_magnification(int i, float spacing) {
  return -(1.0f - float(i) * spacing);
}
inline Vec2f ghost_source(Vec2f p, Vec2f center, float m) {
  return center + (p - center) * m;
}

// Chapman's halo: the mirrored point p' = 2C - p moved `radius` pixels towards C (through it
// when closer than that). A light at L then shows on the line through L and C, at |L - C| +
// radius from C on the mirrored side; a light at the centre becomes a ring of that radius.
// With v = p - C at distance r > 0 the source is C + halo_source_scale(r, radius) v (radial,
// like every ghost's C + m v), at |radius - r| from the centre; p' = C itself for r = 0.
// The map is 2-to-1 (r = radius -+ |L - C|): a light closer to the centre than `radius` also
// shows at radius - |L - C| on its own side, and a light at the centre gives the ring's inner
// and outer halves; each image carries halo_intensity of the light (Jacobian |radius - r| / r).
inline float halo_source_scale(float r, float radius) {
  return r > 0.0f ? radius / r - 1.0f : -1.0f;
}
inline Vec2f halo_source(Vec2f p, Vec2f center, float radius) {
  const Vec2f v = p - center;
  return center + v * halo_source_scale(std::sqrt(v.x * v.x + v.y * v.y), radius);
}

// Anti-aliased coverage of the sprite shapes at distance d (or offset dx, dy) from the centre,
// with a one-pixel soft edge.
inline float edge_coverage(float signed_inside) {  // inside distance + 0.5, clamped
  const float c = signed_inside + 0.5f;
  return c < 0.0f ? 0.0f : (c > 1.0f ? 1.0f : c);
}
inline float sprite_disc_coverage(float d, float r) {
  return edge_coverage(r - d);
}
inline float sprite_ring_coverage(float d, float r, float inner) {
  return edge_coverage(r - d) - edge_coverage(inner - d);
}
// Regular hexagon of circumradius r with a vertex on +x (an aperture of six blades): the
// largest projection on the six edge normals against the apothem r cos(30 deg).
inline float sprite_hexagon_coverage(float dx, float dy, float r) {
  const float ax = std::abs(dx), ay = std::abs(dy);
  // Edge normals at 30, 90, 150 degrees (the other three by symmetry).
  const float c30 = 0.86602540378f;
  const float proj = std::max(ay, c30 * ax + 0.5f * ay);
  return edge_coverage(c30 * r - proj);
}

enum class SpriteShape { Disc, Ring, Hexagon };

// Area of a shape of radius r (ring: inner radius kRingInner r), the sprite's energy divisor.
inline constexpr float kRingInner = 0.8f;
inline float sprite_area(SpriteShape shape, float r) {
  switch (shape) {
    case SpriteShape::Disc:
      return float(kPi) * r * r;
    case SpriteShape::Ring:
      return float(kPi) * r * r * (1.0f - kRingInner * kRingInner);
    case SpriteShape::Hexagon:
      return 2.59807621135f * r * r;  // 3 sqrt(3) / 2
  }
  return 1.0f;
}

// King's table: position t on the line C + t (L - C), radius at d = 0 (of the image height),
// shape, share of sprite_intensity (the shares sum to 1) and tint (multiplies the light's
// color).
struct FlareSprite {
  float t;
  float radius;
  SpriteShape shape;
  float share;
  std::array<float, 3> tint;
};
inline constexpr std::array<FlareSprite, 7> kFlareSprites{{
    {0.55f, 0.015f, SpriteShape::Disc, 0.08f, {1.0f, 0.9f, 0.6f}},
    {0.25f, 0.045f, SpriteShape::Ring, 0.14f, {0.6f, 0.8f, 1.0f}},
    {-0.2f, 0.03f, SpriteShape::Hexagon, 0.16f, {0.7f, 1.0f, 0.7f}},
    {-0.45f, 0.05f, SpriteShape::Disc, 0.2f, {0.85f, 0.6f, 1.0f}},
    {-0.7f, 0.022f, SpriteShape::Hexagon, 0.1f, {1.0f, 0.75f, 0.5f}},
    {-1.0f, 0.07f, SpriteShape::Ring, 0.2f, {0.5f, 0.75f, 1.0f}},
    {-1.35f, 0.035f, SpriteShape::Disc, 0.12f, {1.0f, 0.55f, 0.45f}},
}};
// Chapman's lens color per ghost (ghost i uses entry i mod 4) and the halo's.
inline constexpr std::array<std::array<float, 3>, 4> kGhostTints{
    {{1.0f, 0.85f, 0.6f}, {0.6f, 0.9f, 1.0f}, {0.85f, 1.0f, 0.7f}, {1.0f, 0.7f, 0.9f}}};
inline constexpr std::array<float, 3> kHaloTint{0.9f, 0.85f, 1.0f};

// Streak ray decay per step of `step` pixels for a 1/e length of `length` pixels.
inline float streak_decay(float step, float length) {
  return std::exp(-step / length);
}

// Spencer et al. 1995, in degrees of visual angle r: the lenticular halo of wavelength lambda
// (nm) peaks at r = 3 lambda / 568 (red outside, violet inside, the same apparent size for any
// distance of the light) with the profile exp(-19.75 (r - r_peak)^2); the ciliary corona falls
// as 1 / (r + 0.02)^2.
inline double spencer_halo_radius_deg(double lambda_nm) {
  return 3.0 * lambda_nm / 568.0;
}
inline double spencer_halo_profile(double r_deg, double lambda_nm) {
  const double e = r_deg - spencer_halo_radius_deg(lambda_nm);
  return std::exp(-19.75 * e * e);
}
inline double spencer_corona_profile(double r_deg) {
  return 1.0 / ((r_deg + 0.02) * (r_deg + 0.02));
}
// Representative wavelengths of the Rec.709 R, G, B primaries (nm).
inline constexpr std::array<double, 3> kPrimaryWavelengthNm{610.0, 550.0, 465.0};

// ---------------------------------------------------------------------------------------
// Light detection.

struct BrightLight {
  Vec2d position;                 // energy-weighted centroid, pixels (centres at +0.5)
  double energy = 0.0;            // sum of (max(R,G,B) - threshold) over the component
  std::array<double, 3> color{};  // sum of the bright-pass RGB (the light the flare spreads)
  int pixels = 0;                 // component size
};

// The `max_lights` brightest 8-connected components of the pixels whose max channel exceeds
// `threshold` (finite pixels only), by energy, ties by raster order of their first pixel.
// InputError for an empty or non-RGB image.
std::vector<BrightLight> detect_bright_lights(const ImageF& hdr, float threshold, int max_lights,
                                              const Exec& exec = {});

// ---------------------------------------------------------------------------------------
// The pass. SettingsError for settings out of range, InputError for an empty or non-RGB image.

// The light the flare adds (3 planes, the size of hdr).
ImageF lens_flare_light(const ImageF& hdr, const FlareSettings& s, const Exec& exec = {});

// hdr + lens_flare_light(hdr) (bit-identical to that sum); a copy when every intensity is 0.
ImageF lens_flare(const ImageF& hdr, const FlareSettings& s, const Exec& exec = {});
// lens_flare with `then` run on each output row once it is final (post/row_pass.h): the same
// values as then over every row of lens_flare(hdr), without a second pass over the frame.
ImageF lens_flare(const ImageF& hdr, const FlareSettings& s, const Exec& exec, const RowPass& then);
// The same values, written over hdr's planes (the caller gives up hdr; as bloom's overload,
// post/bloom.h): the light is made from hdr before any row is written. `then` may be empty.
ImageF lens_flare(ImageF&& hdr, const FlareSettings& s, const Exec& exec, const RowPass& then);
// The flare of `radiance` as a RowPass (post/row_pass.h) that adds its light to the rows of
// another image of radiance's size: on every row of an image I it gives I + lens_flare_light(
// radiance) bit for bit (a pass that adds nothing when every intensity is 0, as lens_flare).
// The pipeline adds the flare of the radiance before bloom to bloom's rows (DESIGN.md §1).
// SettingsError / InputError as lens_flare; InputError for a row outside radiance's size.
// With more than one thread the light is made in a task of its own while the caller goes on
// (the first RowFn waits for it): `radiance` must outlive the RowPass and its RowFns.
RowPass lens_flare_row_pass(const ImageF& radiance, const FlareSettings& s, const Exec& exec = {});

// The streaks' light at the bright pass's resolution, from its bright plane `bright` (3
// planes, 1 / s.downsample of a frame `full_height` rows high). Straight rays along x may run
// over the transposed plane or row by row (only the rows with light: the default when at most
// a quarter of the rows have any); `layout` forces one, for the tests that the two agree bit
// for bit.
enum class StreakLayout : uint8_t { automatic, transposed, rows };
ImageF flare_streaks(const ImageF& bright, int full_height, const FlareSettings& s,
                     const Exec& exec, StreakLayout layout);

}  // namespace afterimage::post
