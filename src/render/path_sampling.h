// Pure per-sample functions of the path tracer (path_tracer.h): its random numbers, BSDF
// sampling and light sampling with their densities, multiple importance sampling weights and
// the ray / light intersections. Header-only so tests can call every formula directly.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/math.h"
#include "render/scene.h"
#include "render/shading.h"

namespace afterimage::render {

// ---- Random numbers: Owen-scrambled Sobol pairs, padded by shuffling ----------------------
// Every number is a pure function of (sequence seed, sample index, dimension): a sample can be
// re-traced exactly from its key (A-SVGF, Schied et al. 2018, re-traces the previous frame's
// samples). Dimensions come in pairs; each pair is the 2D Sobol (0, 2)-sequence, Owen
// scrambled per pair, with the sample index itself Owen scrambled per pair ("shuffled") so the
// pairs are decorrelated (Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4)). The
// first 2^m indices of every pair, and every aligned block of 2^m, form a (0, m, 2)-net: one
// point in each of the 2^m elementary intervals of any shape, hence stratified references and
// a per-pixel stratification over consecutive frames of the noisy sequence.

inline uint32_t reverse_bits32(uint32_t x) {
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
  x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
  return (x >> 16) | (x << 16);
}

// The two Sobol dimensions as 32-bit fixed point: the van der Corput radical inverse, and the
// second dimension, whose generator matrix is Pascal's triangle mod 2 (direction numbers
// v_1 = 1/2, v_{k+1} = v_k xor v_k / 2). The second is linear over GF(2) in the index bits, so
// it is four lookups of 256-entry tables, one per index byte (a loop over 32 bits costs a fifth
// of a path otherwise: shuffled indices use every bit).
inline uint32_t sobol_dim0(uint32_t i) {
  return reverse_bits32(i);
}
struct SobolDim1Tables {
  uint32_t t[4][256];
};
constexpr SobolDim1Tables make_sobol_dim1_tables() {
  uint32_t v[32] = {};
  v[0] = 0x80000000u;
  for (int k = 1; k < 32; ++k) v[k] = v[k - 1] ^ (v[k - 1] >> 1);
  SobolDim1Tables r{};
  for (int b = 0; b < 4; ++b)
    for (uint32_t x = 0; x < 256; ++x) {
      uint32_t acc = 0;
      for (int i = 0; i < 8; ++i)
        if ((x >> i) & 1u) acc ^= v[8 * b + i];
      r.t[b][x] = acc;
    }
  return r;
}
inline constexpr SobolDim1Tables kSobolDim1 = make_sobol_dim1_tables();
inline uint32_t sobol_dim1(uint32_t i) {
  return kSobolDim1.t[0][i & 255u] ^ kSobolDim1.t[1][(i >> 8) & 255u] ^
         kSobolDim1.t[2][(i >> 16) & 255u] ^ kSobolDim1.t[3][i >> 24];
}

// Nested uniform (Owen) scrambling of a 32-bit fixed-point number: every bit is flipped by a
// hash of the bits above it. On the bit-reversed value, "above" becomes "below", which
// multiplications by even constants, adding the seed and multiplying by an odd number all
// respect (Laine & Karras 2011; the constants are Vegdahl's improved hash, as Burley 2020 §4
// recommends).
inline uint32_t owen_scramble(uint32_t x, uint32_t seed) {
  x = reverse_bits32(x);
  x ^= x * 0x3d20adeau;
  x += seed;
  x *= (seed >> 16) | 1u;
  x ^= x * 0x05526c56u;
  x ^= x * 0x53a22864u;
  return reverse_bits32(x);
}

// The 2D point of pair `pair` for sample `index` of the sequence `seq`: coordinates in [0, 1).
// Three scramble seeds per (sequence, pair): the index shuffle and one per coordinate.
inline Vec2d sobol_pair(uint64_t seq, uint32_t index, uint32_t pair) {
  const uint64_t h = mix64(seq ^ (uint64_t(pair) + 1) * 0x9e3779b97f4a7c15ULL), h2 = mix64(h);
  const uint32_t j = owen_scramble(index, uint32_t(h));  // shuffle
  const uint32_t a = owen_scramble(sobol_dim0(j), uint32_t(h >> 32));
  const uint32_t b = owen_scramble(sobol_dim1(j), uint32_t(h2));
  return {double(a) * 0x1.0p-32, double(b) * 0x1.0p-32};
}

// Which sequence a pixel's samples come from. Noisy frames: one sequence per pixel, indexed by
// frame * spp_per_frame + k, so consecutive frames of a pixel are stratified against each
// other. References: one sequence per (frame stream, pixel), indexed by the sample number.
// The domains keep the two independent for one seed.
enum class SampleDomain : uint64_t { Noisy = 0x6e6f697379ULL, Reference = 0x726566ULL };
inline uint64_t sequence_seed(uint64_t seed, SampleDomain domain, int stream, int x, int y) {
  uint64_t k = mix64(seed ^ uint64_t(domain));
  k = mix64(k ^ uint64_t(uint32_t(stream)));
  return mix64(k ^ (uint64_t(uint32_t(y)) << 32 | uint32_t(x)));
}

// One path's random numbers: dimension d is coordinate d % 2 of pair d / 2.
struct PathRandom {
  uint64_t seq = 0;
  uint32_t index = 0;
  Vec2d pair(uint32_t p) const { return sobol_pair(seq, index, p); }
  double dim(uint32_t d) const {
    const Vec2d v = pair(d / 2);
    return d % 2 == 0 ? v.x : v.y;
  }
};

// Dimension layout of a path: pair 0 is the position in the pixel (references only; noisy
// frames take the G-buffer's jittered position), then four pairs per scattering vertex
// b = 0, 1, ... (0 = the primary hit).
struct PathDims {
  static constexpr uint32_t kPixel = 0;
  static uint32_t light_uv(int b) { return 1 + 4 * uint32_t(b); }
  static uint32_t bsdf_uv(int b) { return 2 + 4 * uint32_t(b); }
  static uint32_t selects(int b) { return 3 + 4 * uint32_t(b); }   // (light choice, lobe choice)
  static uint32_t roulette(int b) { return 4 + 4 * uint32_t(b); }  // x: Russian roulette
};

// ---- BSDF: Lambert + normalised Blinn-Phong (shading.h brdf_cos) ---------------------------

// Orthonormal tangents of unit w (Duff et al. 2017, "Building an orthonormal basis, revisited").
inline void orthonormal_basis(Vec3d w, Vec3d* t1, Vec3d* t2) {
  const double sign = std::copysign(1.0, w.z);
  const double a = -1.0 / (sign + w.z), b = w.x * w.y * a;
  *t1 = {1.0 + sign * w.x * w.x * a, sign * b, -sign * w.x};
  *t2 = {b, sign + w.y * w.y * a, -w.y};
}

// Direction of polar angle acos(cos_t) and azimuth phi around unit w.
inline Vec3d around(Vec3d w, double cos_t, double phi) {
  Vec3d t1, t2;
  orthonormal_basis(w, &t1, &t2);
  const double sin_t = std::sqrt(std::max(0.0, 1.0 - cos_t * cos_t));
  return normalize(t1 * (sin_t * std::cos(phi)) + t2 * (sin_t * std::sin(phi)) + w * cos_t);
}

// The material's BSDF at a hit: shading normal n and view direction v (both unit, facing the
// viewer), diffuse albedo, Blinn-Phong ks and exponent.
struct Bsdf {
  Vec3d n, v, albedo;
  double ks = 0.0, shininess = 1.0;
  // Probability of sampling the glossy lobe: its weight ks against the diffuse albedo's
  // luminance (each lobe's reflectance, roughly), so dark glossy surfaces sample mostly the
  // highlight and matte ones never do.
  double specular_probability() const {
    const double kd = 0.2126 * albedo.x + 0.7152 * albedo.y + 0.0722 * albedo.z;
    return ks > 0.0 ? ks / (ks + std::max(kd, 0.0)) : 0.0;
  }
  bool black() const { return ks <= 0.0 && albedo.x <= 0.0 && albedo.y <= 0.0 && albedo.z <= 0.0; }
};

// Density (solid angle) of the Blinn-Phong lobe's sampling: half vectors h with density
// (s + 1) / (2 pi) (n.h)^s about n, reflected: p(l) = p(h) / (4 v.h) (PBRT-v3 14.1.1).
inline double blinn_phong_pdf(const Bsdf& f, Vec3d l) {
  const Vec3d hs = f.v + l;
  const double len = length(hs);
  if (!(len > 0.0)) return 0.0;
  const Vec3d h = hs / len;
  const double nh = dot(f.n, h), vh = dot(f.v, h);
  if (nh <= 0.0 || vh <= 0.0) return 0.0;
  return (f.shininess + 1.0) / (2.0 * kPi) * std::pow(nh, f.shininess) / (4.0 * vh);
}

// Density (solid angle) of sampling direction l from the lobe mixture sample_bsdf draws from.
inline double bsdf_pdf(const Bsdf& f, Vec3d l) {
  const double ps = f.specular_probability();
  const double nl = dot(f.n, l);
  const double diffuse = nl > 0.0 ? nl / kPi : 0.0;
  return (1.0 - ps) * diffuse + (ps > 0.0 ? ps * blinn_phong_pdf(f, l) : 0.0);
}

// Draws a direction: with probability specular_probability() a Blinn-Phong half vector
// (cos theta_h = u^(1 / (s + 1))) reflected about it, else a cosine-weighted direction about
// n (Malley's method). `choose` picks the lobe, `u` the direction. The result may lie below
// the surface (its BSDF is 0 there); the caller checks.
inline Vec3d sample_bsdf(const Bsdf& f, double choose, Vec2d u) {
  const double phi = 2.0 * kPi * u.y;
  if (choose < f.specular_probability()) {
    const Vec3d h = around(f.n, std::pow(u.x, 1.0 / (f.shininess + 1.0)), phi);
    return normalize(h * (2.0 * dot(f.v, h)) - f.v);
  }
  return around(f.n, std::sqrt(1.0 - u.x), phi);
}

// ---- Lights ------------------------------------------------------------------------------

// Multiple importance sampling, power heuristic with beta = 2 (Veach 1997, 9.2.4), one
// sample from each of two strategies: the weight of the strategy whose density is `a`.
inline double power_heuristic(double a, double b) {
  const double a2 = a * a, b2 = b * b;
  return a2 > 0.0 ? a2 / (a2 + b2) : 0.0;
}

// One light sample for next-event estimation: direction, shadow-ray length, the radiance
// arriving along it (irradiance for delta lights) and its density in solid angle (1 for delta
// lights, which only light sampling can find).
struct LightDirSample {
  Vec3d dir;
  double distance = 0.0;
  Vec3d radiance{0.0};
  double pdf = 0.0;
  bool delta = false;
};

// Samples light `l` from point p with u in [0, 1)^2. Quad: uniform in area, density
// d^2 / (A cos theta_l) in solid angle; sphere: uniform in the cone it subtends, density
// 1 / Omega (shading.h sample_light); point / directional: delta. False when nothing arrives
// (p behind a quad, inside a sphere).
inline bool sample_light_dir(const Light& l, Vec3d p, Vec2d u, LightDirSample* s) {
  if (l.type == LightType::Quad) {
    const Vec3d q = l.position + l.edge_u * (u.x - 0.5) + l.edge_v * (u.y - 0.5);
    const Vec3d d = q - p, nq = cross(l.edge_u, l.edge_v);
    const double dist = length(d), area = length(nq);
    if (!(dist > 0.0)) return false;
    const Vec3d w = d / dist;
    const double cos_l = -dot(w, nq) / area;
    if (cos_l <= 0.0) return false;  // behind the emitting side
    // The shadow ray stops short of the light's own mesh.
    *s = {w, dist * (1.0 - 1e-4), to_double(l.color), dist * dist / (area * cos_l), false};
    return std::isfinite(s->pdf);
  }
  LightSample ls;
  if (!sample_light(l, p, u, false, &ls)) return false;
  s->dir = ls.dir;
  s->distance = ls.distance;
  if (l.type == LightType::Sphere) {
    // ls.weight = L Omega; the density is 1 / Omega, the same expression intersect_light uses.
    const double dist = length(l.position - p);
    const double sin2 = (l.radius * l.radius) / (dist * dist);
    const double omega = 2.0 * kPi * (1.0 - std::sqrt(std::max(0.0, 1.0 - sin2)));
    if (!(omega > 0.0)) return false;
    s->radiance = to_double(l.color);
    s->pdf = 1.0 / omega;
    s->delta = false;
    return true;
  }
  s->radiance = ls.weight;  // point, directional: irradiance
  s->pdf = 1.0;
  s->delta = true;
  return true;
}

// Where a ray meets an area light (sphere, quad): distance along the unit direction, the
// radiance leaving toward the ray's origin (0 from a quad's back), and the density with which
// sample_light_dir would have chosen that direction from the origin.
struct LightHit {
  double t = 0.0;
  Vec3d radiance{0.0};
  double pdf = 0.0;
};

// Ray (origin o, unit direction d) against area light l, hits with t in (0, tmax). A sphere
// light is seen from outside only (rays from inside it are not lit by it).
inline bool intersect_light(const Light& l, Vec3d o, Vec3d d, double tmax, LightHit* hit) {
  if (l.type == LightType::Sphere) {
    const Vec3d oc = o - l.position;
    const double b = dot(oc, d), c = dot(oc, oc) - l.radius * l.radius;
    if (c <= 0.0) return false;  // inside
    const double disc = b * b - c;
    if (disc < 0.0) return false;
    const double t = -b - std::sqrt(disc);
    if (!(t > 0.0 && t < tmax)) return false;
    const double dist = std::sqrt(dot(oc, oc));
    const double sin2 = (l.radius * l.radius) / (dist * dist);
    const double omega = 2.0 * kPi * (1.0 - std::sqrt(std::max(0.0, 1.0 - sin2)));
    *hit = {t, to_double(l.color), omega > 0.0 ? 1.0 / omega : 0.0};
    return true;
  }
  if (l.type == LightType::Quad) {
    const Vec3d nq = cross(l.edge_u, l.edge_v);
    const double area = length(nq), dn = dot(d, nq);
    if (dn == 0.0) return false;
    const double t = dot(l.position - o, nq) / dn;
    if (!(t > 0.0 && t < tmax)) return false;
    // Coordinates of the hit in the edge basis (the edges need not be orthogonal).
    const Vec3d q = o + d * t - l.position;
    const double uu = dot(l.edge_u, l.edge_u), uv = dot(l.edge_u, l.edge_v),
                 vv = dot(l.edge_v, l.edge_v);
    const double qu = dot(q, l.edge_u), qv = dot(q, l.edge_v), det = uu * vv - uv * uv;
    const double a = (qu * vv - qv * uv) / det, b = (qv * uu - qu * uv) / det;
    if (std::abs(a) > 0.5 || std::abs(b) > 0.5) return false;
    const double cos_l = -dn / area;
    if (cos_l <= 0.0) {  // the back: blocks the ray, emits nothing
      *hit = {t, Vec3d(0.0), 0.0};
      return true;
    }
    *hit = {t, to_double(l.color), t * t / (area * cos_l)};
    return true;
  }
  return false;
}

// ---- G-buffer extras of a path-traced frame ----------------------------------------------

// Roughness in [0, 1] of a material's glossy lobe: Blinn-Phong exponent s matches a Beckmann
// slope alpha = sqrt(2 / (s + 2)) (Walter et al. 2007, 5.2), and perceptual roughness is
// sqrt(alpha) (alpha = roughness^2, Burley 2012). A material without a glossy lobe is 1.
inline float material_roughness(const Material& m) {
  if (!(m.specular > 0.0f)) return 1.0f;
  return float(std::sqrt(std::sqrt(2.0 / (double(m.shininess) + 2.0))));
}

}  // namespace afterimage::render
