// Internal to render/: what the renderers share per frame — the frame's camera, objects and
// lights (FrameContext), the primary hit (Sample, Surface) and the row loop. renderer.cpp
// (G-buffer, reference) and path_tracer.cpp (path-traced frames) both trace through these, so
// a path-traced frame's G-buffer channels are exactly those of gbuffer().
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <vector>

#include "core/parallel.h"
#include "frame/frame.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "render/shading.h"

namespace afterimage::render {

class Accel;
struct Hit;

namespace detail {

// Per-object matrices of one frame.
struct ObjectFrame {
  Mat4 to_world;         // M_curr (tangents of bump-mapped surfaces)
  Mat4 normal_to_world;  // inverse transpose of M_curr (upper 3x3 used)
  Mat4 to_prev;          // M_prev * M_curr^-1: current world point -> its previous world position
  bool moved = false;    // M_prev != M_curr
  Mat4 to_next;          // M_next * M_curr^-1 (motion_next)
  bool moves_next = false;
  bool emits = true;  // material emission on at this frame's time (Material::emission_blink)
};

// Everything a sample needs, fixed for one frame.
struct FrameContext {
  const Scene* scene = nullptr;
  const Accel* accel = nullptr;
  int width = 0, height = 0;
  Mat4 view, vp, inv_vp, vp_prev;
  // Thin-lens rays (CameraEffects::depth_of_field): camera -> world, the lens, its ray radius
  // (thin_lens_ray_radius) and the near plane.
  bool thin_lens = false;
  Mat4 inv_view;
  ThinLens lens;
  double lens_radius = 0.0, near_plane = 0.0;
  bool camera_moved = false;  // previous VP != current VP
  // motion_next (RenderSettings::motion_next): the next frame's VP, and whether anything is
  // written (false: channel not requested, or the next frame starts a camera cut -> zero).
  bool motion_next = false;
  Mat4 vp_next;
  bool camera_moves_next = false;
  bool orthographic = false;
  double far_plane = 0.0;
  std::vector<ObjectFrame> objects;
  std::vector<Light>
      lights;  // the scene's lights at this frame's time, those switched off left out
  bool soft_shadows = false;
  int light_axis = 1;  // light samples per axis (soft shadows)
};

// One camera sample: shading plus the G-buffer attributes of its first hit.
struct Sample {
  Vec3d color;
  float depth = kBackgroundDepth;
  Vec3f normal{0, 0, 0}, albedo{0, 0, 0};
  uint32_t id = 0;
  Vec2d motion{0, 0};
  Vec2d motion_next{0, 0};
};

// What shading a hit needs (trace_surface -> shade_direct; the path tracer's vertices): kept
// per pixel when the direct light of only some pixels is computed
// (SceneRenderer::gbuffer_masked).
struct Surface {
  bool hit = false;
  const Material* material = nullptr;
  Vec3d p, n, ng, v, albedo;  // n: shading normal, ng: geometric; both face v (the viewer)
  Vec3d emission{0.0};        // the material's emission while it is on, else 0
  Vec3d base;                 // emission + albedo * ambient at a hit, sky radiance otherwise
};

struct RayCounts {
  uint64_t primary = 0, shadow = 0, bounce = 0;
};

// The surface a ray hit (h.hit must be true): shading and geometric normals facing the ray's
// origin (two-sided surfaces), bump mapping, albedo and emission at the hit.
Surface surface_at_hit(const FrameContext& fc, const Vec3d& origin, const Vec3d& dir, const Hit& h);

// The primary hit of a camera ray: its G-buffer attributes (color left 0) and `surf`.
Sample trace_surface_ray(const FrameContext& fc, const Ray& ray, double tnear, RayCounts& counts,
                         Surface& surf);

// Stores the G-buffer attributes of `s` and `color` at pixel (x, y) of f.
void store(Frame& f, int x, int y, const Sample& s, Vec3d color);

// Sets the BVH to the frame's time and builds its context; allocates f with the frame's header.
FrameContext setup_frame(const Scene& sc, Accel& accel, int frame_index, const RenderSettings& rs,
                         Frame& f);

// Random-number stream of a reference frame (0 for every frame of a static scene).
int sample_stream(const Scene& sc, int frame_index, const RenderSettings& rs);

// Offset of a spawned ray's origin along the geometric normal, scaled with the magnitude of
// p: float ray origins carry a relative error of ~1e-7 (PBRT-v3 3.9 "Robust spawned rays",
// simplified).
inline Vec3d offset_origin(Vec3d p, Vec3d ng) {
  const double mag = std::max({1.0, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  return p + ng * (2e-5 * mag);
}

// Row loop with ray counting, progress reporting and timing.
template <class RowFn>
RenderStats run_rows(const Exec& ex, int height, const ProgressFn& progress, RowFn&& row) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<RayCounts> counts(static_cast<size_t>(height));
  std::atomic<int> done{0};
  std::mutex mu;
  int reported = -1;  // guarded by mu
  parallel_rows(ex, height, [&](int y) {
    row(y, counts[size_t(y)]);
    const int d = done.fetch_add(1) + 1;
    if (progress) {
      const int percent = int(int64_t(d) * 100 / height);
      std::lock_guard<std::mutex> lock(mu);
      if (percent > reported) {
        reported = percent;
        progress(double(d) / height);
      }
    }
  });
  RenderStats st;
  for (const RayCounts& c : counts) {
    st.primary_rays += c.primary;
    st.shadow_rays += c.shadow;
    st.bounce_rays += c.bounce;
  }
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace detail
}  // namespace afterimage::render
