// Motion blur (motion_blur.h): the settings, the camera split's checks, the entry point, which
// runs the fast schedule (motion_blur_fast.cpp) or, with --simd off, its plain statement
// (motion_blur_reference.cpp), the same bits, and the sequence's running-sum trail.
#include "post/motion_blur.h"

#include <fmt/format.h>

#include <cmath>
#include <string>

#include "core/error.h"
#include "post/motion_blur_camera.h"
#include "post/motion_blur_fast.h"

namespace afterimage::post {

const ParamTable<MotionBlurSettings>& MotionBlurSettings::params() {
  static const ParamTable<MotionBlurSettings> kTable = [] {  // immutable once built
    using S = MotionBlurSettings;
    ParamTable<S> t("motion_blur");
    t.add_float("shutter", &S::shutter, 0.0f, 1.0f,
                "fraction of the frame interval the shutter is open (0.5 = 180 degrees)");
    t.add_int("max_radius", &S::max_radius, 1, 256,
              "half-length clamp of the blur in pixels, also the tile size");
    t.add_int("samples", &S::samples, 3, 63, "taps along the dominant velocity (odd)");
    t.add_float("soft_depth", &S::soft_depth, 1e-4f, 10.0f,
                "relative depth extent of the soft front/back comparison");
    t.add_int("camera_max_radius", &S::camera_max_radius, 0, 256,
              "clamp of the camera-motion half vector in pixels (0: none, only max_radius)");
    t.add_int("object_max_radius", &S::object_max_radius, 0, 256,
              "clamp of the object-motion half vector in pixels (0: none, only max_radius)");
    t.add_bool("camera_rotation", &S::camera_rotation,
               "false: the camera's rotation does not blur, only its translation and objects");
    t.add_int("trail_frames", &S::trail_frames, 1, 32,
              "running-sum trail over the last N frames (seed 004); 1 = off");
    t.add_float("tile_jitter", &S::tile_jitter, 0.0f, 0.5f,
                "per-pixel offset of the NeighborMax lookup in tiles (Jimenez 2014); 0 = none");
    t.add_float("uniform_tolerance", &S::uniform_tolerance, 0.0f, 64.0f,
                "fast path where the neighbourhood's half vectors agree within this many pixels "
                "per axis (box filter, no depth test; Jimenez 2014); 0 = always the full path");
    t.add_float("fast_tap_spacing", &S::fast_tap_spacing, 0.0f, 64.0f,
                "fast path: ceil(|v| / spacing) tap pairs per pixel (at most samples'), taps at "
                "most this many pixels apart; 0 = always `samples`");
    t.add_bool("mirror_weights", &S::mirror_weights,
               "Jimenez 2014 mirrored tap-pair weights (the faster tap in front lends its weight)");
    t.check([](const S& s) {
      return s.samples % 2 == 1 ? std::string() : fmt::format("samples {} must be odd", s.samples);
    });
    return t;
  }();
  return kTable;
}
void MotionBlurSettings::set_assignment(const std::string& assignment) {
  params().set_assignment(*this, assignment);
}
void MotionBlurSettings::validate() const {
  params().validate(*this);
}

Mat4 view_without_rotation_change(const Mat4& previous, const Mat4& current) {
  // The previous camera's position C (world), seen with the current rotation R: x -> R (x - C).
  const Vec3d c = previous.inverse().transform_point({0, 0, 0});
  Mat4 v = current;
  const Vec3d rc = current.transform_dir(c);
  v.m[0][3] = -rc.x;
  v.m[1][3] = -rc.y;
  v.m[2][3] = -rc.z;
  return v;
}

CameraMotionSplit::CameraMotionSplit(const Frame& f, const MotionBlurSettings& s,
                                     const FrameHeader* previous)
    : known_(splits_camera_motion(s) && previous && previous->width == f.width &&
             previous->height == f.height),
      rotation_(s.camera_rotation) {
  if (!known_) return;
  full_ = reproject::CameraTransfer::between(f, *previous);
  FrameHeader turned = *previous;
  turned.view = view_without_rotation_change(previous->view, f.view);
  translation_ = reproject::CameraTransfer::between(f, turned);
}

CameraMotion CameraMotionSplit::at(int x, int y, float depth) const {
  CameraMotion m;
  if (!known_) return m;
  const Vec2d p{x + 0.5, y + 0.5};
  const reproject::Reprojected r = reproject::camera_displacement(full_, p, depth);
  if (!r.valid) return m;
  m.full = r.displacement;
  m.blur = m.full;
  if (!rotation_) {
    const reproject::Reprojected t = reproject::camera_displacement(translation_, p, depth);
    m.blur = t.valid ? t.displacement : Vec2d{0, 0};
  }
  return m;
}

bool splits_camera_motion(const MotionBlurSettings& s) {
  return s.camera_max_radius > 0 || s.object_max_radius > 0 || !s.camera_rotation;
}
void check_motion_blur_camera(const FrameHeader& h, const MotionBlurSettings& s) {
  if (splits_camera_motion(s) && !h.camera_known)
    throw InputError(fmt::format(
        "motion_blur: frame {} carries no camera (not in the file, no view and projection in a "
        "camera sidecar), which camera_rotation=false, camera_max_radius and object_max_radius "
        "need to tell the camera's motion from the objects': give the camera (--jitter-file) "
        "or leave those settings at their defaults",
        h.index));
}
bool keeps_frames(const MotionBlurSettings& s) {
  return splits_camera_motion(s) || s.trail_frames > 1;
}
void check_motion_blur_input(const Frame& f, const ImageF* color) {
  if (!f.has_depth() || !f.has_motion())
    throw InputError(fmt::format("motion_blur: frame {} needs depth and motion", f.index));
  if (color && (color->width() != f.width || color->height() != f.height || color->channels() != 3))
    throw InputError(fmt::format("motion_blur: frame {} is {}x{}, its color {}x{}x{}", f.index,
                                 f.width, f.height, color->width(), color->height(),
                                 color->channels()));
}

ImageF motion_blur(const Frame& f, const ImageF& color, const MotionBlurSettings& s,
                   const Exec& exec) {
  return motion_blur(f, color, s, nullptr, exec);
}

ImageF motion_blur(const Frame& f, const ImageF& color, const MotionBlurSettings& s,
                   const FrameHeader* previous, const Exec& exec) {
  s.validate();
  check_motion_blur_input(f, &color);
  // --simd off runs the plain statement of the pass (the same bits).
  if (!exec.simd) return motion_blur_reference(f, color, s, previous, exec);
  return motion_blur_fast(f, color, s, previous, exec);
}

void RunningSumTrail::reset() {
  window_.clear();
  sum_.clear();
  pushes_since_rebuild_ = 0;
}

ImageF RunningSumTrail::push(const ImageF& image, int frames, const Exec& exec) {
  AI_CHECK(frames >= 1);
  const auto finite = [](float v) { return std::isfinite(v) ? double(v) : 0.0; };
  if (!window_.empty() &&
      (window_.front().width() != image.width() || window_.front().height() != image.height() ||
       window_.front().channels() != image.channels() || int(window_.size()) > frames))
    reset();  // another size, or a shorter window: start again
  const size_t n = image.data().size();
  if (sum_.empty()) sum_.assign(n, 0.0);
  window_.push_back(image);
  const bool leaves = int(window_.size()) > frames;
  const ImageF* oldest = leaves ? &window_.front() : nullptr;
  const bool rebuild = ++pushes_since_rebuild_ >= frames;
  const int count = leaves ? frames : int(window_.size());
  ImageF out(image.width(), image.height(), image.channels());
  parallel_rows(exec, image.height(), [&](int y) {
    for (int c = 0; c < image.channels(); ++c)
      for (int x = 0; x < image.width(); ++x) {
        const size_t i =
            (size_t(c) * size_t(image.height()) + size_t(y)) * size_t(image.width()) + size_t(x);
        double& sum = sum_[i];
        if (rebuild) {
          // Once per turn of the window: the exact sum of what it holds (oldest first).
          sum = 0.0;
          for (size_t k = leaves ? 1 : 0; k < window_.size(); ++k)
            sum += finite(window_[k].data()[i]);
        } else {
          sum += finite(image.data()[i]);
          if (oldest) sum -= finite(oldest->data()[i]);
        }
        out.data()[i] = float(sum / count);
      }
  });
  if (rebuild) pushes_since_rebuild_ = 0;
  if (leaves) window_.pop_front();
  return out;
}

void MotionBlurSequence::reset() {
  has_previous_ = false;
  trail_.reset();
}

ImageF MotionBlurSequence::process(const Frame& frame, const ImageF& color,
                                   const MotionBlurSettings& s, const Exec& exec) {
  const bool restart = frame.camera_cut || !has_previous_ || previous_.width != frame.width ||
                       previous_.height != frame.height;
  if (restart) trail_.reset();
  ImageF out = motion_blur(frame, color, s, restart ? nullptr : &previous_, exec);
  previous_ = frame;  // the header part
  has_previous_ = true;
  if (s.trail_frames > 1) return trail_.push(out, s.trail_frames, exec);
  trail_.reset();  // trail off: no frames kept
  return out;
}

}  // namespace afterimage::post
