// Camera model, projections and sub-pixel jitter (DESIGN.md §3; seed 003 "抖动 Jitter").
#pragma once

#include <string>
#include <vector>

#include "core/math.h"

namespace afterimage {

// Thin-lens parameters (issue 12): the depth-of-field reference of the ray tracer and the
// DoF pass read the same lens through circle_of_confusion_px (DESIGN.md §3 "Lens").
//
// Field of view rule: the camera's vertical FOV is the source of truth for the projection.
// The focal length that goes with it is derived from the sensor width and the image aspect
// (focal_length_for_fov_mm; the sensor width spans the image width, no focus breathing), and
// the renderer writes that derived focal length into every frame header (frame_lens), so a
// frame's lens and its projection always agree. Choosing a focal length instead (render
// --focal-length) sets the vertical FOV through fov_for_focal_length_deg.
struct ThinLens {
  double focal_length_mm = 50.0;  // lens focal length
  double f_number = 0.0;          // aperture N; 0 = pinhole (no defocus)
  double focus_distance = 5.0;    // scene units along the view axis (linear view depth)
  double sensor_width_mm = 36.0;  // full-frame sensor
  // Aperture shape: 0 = disc; N >= 3 = regular N-gon (N diaphragm blades) inscribed in the
  // aperture circle, a vertex at blade_rotation_deg counter-clockwise from the view-space +x
  // axis (x right, y up, seen from behind the camera).
  int blades = 0;
  double blade_rotation_deg = 0.0;
  // Aperture radius in scene units, assuming 1 scene unit = 1 m.
  double aperture_radius() const {
    return f_number > 0 ? 0.5 * (focal_length_mm / f_number) * 1e-3 : 0.0;
  }
  bool operator==(const ThinLens&) const = default;
};

// Throws SettingsError unless the lens is usable: finite values, f_number 0 or > 0,
// focal length and sensor width > 0, focus distance > focal length, blades 0 or 3..16.
void validate_lens(const ThinLens& lens);

// Signed circle-of-confusion DIAMETER in PIXELS of a point at linear view depth `depth` (scene
// units = m), for an image `image_width` pixels wide (thin-lens formula):
//   c_sensor = A * (depth - s) / depth * f / (s - f),   A = f / N (aperture diameter),
//   c_px = c_sensor * image_width / sensor_width,
// with f the focal length and s the focus distance (both in m for the ratio). Sign: negative
// in front of the focus plane (near field), 0 on it, positive behind it (far field); the far
// field tends to A f / (s - f) at infinite depth (the background depth 1e10 gives that). 0 for
// a pinhole (f_number 0). For a bladed aperture it is the diameter of the circumscribed circle
// (blade tips). Pure; the DoF pass and the ray tracer's reference use this one function.
double circle_of_confusion_px(const ThinLens& lens, double depth, int image_width);

// Focal length (mm) that gives a perspective camera of full vertical FOV `vfov_degrees` on an
// image of aspect width / height when the sensor, `sensor_width_mm` wide, spans the width:
//   f = sensor_width / (2 tan(hfov / 2)),  tan(hfov / 2) = aspect tan(vfov / 2).
double focal_length_for_fov_mm(double vfov_degrees, double sensor_width_mm, double aspect);
// The inverse: the vertical FOV (degrees) of focal length `focal_length_mm`.
double fov_for_focal_length_deg(double focal_length_mm, double sensor_width_mm, double aspect);

// Radius (scene units) of the disc on the camera's x/y plane from which the ray tracer's
// thin-lens rays start: aperture_radius() * s / (s - f). The rays aim at the pinhole ray's
// point at view depth s (PBRT-v3 6.2.3), with the projection fixed by the FOV; this radius
// makes their blur equal circle_of_confusion_px exactly (a point at depth d spreads over
// 2 r (d - s) / (s d) in tan units = the formula above in pixels). 0 for a pinhole.
double thin_lens_ray_radius(const ThinLens& lens);

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

// The lens a frame of width x height carries: camera.lens with focal_length_mm derived from
// the vertical FOV (focal_length_for_fov_mm; the FOV rule above). Orthographic cameras: the
// lens unchanged.
ThinLens frame_lens(const Camera& camera, int width, int height);

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
