#include "render/accel.h"

#include <embree3/rtcore.h>
#include <tbb/task_arena.h>

#include <cstring>
#include <limits>
#include <string>

#include "core/error.h"

namespace afterimage::render {

namespace {

void check_device(RTCDevice dev, const char* what) {
  const RTCError e = rtcGetDeviceError(dev);
  if (e != RTC_ERROR_NONE)
    throw Error(std::string("embree: ") + what + " failed (error " + std::to_string(int(e)) + ")");
}

// Embree 3 takes a 3x4 affine matrix; column-major float layout.
void to_embree_xfm(const Mat4& m, float out[12]) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 3; ++r) out[c * 3 + r] = float(m.m[r][c]);
}

// Runs `f` in a one-thread arena: Embree's TBB builders then partition serially, so the BVH
// layout (and which of two coincident hits wins) is the same whatever the caller's threads.
template <class F>
void serial(F&& f) {
  tbb::task_arena arena(1);
  arena.execute(f);
}

}  // namespace

struct Accel::Impl {
  RTCDevice device = nullptr;
  std::vector<RTCScene> mesh_scenes;  // one per mesh (null for empty meshes)
  RTCScene top = nullptr;
  std::vector<RTCGeometry> instances;  // one per object (null for empty meshes)

  ~Impl() {
    if (top) rtcReleaseScene(top);
    for (RTCScene s : mesh_scenes)
      if (s) rtcReleaseScene(s);
    if (device) rtcReleaseDevice(device);
  }
};

Accel::Accel(const Scene& scene) : impl_(std::make_unique<Impl>()) {
  Impl& I = *impl_;
  I.device = rtcNewDevice("verbose=0");
  if (!I.device) throw Error("embree: cannot create device");
  serial([&] {
    for (const Mesh& m : scene.meshes) {
      if (m.triangle_count() == 0) {
        I.mesh_scenes.push_back(nullptr);
        continue;
      }
      RTCScene s = rtcNewScene(I.device);
      rtcSetSceneBuildQuality(s, RTC_BUILD_QUALITY_MEDIUM);
      RTCGeometry g = rtcNewGeometry(I.device, RTC_GEOMETRY_TYPE_TRIANGLE);
      // Embree-owned buffers are padded for its 16-byte vector loads.
      auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
          g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), m.positions.size()));
      for (size_t i = 0; i < m.positions.size(); ++i) {
        vb[3 * i + 0] = m.positions[i].x;
        vb[3 * i + 1] = m.positions[i].y;
        vb[3 * i + 2] = m.positions[i].z;
      }
      auto* ib = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
          g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), m.triangle_count()));
      std::memcpy(ib, m.indices.data(), m.indices.size() * sizeof(uint32_t));
      rtcCommitGeometry(g);
      rtcAttachGeometryByID(s, g, 0);
      rtcReleaseGeometry(g);
      rtcCommitScene(s);
      I.mesh_scenes.push_back(s);
    }
    I.top = rtcNewScene(I.device);
    // The top level holds one box per object, so rebuilding it per frame costs microseconds;
    // the mesh BVHs above, the expensive part, are never rebuilt while the Accel lives.
    // (Embree 3 refits only geometry BVHs; a scene accepts LOW/MEDIUM/HIGH quality.)
    rtcSetSceneBuildQuality(I.top, RTC_BUILD_QUALITY_MEDIUM);
    for (size_t k = 0; k < scene.objects.size(); ++k) {
      RTCScene ms = I.mesh_scenes[size_t(scene.objects[k].mesh)];
      if (!ms) {
        I.instances.push_back(nullptr);
        continue;
      }
      RTCGeometry inst = rtcNewGeometry(I.device, RTC_GEOMETRY_TYPE_INSTANCE);
      rtcSetGeometryInstancedScene(inst, ms);
      // Geometry id in the top scene = object index, so hit.instID[0] names the object.
      rtcAttachGeometryByID(I.top, inst, unsigned(k));
      rtcReleaseGeometry(inst);  // the scene keeps it alive
      I.instances.push_back(inst);
    }
  });
  check_device(I.device, "mesh BVH build");
}

Accel::~Accel() = default;

void Accel::set_transforms(const std::vector<Mat4>& object_to_world) {
  Impl& I = *impl_;
  AI_CHECK_EQ(object_to_world.size(), I.instances.size());
  serial([&] {
    for (size_t k = 0; k < I.instances.size(); ++k) {
      if (!I.instances[k]) continue;
      float xfm[12];
      to_embree_xfm(object_to_world[k], xfm);
      rtcSetGeometryTransform(I.instances[k], 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
      rtcCommitGeometry(I.instances[k]);
    }
    rtcCommitScene(I.top);
  });
  check_device(I.device, "instance BVH build");
}

Hit Accel::intersect(Vec3d o, Vec3d d, double tnear, double tfar) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  rh.ray.org_x = float(o.x);
  rh.ray.org_y = float(o.y);
  rh.ray.org_z = float(o.z);
  rh.ray.dir_x = float(d.x);
  rh.ray.dir_y = float(d.y);
  rh.ray.dir_z = float(d.z);
  rh.ray.tnear = float(tnear);
  rh.ray.tfar = tfar >= 1e30 ? std::numeric_limits<float>::infinity() : float(tfar);
  rh.ray.time = 0.0f;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->top, &ctx, &rh);
  Hit h;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return h;
  h.hit = true;
  h.object = rh.hit.instID[0];
  h.prim = rh.hit.primID;
  h.u = rh.hit.u;
  h.v = rh.hit.v;
  h.t = rh.ray.tfar;
  return h;
}

bool Accel::occluded(Vec3d o, Vec3d d, double tnear, double tfar) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r;
  r.org_x = float(o.x);
  r.org_y = float(o.y);
  r.org_z = float(o.z);
  r.dir_x = float(d.x);
  r.dir_y = float(d.y);
  r.dir_z = float(d.z);
  r.tnear = float(tnear);
  r.tfar = tfar >= 1e30 ? std::numeric_limits<float>::infinity() : float(tfar);
  r.time = 0.0f;
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
  rtcOccluded1(impl_->top, &ctx, &r);
  // Embree sets tfar to -inf when an occluder is found.
  return r.tfar < 0.0f;
}

}  // namespace afterimage::render
