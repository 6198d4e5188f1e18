// Depth of field (dof.h): the settings, the lens and bokeh, and the entry point, which runs the
// gather's fast schedule (dof_gather_fast.cpp) or, with --simd off, its plain statement
// (dof_reference.cpp), the same bits.
#include "post/dof.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "camera/camera.h"
#include "core/error.h"
#include "post/dof_diffusion.h"
#include "post/dof_gather_fast.h"

namespace afterimage::post {

namespace {
constexpr EnumNames<DofMode, 2> kDofModeNames{{
    {DofMode::gather, "gather"},
    {DofMode::diffusion, "diffusion"},
}};
constexpr EnumNames<DofResolution, 2> kDofResolutionNames{{
    {DofResolution::full, "full"},
    {DofResolution::half, "half"},
}};
constexpr EnumNames<DofCoc, 2> kDofCocNames{{
    {DofCoc::lens, "lens"},
    {DofCoc::ranges, "ranges"},
}};
}  // namespace

const ParamTable<DofSettings>& DofSettings::params() {
  static const ParamTable<DofSettings> kTable = [] {  // immutable once built
    using S = DofSettings;
    ParamTable<S> t("dof");
    t.add_int("max_radius", &S::max_radius, 1, 128,
              "clamp of the circle-of-confusion radius in pixels, also the tile size");
    t.add_int("taps", &S::taps, 8, 1024, "gather taps over the neighbourhood's disc");
    t.add_enum("mode", &S::mode, kDofModeNames,
               "gather (scatter-as-gather, Jimenez 2014) or diffusion (Kass, Lefohn, Owens 2006)");
    t.add_float("diffusion_scale", &S::diffusion_scale, 0.01f, 100.0f,
                "diffusion: conductivity multiplier (1: the variance of the CoC disc)");
    t.add_int("diffusion_steps", &S::diffusion_steps, 1, 16,
              "diffusion: implicit steps sharing the blur (1: the paper's single ADI step)");
    t.add_bool("diffusion_near_layer", &S::diffusion_near_layer,
               "diffusion: diffuse the near field as its own layer over the background");
    t.add_enum("resolution", &S::resolution, kDofResolutionNames,
               "gather: full, or half (gather at half resolution, composited by CoC)");
    t.add_float("half_from", &S::half_from, 0.0f, 1024.0f,
                "resolution=half: neighbourhood radius (px) from which a tile takes the "
                "half-resolution gather (0: every blurred tile)");
    t.add_enum("coc", &S::coc, kDofCocNames,
               "circle of confusion: lens (the frame's thin lens, with the values below) or "
               "ranges (artist near / far depth ranges, no lens)");
    t.add_float("f_number", &S::f_number, 0.0f, 1024.0f,
                "coc=lens: f-number replacing the frame's (0: the frame's)");
    t.add_float("focal_length", &S::focal_length, 0.0f, 1e5f,
                "coc=lens: focal length in mm replacing the frame's (0: the frame's)");
    t.add_float("focus_distance", &S::focus_distance, 0.0f, 1e9f,
                "coc=lens: focus distance (view depth, scene units) replacing the frame's (0: "
                "the frame's)");
    t.add_float("sensor_width", &S::sensor_width, 0.0f, 1e4f,
                "coc=lens: sensor width in mm replacing the frame's (0: the frame's)");
    t.add_float("near_start", &S::near_start, 0.0f, 1e9f,
                "coc=ranges: view depth at and before which the near blur is near_radius");
    t.add_float("near_end", &S::near_end, 0.0f, 1e9f,
                "coc=ranges: view depth where the near blur reaches 0");
    t.add_float("far_start", &S::far_start, 0.0f, 1e9f,
                "coc=ranges: view depth where the far blur starts from 0");
    t.add_float("far_end", &S::far_end, 0.0f, 1e9f,
                "coc=ranges: view depth at and beyond which the far blur is far_radius");
    t.add_float("near_radius", &S::near_radius, 0.0f, 1024.0f,
                "coc=ranges: blur radius in px of the nearest depths (clamped to max_radius)");
    t.add_float("far_radius", &S::far_radius, 0.0f, 1024.0f,
                "coc=ranges: blur radius in px of the farthest depths (clamped to max_radius)");
    t.add_int("blades", &S::blades, -1, 16,
              "bokeh shape: -1 the frame's lens, 0 disc, 3..16 polygon of that many blades");
    t.add_float("blade_rotation", &S::blade_rotation, -360.0f, 360.0f,
                "blades >= 3: a vertex's angle in degrees counter-clockwise from the view's +x");
    return t;
  }();
  return kTable;
}
void DofSettings::set_assignment(const std::string& assignment) {
  params().set_assignment(*this, assignment);
}
void DofSettings::validate() const {
  params().validate(*this);
  if (blades == 1 || blades == 2)
    throw SettingsError(fmt::format("dof setting blades {}: -1, 0 or 3..16", blades));
  if (coc == DofCoc::ranges &&
      !(near_start < near_end && near_end <= far_start && far_start < far_end))
    throw SettingsError(fmt::format(
        "dof settings near_start {}, near_end {}, far_start {}, far_end {}: need near_start < "
        "near_end <= far_start < far_end",
        near_start, near_end, far_start, far_end));
}

Bokeh lens_bokeh(const ThinLens& lens) {
  return {lens.blades >= 3 ? lens.blades : 0, lens.blade_rotation_deg * kPi / 180.0};
}

float bokeh_distance(const Bokeh& b, int dx, int dy, bool in_front) {
  const float euclid = std::hypot(float(dx), float(dy));
  if (!b.polygon()) return euclid;
  // p - q = (-dx, -dy) in the image, (-dx, dy) in view coordinates; point-reflected in front.
  const double x = in_front ? dx : -dx, y = in_front ? -dy : dy, half = kPi / b.blades;
  double gauge = 0.0;  // the largest projection on an edge's outward normal, over the apothem
  for (int k = 0; k < b.blades; ++k) {
    const double a = b.rotation_rad + 2.0 * kPi * k / b.blades + half;
    gauge = std::max(gauge, x * std::cos(a) + y * std::sin(a));
  }
  return std::max(euclid, float(gauge / std::cos(half)));
}

ThinLens dof_lens(const ThinLens& frame_lens, const DofSettings& s) {
  ThinLens l = frame_lens;
  if (s.blades >= 0) {
    l.blades = s.blades;
    l.blade_rotation_deg = s.blade_rotation;
  }
  if (s.f_number > 0.0f) l.f_number = s.f_number;
  if (s.focal_length > 0.0f) l.focal_length_mm = s.focal_length;
  if (s.focus_distance > 0.0f) l.focus_distance = s.focus_distance;
  if (s.sensor_width > 0.0f) l.sensor_width_mm = s.sensor_width;
  return l;
}

ThinLens checked_dof_lens(const FrameHeader& h, const DofSettings& s, const WarnFn& note) {
  const ThinLens lens = dof_lens(h.lens, s);
  if (s.coc == DofCoc::ranges) return lens;
  if (!h.lens_known) {
    std::string missing;
    for (const auto& [given, key] : {std::pair{s.f_number > 0.0f, "f_number"},
                                     std::pair{s.focal_length > 0.0f, "focal_length"},
                                     std::pair{s.focus_distance > 0.0f, "focus_distance"}})
      if (!given) missing += fmt::format("{}dof.{}", missing.empty() ? "" : ", ", key);
    if (!missing.empty())
      throw InputError(fmt::format(
          "dof: frame {} carries no lens (not in the file, no \"lens\" in a camera sidecar): "
          "set {} (dof.sensor_width is 36 mm unless set), or set dof.coc=ranges",
          h.index, missing));
  }
  if (!(lens.f_number > 0.0)) {
    if (note)
      note(
          fmt::format("dof: frame {}'s lens is a pinhole (f-number 0, in focus at every "
                      "depth): dof leaves such frames unchanged; dof.f_number opens the aperture",
                      h.index));
    return lens;
  }
  // The lens is mostly the frame's data (its file's metadata), so an unusable one is bad
  // input: `run` then names the file as well.
  try {
    validate_lens(lens);
  } catch (const SettingsError& e) {
    throw InputError(fmt::format("dof: frame {}: {}", h.index, e.what()));
  }
  return lens;
}

SignedCoc::SignedCoc(const DofSettings& s, const ThinLens& lens)
    : ranges_(s.coc == DofCoc::ranges), lens_(lens), range_([&] {
        DofSettings unclamped = s;
        unclamped.max_radius = std::numeric_limits<int>::max();
        return CocRanges(unclamped);
      }()) {}

std::optional<ThinLens> checked_dof_input(const Frame& f, const ImageF& color,
                                          const DofSettings& s) {
  s.validate();
  if (!f.has_depth()) throw InputError(fmt::format("dof: frame {} has no depth", f.index));
  const int w = color.width(), h = color.height();
  if (w != f.width || h != f.height || color.channels() != 3)
    throw InputError(fmt::format("dof: frame {} is {}x{}, its color {}x{}x{}", f.index, f.width,
                                 f.height, w, h, color.channels()));
  const ThinLens thin = checked_dof_lens(f, s);
  if (s.coc == DofCoc::lens && !(thin.f_number > 0.0)) return std::nullopt;  // pinhole
  return thin;
}

ImageF depth_of_field(const Frame& f, const ImageF& color, const DofSettings& s, const Exec& exec) {
  const std::optional<ThinLens> thin = checked_dof_input(f, color, s);
  if (!thin) return color;  // pinhole: everything in focus
  if (s.mode == DofMode::diffusion) return depth_of_field_diffusion(f, color, s, exec);
  // --simd off runs the gather's plain statement, at either resolution (the same bits).
  if (!exec.simd) return dof_reference(f, color, s, exec);
  return dof_gather_fast(f, color, s, *thin, exec);
}

}  // namespace afterimage::post
