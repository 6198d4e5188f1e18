// Path-traced noisy frames, references and re-traced samples (path_tracer.h).
#include "render/path_tracer.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "core/color.h"
#include "core/error.h"
#include "render/accel.h"
#include "render/frame_context.h"
#include "render/path_sampling.h"
#include "render/renderer.h"

namespace afterimage::render {

const ParamTable<PathTraceSettings>& PathTraceSettings::params() {
  static const ParamTable<PathTraceSettings> kTable = [] {  // immutable once built
    using S = PathTraceSettings;
    ParamTable<S> t("path_trace");
    t.add_int("bounces", &S::bounces, 1, 64,
              "scattering events per path (1 = direct light only, reflected once)");
    t.add_int("spp_per_frame", &S::spp_per_frame, 1, 4096,
              "samples per pixel of a noisy frame, through its jittered primary ray");
    t.add_int("rr_start", &S::rr_start, 0, 64,
              "first scattering vertex (0 = primary hit) after which Russian roulette may "
              "end a path");
    return t;
  }();
  return kTable;
}
void PathTraceSettings::set_assignment(const std::string& assignment) {
  params().set_assignment(*this, assignment);
}
void PathTraceSettings::validate() const {
  params().validate(*this);
}

namespace {

// Index of noisy-frame sample k of `frame` in its pixel's sequence.
uint32_t noisy_index(int frame, int k, int spp_per_frame) {
  return uint32_t(frame) * uint32_t(spp_per_frame) + uint32_t(k);
}

}  // namespace

double path_random(uint64_t seed, int frame, int x, int y, int k, int dim, int spp_per_frame) {
  const PathRandom r{sequence_seed(seed, SampleDomain::Noisy, 0, x, y),
                     noisy_index(frame, k, spp_per_frame)};
  return r.dim(uint32_t(dim));
}

namespace {

// SplitMix64's finaliser (Steele, Lea, Flood 2014): a well-mixed 64-bit hash step.
uint64_t mix64(uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

uint64_t stratum_hash(uint64_t seed, int frame, int sx, int sy, uint64_t salt) {
  uint64_t h = mix64(seed ^ salt);
  h = mix64(h ^ uint64_t(uint32_t(frame)));
  return mix64(h ^ (uint64_t(uint32_t(sx)) << 32 | uint64_t(uint32_t(sy))));
}

}  // namespace

int gradient_stratum_pick(uint64_t seed, int frame, int sx, int sy) {
  return int(stratum_hash(seed, frame, sx, sy, 0x6772616450696B65ull) % 9u);
}

uint64_t gradient_priority(uint64_t seed, int frame, int sx, int sy) {
  return stratum_hash(seed, frame, sx, sy, 0x6772616450726F69ull);
}

namespace {

using namespace detail;

// Light reflected toward the viewer at a scattering vertex, per BSDF lobe: `diffuse` is
// demodulated (the albedo not applied), `specular` is radiance.
struct LobeLight {
  Vec3d diffuse{0.0}, specular{0.0};
};

// What one path brings to its pixel beyond the primary hit's emission.
struct PathResult {
  LobeLight lobes;                   // at the primary hit
  Vec3d direct{0.0}, indirect{0.0};  // reflected once / two or more times
};

// Radiance arriving along a ray leaving a scattering vertex: `emitted` by what the ray hits
// (MIS-weighted on area lights), `further` reflected there and beyond.
struct Incoming {
  Vec3d emitted{0.0}, further{0.0};
};

Bsdf bsdf_at(const Surface& s) {
  return {s.n, s.v, s.albedo, double(s.material->specular), double(s.material->shininess)};
}

Vec3d lobe_sum(const Vec3d& albedo, const LobeLight& l) {
  return albedo * l.diffuse + l.specular;
}

// Next-event estimation at a vertex: one light chosen uniformly, one sample of it, the shadow
// ray, MIS against the BSDF's density of the same direction (delta lights: weight 1).
// `sel` is the vertex's selects pair (x: the light).
LobeLight next_event(const FrameContext& fc, const Surface& s, const Bsdf& f, Vec3d origin,
                     const PathRandom& rnd, int vertex, Vec2d sel, RayCounts& counts) {
  const size_t n = fc.lights.size();
  if (n == 0) return {};
  const size_t i = std::min(size_t(sel.x * double(n)), n - 1);
  LightDirSample ls;
  if (!sample_light_dir(fc.lights[i], origin, rnd.pair(PathDims::light_uv(vertex)), &ls)) return {};
  if (dot(ls.dir, s.ng) <= 0.0) return {};  // below the surface
  const BrdfCosSplit b = brdf_cos_split(f.ks, f.shininess, f.n, f.v, ls.dir);
  if (b.diffuse <= 0.0 && b.specular <= 0.0) return {};
  if (ls.radiance.x <= 0.0 && ls.radiance.y <= 0.0 && ls.radiance.z <= 0.0) return {};
  ++counts.shadow;
  if (fc.accel->occluded(origin, ls.dir, 0.0, ls.distance)) return {};
  const double pl = ls.pdf / double(n);
  const double w = ls.delta ? 1.0 : power_heuristic(pl, bsdf_pdf(f, ls.dir));
  const Vec3d l = ls.radiance * (w / pl);
  return {l * b.diffuse, l * b.specular};
}

// A BSDF-sampled continuation from a vertex: direction, its density and the lobes' weights
// (cos / pi) / pdf and specular * cos / pdf. False when the sample carries nothing.
struct Continuation {
  Vec3d dir;
  double pdf = 0.0, diffuse = 0.0, specular = 0.0;
};
// `sel` is the vertex's selects pair (y: the lobe).
bool continue_path(const Surface& s, const Bsdf& f, const PathRandom& rnd, int vertex, Vec2d sel,
                   Continuation* c) {
  c->dir = sample_bsdf(f, sel.y, rnd.pair(PathDims::bsdf_uv(vertex)));
  if (dot(c->dir, s.ng) <= 0.0) return false;  // below the surface
  const BrdfCosSplit b = brdf_cos_split(f.ks, f.shininess, f.n, f.v, c->dir);
  c->pdf = bsdf_pdf(f, c->dir);
  if (!(c->pdf > 0.0) || (b.diffuse <= 0.0 && b.specular <= 0.0)) return false;
  c->diffuse = b.diffuse / c->pdf;
  c->specular = b.specular / c->pdf;
  return true;
}

// Radiance arriving at `o` from direction d, sampled by the BSDF of the previous vertex with
// density prev_pdf; `vertex` is the index of the vertex the ray will hit (>= 1).
Incoming trace_incoming(const FrameContext& fc, const PathTraceSettings& pt, Vec3d o, Vec3d d,
                        double prev_pdf, const PathRandom& rnd, int vertex, RayCounts& counts) {
  Incoming in;
  Vec3d beta(1.0);
  const double n_lights = double(fc.lights.size());
  for (int b = vertex;; ++b) {
    Vec3d& sink = b == vertex ? in.emitted : in.further;
    ++counts.bounce;
    const Hit h = fc.accel->intersect(o, d, 0.0, 1e30);
    // Area lights are hit through their analytic shapes, before the scene's meshes (their
    // visible meshes lie inside the sphere / on the quad): that is the shape light sampling
    // draws from, so the two strategies' densities agree.
    const double tmax = h.hit ? double(h.t) * (1.0 + 1e-4) : 1e30;
    LightHit best;
    bool lit = false;
    for (const Light& l : fc.lights) {
      LightHit lh;
      if (intersect_light(l, o, d, lit ? best.t : tmax, &lh)) {
        best = lh;
        lit = true;
      }
    }
    if (lit) {
      sink += beta * best.radiance * power_heuristic(prev_pdf, best.pdf / n_lights);
      break;
    }
    if (!h.hit) {  // sky: found by BSDF sampling only
      sink += beta * to_double(sky_radiance(fc.scene->sky, d));
      break;
    }
    const Surface s = surface_at_hit(fc, o, d, h);
    sink += beta * s.emission;  // emissive meshes that are no light: BSDF sampling only
    if (b >= pt.bounces) break;
    const Bsdf f = bsdf_at(s);
    if (f.black()) break;
    const Vec3d origin = offset_origin(s.p, s.ng);
    const Vec2d sel = rnd.pair(PathDims::selects(b));
    in.further += beta * lobe_sum(s.albedo, next_event(fc, s, f, origin, rnd, b, sel, counts));
    Continuation c;
    if (!continue_path(s, f, rnd, b, sel, &c)) break;
    beta = beta * (s.albedo * c.diffuse + Vec3d(c.specular));
    if (b >= pt.rr_start) {
      // Russian roulette (PBRT-v3 14.5.1): survive with q = the throughput's largest
      // component, and divide by q so the estimate stays unbiased.
      const double q = std::min(1.0, std::max({beta.x, beta.y, beta.z}));
      if (!(rnd.pair(PathDims::roulette(b)).x < q)) break;
      beta = beta / q;
    }
    o = origin;
    d = c.dir;
    prev_pdf = c.pdf;
  }
  return in;
}

// One path from a primary hit: NEE and one continuation at the primary vertex, split by lobe
// (the demodulated channels) and by the number of reflections (direct / indirect).
PathResult trace_from_primary(const FrameContext& fc, const PathTraceSettings& pt,
                              const Surface& prim, const PathRandom& rnd, RayCounts& counts) {
  PathResult r;
  if (!prim.hit) return r;
  const Bsdf f = bsdf_at(prim);
  if (f.black()) return r;
  const Vec3d origin = offset_origin(prim.p, prim.ng);
  const Vec2d sel = rnd.pair(PathDims::selects(0));
  const LobeLight nee = next_event(fc, prim, f, origin, rnd, 0, sel, counts);
  r.lobes = nee;
  r.direct = lobe_sum(prim.albedo, nee);
  Continuation c;
  if (!continue_path(prim, f, rnd, 0, sel, &c)) return r;
  const Incoming in = trace_incoming(fc, pt, origin, c.dir, c.pdf, rnd, 1, counts);
  const Vec3d total = in.emitted + in.further;
  r.lobes.diffuse += total * c.diffuse;
  r.lobes.specular += total * c.specular;
  const Vec3d weight = prim.albedo * c.diffuse + Vec3d(c.specular);
  r.direct += weight * in.emitted;
  r.indirect += weight * in.further;
  return r;
}

// Radiance the camera sees at the primary hit itself: the emission, or the sky.
Vec3d primary_emission(const Surface& s) {
  return s.hit ? s.emission : s.base;
}

// The noisy estimate through pixel-space position `pos` with the random numbers of noisy
// frame key_frame's pixel (key_x, key_y). `g` / `surf` receive the primary hit.
PathPixel shade_pixel(const FrameContext& fc, const PathTraceSettings& pt, uint64_t seed, Vec2d pos,
                      int key_frame, int key_x, int key_y, RayCounts& counts, Sample* g,
                      Surface* surf) {
  *g = trace_surface_ray(fc, camera_ray(fc.inv_vp, pos, fc.width, fc.height), 0.0, counts, *surf);
  const uint64_t seq = sequence_seed(seed, SampleDomain::Noisy, 0, key_x, key_y);
  PathResult sum;
  for (int k = 0; k < pt.spp_per_frame; ++k) {
    const PathRandom rnd{seq, noisy_index(key_frame, k, pt.spp_per_frame)};
    const PathResult r = trace_from_primary(fc, pt, *surf, rnd, counts);
    sum.lobes.diffuse += r.lobes.diffuse;
    sum.lobes.specular += r.lobes.specular;
    sum.direct += r.direct;
    sum.indirect += r.indirect;
  }
  const double inv = 1.0 / pt.spp_per_frame;
  const Vec3d emission = primary_emission(*surf), albedo = surf->hit ? surf->albedo : Vec3d(0.0);
  const Vec3d diffuse = sum.lobes.diffuse * inv, specular = sum.lobes.specular * inv;
  PathPixel p;
  p.color = to_float(compose_shading(emission, albedo, diffuse, specular));
  p.emission = to_float(emission);
  p.albedo = to_float(albedo);
  p.diffuse = to_float(diffuse);
  p.specular = to_float(specular);
  p.direct = to_float(sum.direct * inv);
  p.indirect = to_float(sum.indirect * inv);
  p.depth = g->depth;
  p.normal = g->normal;
  p.id = g->id;
  return p;
}

// Screen-space depth gradient of a primary hit: the linear depth where the rays through
// pos + (1, 0) and pos + (0, 1) meet the hit's tangent plane, minus the hit's depth. Edge-on
// planes (the neighbouring ray misses the plane, or the change exceeds the depth itself) are
// capped at the depth.
Vec2d depth_gradient(const FrameContext& fc, Vec2d pos, const Surface& s, double depth) {
  if (!s.hit) return {0.0, 0.0};
  double g[2];
  for (int a = 0; a < 2; ++a) {
    const Ray r = camera_ray(fc.inv_vp, {pos.x + (a == 0), pos.y + (a == 1)}, fc.width, fc.height);
    const double denom = dot(r.dir, s.ng);
    const double t = denom < 0.0 ? dot(s.p - r.origin, s.ng) / denom : -1.0;
    g[a] = depth;
    if (t > 0.0 && std::isfinite(t)) {
      const double dz = -(fc.view.transform_point(r.origin + r.dir * t)).z - depth;
      g[a] = std::clamp(dz, -depth, depth);
    }
  }
  return {g[0], g[1]};
}

void set3(ImageF& img, int x, int y, const Vec3f& v) {
  for (int c = 0; c < 3; ++c) img.at(x, y, c) = v[c];
}

}  // namespace

Frame SceneRenderer::path_traced(int frame_index, RenderStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  const PathTraceSettings& pt = *settings_.path_trace;
  Frame f;
  const FrameContext fc = setup_frame(scene_, *accel_, frame_index, settings_, f);
  f.jitter = settings_.jitter.at(frame_index);
  for (Channel c : {Channel::emission, Channel::diffuse, Channel::specular, Channel::direct,
                    Channel::indirect, Channel::depth_gradient, Channel::roughness})
    f.allocate_channel(c);
  const Vec2d j = f.jitter;
  const RenderSettings& rs = settings_;
  RenderStats st = run_rows(exec_, rs.height, rs.progress, [&](int y, RayCounts& c) {
    for (int x = 0; x < rs.width; ++x) {
      const Vec2d pos{x + 0.5 + j.x, y + 0.5 + j.y};
      Sample g;
      Surface surf;
      const PathPixel p = shade_pixel(fc, pt, rs.seed, pos, frame_index, x, y, c, &g, &surf);
      store(f, x, y, g, to_double(p.color));
      set3(f.emission, x, y, p.emission);
      set3(f.diffuse, x, y, p.diffuse);
      set3(f.specular, x, y, p.specular);
      set3(f.direct, x, y, p.direct);
      set3(f.indirect, x, y, p.indirect);
      const Vec2d dg = depth_gradient(fc, pos, surf, g.depth);
      f.depth_gradient.at(x, y, 0) = float(dg.x);
      f.depth_gradient.at(x, y, 1) = float(dg.y);
      f.roughness.at(x, y, 0) = surf.hit ? material_roughness(*surf.material) : 0.0f;
    }
  });
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (stats) *stats += st;
  return f;
}

Frame SceneRenderer::path_traced_gradients(int frame_index, RenderStats* stats) {
  // This frame's samples are forward-projected into the next one with motion_next.
  const bool keep_next = settings_.motion_next;
  settings_.motion_next = true;
  Frame f;
  try {
    f = path_traced(frame_index, stats);
  } catch (...) {
    settings_.motion_next = keep_next;
    throw;
  }
  settings_.motion_next = keep_next;
  f.allocate_channel(Channel::gradient);
  const int w = f.width, h = f.height;
  const uint64_t seed = settings_.seed;
  std::vector<uint8_t> replaced(size_t(w) * size_t(h), 0);
  const Frame* p = prev_noisy_.get();
  if (p && p->index == frame_index - 1 && !f.camera_cut && p->width == w && p->height == h &&
      prev_seed_ == seed && p->has(Channel::motion_next)) {
    // Steps 1-3 (path_tracer.h): one candidate per stratum of frame f - 1, the smallest
    // priority per stratum of frame f. Serial and cheap (one entry per 9 pixels).
    constexpr int kS = kGradientStratum;
    const int sw = (w + kS - 1) / kS, sh = (h + kS - 1) / kS;
    struct Candidate {
      uint64_t priority = UINT64_MAX;
      int px = -1, py = -1;
      Vec2d pos;
    };
    std::vector<Candidate> best(size_t(sw) * size_t(sh));
    const int prev_frame = frame_index - 1;
    for (int sy = 0; sy < sh; ++sy)
      for (int sx = 0; sx < sw; ++sx) {
        const int pick = gradient_stratum_pick(seed, prev_frame, sx, sy);
        int px = -1, py = -1;
        for (int k = 0; k < kS * kS && px < 0; ++k) {
          const int i = (pick + k) % (kS * kS);
          const int x = sx * kS + i % kS, y = sy * kS + i / kS;
          if (x < w && y < h && !prev_replaced_[size_t(y) * size_t(w) + size_t(x)]) {
            px = x;
            py = y;
          }
        }
        if (px < 0 || p->id.at(px, py, 0) == 0) continue;  // no sample, or the sky
        const Vec2d pos{px + 0.5 + p->jitter.x + p->motion_next.at(px, py, 0),
                        py + 0.5 + p->jitter.y + p->motion_next.at(px, py, 1)};
        if (!(pos.x >= 0.0 && pos.x < w && pos.y >= 0.0 && pos.y < h)) continue;  // NaN too
        const int lx = std::min(w - 1, int(pos.x)), ly = std::min(h - 1, int(pos.y));
        Candidate& c = best[size_t(ly / kS) * size_t(sw) + size_t(lx / kS)];
        const uint64_t prio = gradient_priority(seed, prev_frame, sx, sy);
        if (prio < c.priority) c = {prio, px, py, pos};
      }
    std::vector<RetraceRequest> requests;
    std::vector<const Candidate*> from;
    for (const Candidate& c : best)
      if (c.px >= 0) {
        requests.push_back({c.pos, prev_frame, c.px, c.py});
        from.push_back(&c);
      }
    // Step 4: re-trace with frame f - 1's random numbers; step 5: accept and replace.
    const std::vector<PathPixel> out = retrace(frame_index, requests, stats);
    if (stats) stats->gradient_retraced += out.size();
    for (size_t i = 0; i < out.size(); ++i) {
      const Candidate& c = *from[i];
      const PathPixel& q = out[i];
      const float pd = p->depth.at(c.px, c.py, 0);
      const Vec3f pn{p->normal.at(c.px, c.py, 0), p->normal.at(c.px, c.py, 1),
                     p->normal.at(c.px, c.py, 2)};
      if (q.id != p->id.at(c.px, c.py, 0) || !(dot(q.normal, pn) >= kGradientNormalCos) ||
          !(std::abs(q.depth - pd) <= kGradientDepthRel * pd))
        continue;
      if (stats) ++stats->gradient_accepted;
      const int lx = std::min(w - 1, int(c.pos.x)), ly = std::min(h - 1, int(c.pos.y));
      if (settings_.gradient_replace) {
        set3(f.color, lx, ly, q.color);
        set3(f.emission, lx, ly, q.emission);
        set3(f.albedo, lx, ly, q.albedo);
        set3(f.diffuse, lx, ly, q.diffuse);
        set3(f.specular, lx, ly, q.specular);
        set3(f.direct, lx, ly, q.direct);
        set3(f.indirect, lx, ly, q.indirect);
        replaced[size_t(ly) * size_t(w) + size_t(lx)] = 1;
      }
      const float now = luminance(q.color), before = luminance(p->color_at(c.px, c.py));
      f.gradient.at(lx, ly, 0) = now - before;
      f.gradient.at(lx, ly, 1) = std::max(now, before);
      f.gradient.at(lx, ly, 2) = 1.0f;
    }
  }
  prev_noisy_ = std::make_unique<Frame>(f);
  prev_replaced_ = std::move(replaced);
  prev_seed_ = seed;
  if (!keep_next) f.motion_next = {};
  return f;
}

Frame SceneRenderer::path_reference(int frame_index, int spp, RenderStats* stats) {
  if (spp < 1)
    throw SettingsError(fmt::format("path-traced reference: {} samples per pixel < 1", spp));
  const auto t0 = std::chrono::steady_clock::now();
  const PathTraceSettings& pt = *settings_.path_trace;
  Frame f;
  const FrameContext fc = setup_frame(scene_, *accel_, frame_index, settings_, f);
  f.jitter = {0.0, 0.0};
  for (Channel c : {Channel::emission, Channel::direct, Channel::indirect}) f.allocate_channel(c);
  const int stream = sample_stream(scene_, frame_index, settings_);
  const RenderSettings& rs = settings_;
  RenderStats st = run_rows(exec_, rs.height, rs.progress, [&](int y, RayCounts& c) {
    for (int x = 0; x < rs.width; ++x) {
      const uint64_t seq = sequence_seed(rs.seed, SampleDomain::Reference, stream, x, y);
      Vec3d color(0.0), emission(0.0), direct(0.0), indirect(0.0);
      for (int s = 0; s < spp; ++s) {
        // Box filter over the pixel: positions from the sampler's pixel pair.
        const PathRandom rnd{seq, uint32_t(s)};
        const Vec2d u = rnd.pair(PathDims::kPixel);
        Surface surf;
        trace_surface_ray(fc, camera_ray(fc.inv_vp, {x + u.x, y + u.y}, fc.width, fc.height), 0.0,
                          c, surf);
        const PathResult r = trace_from_primary(fc, pt, surf, rnd, c);
        const Vec3d e = primary_emission(surf);
        color += compose_shading(e, surf.hit ? surf.albedo : Vec3d(0.0), r.lobes.diffuse,
                                 r.lobes.specular);
        emission += e;
        direct += r.direct;
        indirect += r.indirect;
      }
      const double inv = 1.0 / spp;
      Surface surf;
      const Sample center = trace_surface_ray(
          fc, camera_ray(fc.inv_vp, {x + 0.5, y + 0.5}, fc.width, fc.height), 0.0, c, surf);
      store(f, x, y, center, color * inv);
      set3(f.emission, x, y, to_float(emission * inv));
      set3(f.direct, x, y, to_float(direct * inv));
      set3(f.indirect, x, y, to_float(indirect * inv));
    }
  });
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (stats) *stats += st;
  return f;
}

std::vector<PathPixel> SceneRenderer::retrace(int frame_index,
                                              const std::vector<RetraceRequest>& requests,
                                              RenderStats* stats) {
  if (!settings_.path_trace)
    throw SettingsError("retrace: the renderer is not path tracing (RenderSettings::path_trace)");
  for (size_t i = 0; i < requests.size(); ++i)
    if (!std::isfinite(requests[i].position.x) || !std::isfinite(requests[i].position.y))
      throw InputError(
          fmt::format("retrace in frame {}: request {} has a non-finite position", frame_index, i));
  const auto t0 = std::chrono::steady_clock::now();
  const PathTraceSettings& pt = *settings_.path_trace;
  Frame f;
  const FrameContext fc = setup_frame(scene_, *accel_, frame_index, settings_, f);
  std::vector<PathPixel> out(requests.size());
  constexpr int kChunk = 64;  // requests per task
  const int chunks = int((requests.size() + kChunk - 1) / kChunk);
  RenderStats st = run_rows(exec_, chunks, {}, [&](int chunk, RayCounts& c) {
    const size_t end = std::min(requests.size(), size_t(chunk + 1) * kChunk);
    for (size_t i = size_t(chunk) * kChunk; i < end; ++i) {
      const RetraceRequest& q = requests[i];
      Sample g;
      Surface surf;
      out[i] = shade_pixel(fc, pt, settings_.seed, q.position, q.key_frame, q.key_x, q.key_y, c, &g,
                           &surf);
    }
  });
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (stats) *stats += st;
  return out;
}

}  // namespace afterimage::render
