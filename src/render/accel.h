// Embree acceleration structure of a Scene (internal to render/; Embree types stay in
// accel.cpp). Two levels: one BVH per mesh, built when the Accel is made, and a top-level BVH
// over instances whose transforms are the objects' matrices at the traced time, so animation
// only rebuilds the small top level (Embree 3 "rtcSetGeometryInstancedScene" instancing). A
// SceneRenderer keeps one Accel for a whole sequence; render_gbuffer / render_reference
// make one per call.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/math.h"
#include "render/scene.h"

namespace afterimage::render {

struct Hit {
  uint32_t object = 0;  // index into Scene::objects (valid only if hit)
  uint32_t prim = 0;    // triangle index in the object's mesh
  float u = 0, v = 0;   // barycentrics of vertices 1 and 2
  float t = 0;          // ray parameter of the hit (units of the ray direction)
  bool hit = false;
};

class Accel {
 public:
  // Builds one BVH per mesh (build quality medium). Builds run single-threaded so the BVH,
  // and hence tie-breaking between coincident hits, never depends on the thread count.
  explicit Accel(const Scene& scene);
  ~Accel();
  Accel(const Accel&) = delete;
  Accel& operator=(const Accel&) = delete;

  // Sets every object's object -> world matrix (one per Scene::objects entry, affine) and
  // rebuilds the top-level BVH (one box per object; the mesh BVHs are kept).
  void set_transforms(const std::vector<Mat4>& object_to_world);

  // Closest hit along origin + t dir for t in [tnear, tfar]. Thread-safe.
  Hit intersect(Vec3d origin, Vec3d dir, double tnear, double tfar) const;
  // Any hit along origin + t dir for t in [tnear, tfar]. Thread-safe.
  bool occluded(Vec3d origin, Vec3d dir, double tnear, double tfar) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace afterimage::render
