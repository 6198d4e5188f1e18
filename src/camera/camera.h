// Camera model, projections and sub-pixel jitter (DESIGN.md §3; seed 003 "抖动 Jitter").
#pragma once

#include <string>
#include <vector>

#include "core/math.h"

namespace afterimage {

// Thin-lens parameters, kept on the camera for depth of field (a later pass).
struct ThinLens {
  double focal_length_mm = 50.0;  // lens focal length
  double f_number = 0.0;          // aperture N; 0 = pinhole (no defocus)
  double focus_distance = 5.0;    // scene units along the view axis
  double sensor_width_mm = 36.0;  // full-frame sensor
  // Aperture radius in scene units, assuming 1 scene unit = 1 m.
  double aperture_radius() const {
    return f_number > 0 ? 0.5 * (focal_length_mm / f_number) * 1e-3 : 0.0;
  }
  bool operator==(const ThinLens&) const = default;
};

enum class ProjectionType { Perspective, Orthographic };

struct Camera {
  ProjectionType type = ProjectionType::Perspective;
  double vfov_degrees = 45.0;  // perspective: full vertical field of view
  double ortho_height = 2.0;   // orthographic: full vertical extent in scene units
  double near_plane = 0.05;
  double far_plane = 1000.0;
  Mat4 view = Mat4::identity();  // world -> view (right-handed, looks down -Z)
  ThinLens lens;

  // Unjittered OpenGL-style projection for an image of width x height pixels
  // (NDC x, y, z in [-1, 1], NDC +y up).
  Mat4 projection(int width, int height) const;
};

// The projection a rasteriser uses to take this frame's samples (DESIGN.md §3 Jitter): it
// moves every projected point by exactly -jitter pixels (x right, y down), so the pixel
// center (i + 0.5, j + 0.5) sees what lies at the unjittered position (i + 0.5 + jitter.x,
// j + 0.5 + jitter.y) — the sample our ray tracer takes. An NDC translation applied after
// projection, P' = T_ndc * P: the seed's P[0][2] / P[1][2] edit for perspective and
// P[0][3] / P[1][3] for orthographic, with the sign that matches our jitter.
Mat4 jittered_projection(const Mat4& projection, Vec2d jitter_px, int width, int height);

// Pixel coordinates (x right, y down, pixel centers at +0.5) of a world point under a
// view-projection; w_out receives clip w (> 0 in front of a perspective camera).
Vec2d project_to_pixel(const Mat4& view_projection, Vec3d world, int width, int height,
                       double* w_out = nullptr);

// Radical inverse of `index` in `base` (Halton sequence): 1 -> 1/2, 2 -> 1/4, 3 -> 3/4, ...
double halton(unsigned index, unsigned base);

// Jitter sequences in pixels within [-0.5, 0.5]^2 (y down). Halton(2,3) skips index 0
// (which would be (0, 0) every cycle) so sample k uses index k + 1.
enum class JitterPattern { Halton, None };
struct JitterSequence {
  JitterPattern pattern = JitterPattern::Halton;
  int length = 16;
  Vec2d at(long frame) const;  // jitter for frame number `frame` (cycles with `length`)
};
// Parses "halton16", "halton8", "haltonN", "none".
JitterSequence parse_jitter(const std::string& name);

}  // namespace afterimage
