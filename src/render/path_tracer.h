// Path-traced frames: the noisy input of SVGF and its converged reference (issue 11, "Noisy
// input and its truth"). SceneRenderer renders them when RenderSettings::path_trace is set;
// this header holds the settings and the types of sample re-tracing.
//
// Integrator: unidirectional path tracing with next-event estimation at every scattering
// vertex (one light chosen uniformly among the lights on at the frame's time) and BSDF
// sampling of the continuation, combined by multiple importance sampling with the power
// heuristic (Veach 1997 ch. 9) for area lights (quad, sphere; also hit by BSDF rays through
// their analytic shape); point and directional lights are delta lights (light sampling only);
// emissive meshes that are no light and the sky are found by BSDF rays only. Russian roulette
// (survival = the path throughput's largest component, at most 1) from vertex rr_start on.
// BSDF: the scene's Lambert + normalised Blinn-Phong (shading.h brdf_cos); `Scene::ambient`
// is not used (the paths compute the indirect light it stands in for).
//
// Channels of a noisy frame (SceneRenderer::gbuffer with path_trace set), per pixel, from the
// primary ray through the G-buffer's jittered position (i + 0.5 + jitter.x, j + 0.5 +
// jitter.y), shared by the pixel's spp_per_frame samples:
//   color     = emission + albedo * diffuse + specular   (compose_shading, per channel)
//             = emission + direct + indirect
//   emission  the primary hit's emitted radiance (the sky's radiance where the ray misses)
//   albedo    the primary hit's diffuse albedo, texture included (0 on the sky)
//   diffuse   demodulated: the diffuse lobe's estimate divided by nothing but the albedo
//             (sum of (cos / pi) / pdf * L_i over the pixel's samples, averaged)
//   specular  the glossy lobe's radiance, not demodulated
//   direct    light reflected once (at the primary hit) toward the camera
//   indirect  light reflected two or more times
//   depth, normal, id, motion (and motion_next if asked): exactly gbuffer()'s primary hit
//   roughness material_roughness of the primary hit (0 on the sky)
//   depth_gradient  dZ/dx, dZ/dy: the linear depth change over one pixel to the right / down
//             of the primary hit's tangent plane (ray differentials; 0 on the sky; a plane
//             seen edge-on gives at most the depth itself)
// A reference frame (SceneRenderer::reference with path_trace set) averages `spp` paths over
// the pixel's box (positions from the sampler's pixel pair), with emission, direct and
// indirect averaged too (color = emission + direct + indirect); its G-buffer channels are the
// pixel-center sample's, like render_reference's.
//
// Gradient samples (RenderSettings::gradients; Schied, Peters, Dachsbacher, "Gradient
// Estimation for Real-Time Adaptive Temporal Filtering", HPG 2018, Sec. 3). For frame f > 0
// following noisy frame f - 1 (no camera cut):
//   1. per 3x3 stratum of frame f - 1 one pixel, gradient_stratum_pick (a pure hash of seed,
//      frame, stratum; pixels that already hold a re-traced sample are skipped);
//   2. its sample position (x + 0.5 + jitter) is forward-projected with frame f - 1's
//      motion_next; it lands in pixel floor(position) of frame f;
//   3. at most one sample per 3x3 stratum of frame f: among those landing in it, the one of
//      smallest gradient_priority;
//   4. it is re-traced in frame f at that position with frame f - 1's random numbers
//      (RetraceRequest key_frame = f - 1), and accepted if its primary hit is the original
//      surface (same id, normals within gradient_normal_cos, depth within gradient_depth_rel);
//   5. the landing pixel of an accepted sample stores
//        gradient = (lum(re-traced) - lum(original in f - 1), max of the two, 1);
//      every other pixel stores (0, 0, 0). With RenderSettings::gradient_replace (the paper)
//      the sample also REPLACES the landing pixel's sample in frame f (color, emission, albedo,
//      diffuse, specular, direct, indirect; the G-buffer stays the pixel's own; still 1 sample
//      per pixel and unbiased, but a copy of last frame's sample: measured worse, off by
//      default), and such pixels are not picked again in the next frame.
// On a static scene the re-traced sample is the original bit for bit (delta exactly 0). The
// cost is one extra primary ray and path per stratum (about 1/9 more rays).
#pragma once

#include <cstdint>
#include <string>

#include "core/math.h"
#include "core/params.h"

namespace afterimage::render {

struct PathTraceSettings {
  // Scattering events per path: 1 = direct light only (light reflected once), 4 = light
  // reflected up to four times.
  int bounces = 4;
  // Samples per pixel of a noisy frame, averaged (all through the frame's jittered primary
  // ray); references take their own count.
  int spp_per_frame = 1;
  // First scattering vertex (0 = the primary hit) after which Russian roulette may end a path.
  int rr_start = 2;

  static const ParamTable<PathTraceSettings>& params();
  void set_assignment(const std::string& assignment);
  void validate() const;  // SettingsError
  bool operator==(const PathTraceSettings&) const = default;
};

// The random numbers of noisy-frame sample k of pixel (x, y) of frame `frame`, dimension `dim`
// (PathDims): a pure function of its arguments (path_sampling.h sobol_pair).
double path_random(uint64_t seed, int frame, int x, int y, int k, int dim, int spp_per_frame = 1);

// One sample re-traced in another frame (A-SVGF's gradient samples): the primary ray goes
// through pixel-space `position` of the frame being traced, and every random number is that
// of noisy frame `key_frame`'s pixel (key_x, key_y) (all spp_per_frame of its samples).
// position = the key pixel's jittered position and key_frame = the traced frame reproduce
// that frame's pixel bit for bit.
struct RetraceRequest {
  Vec2d position;
  int key_frame = 0, key_x = 0, key_y = 0;
};

// Gradient samples (see above): which pixel of 3x3 stratum (sx, sy) of frame `frame` is
// forward-projected (0..8, row-major in the stratum), and the priority of that stratum's
// sample when several land in one stratum of the next frame (smallest wins). Pure functions.
int gradient_stratum_pick(uint64_t seed, int frame, int sx, int sy);
uint64_t gradient_priority(uint64_t seed, int frame, int sx, int sy);
inline constexpr int kGradientStratum = 3;
inline constexpr float kGradientNormalCos = 0.9f;  // same surface: dot(n_prev, n) >= this
inline constexpr float kGradientDepthRel = 0.05f;  // and |d - d_prev| <= this * d_prev

// A re-traced pixel: the noisy frame's channels at that sample (same meanings as above).
struct PathPixel {
  Vec3f color, emission, albedo, diffuse, specular, direct, indirect;
  float depth = 0.0f;
  Vec3f normal;
  uint32_t id = 0;
};

}  // namespace afterimage::render
