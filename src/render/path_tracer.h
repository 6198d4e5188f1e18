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

// A re-traced pixel: the noisy frame's channels at that sample (same meanings as above).
struct PathPixel {
  Vec3f color, emission, albedo, diffuse, specular, direct, indirect;
  float depth = 0.0f;
  Vec3f normal;
  uint32_t id = 0;
};

}  // namespace afterimage::render
