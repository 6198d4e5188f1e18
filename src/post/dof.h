// Depth of field as a post process over the G-buffer (issue 12; seed 004 "Depth of Field"):
// a single-pass "scatter as you gather" (Jimenez, "Next Generation Post Processing in Call of
// Duty: Advanced Warfare", SIGGRAPH 2014; McIntosh, Riecke, DiPaola 2012) over the signed
// circle of confusion of the thin lens the frame carries (Frame::lens, the same
// circle_of_confusion_px the ray tracer's reference uses, camera/camera.h).
//
// Every pixel q is a disc of radius r_q = |CoC_q| / 2 (clamped to max_radius) holding its
// color spread evenly (weight 1 / r_q^2). Pixel p gathers the taps q of a disc of radius R =
// the largest r in the 3x3 tiles around p (TileMax / NeighborMax, as for motion blur) whose
// disc covers p, with a one-pixel soft edge. Depth order (Bukowski et al. 2013's near and far
// fields): a tap behind p covers p at most with p's own radius — a blurred background does not
// spread over a sharper nearer surface (the far field rejects nearer samples) — while a tap in
// front covers p with its full radius — the blurred near field spreads over the sharp
// background. Pixels whose neighbourhood is in focus (R < 0.5 px, the focus field) are copied.
#pragma once

#include <string>

#include "core/image.h"
#include "core/parallel.h"
#include "core/params.h"
#include "frame/frame.h"

namespace afterimage::post {

struct DofSettings {
  int max_radius = 16;  // pixels: clamp of the CoC radius, also the tile size
  int taps = 96;        // gather taps over the neighbourhood's disc (golden-angle spiral)

  static const ParamTable<DofSettings>& params();
  void set_assignment(const std::string& assignment);
  void validate() const;
};

// How much of pixel p a tap q at distance d covers: its disc of radius r (>= 0.5) reaches p,
// with a one-pixel soft edge: clamp(r - d + 0.5, 0, 1).
inline float disc_coverage(float r, float d) {
  const float c = r - d + 0.5f;
  return c < 0.0f ? 0.0f : (c > 1.0f ? 1.0f : c);
}

// The radius with which tap q covers p (depth order): a tap behind p at most p's own radius.
inline float effective_radius(float r_q, float z_q, float r_p, float z_p) {
  return z_q > z_p ? (r_q < r_p ? r_q : r_p) : r_q;
}

// The pass. A frame whose lens is a pinhole (f_number 0) is returned unchanged. InputError for
// a frame without depth; SettingsError for bad settings or an unusable lens.
ImageF depth_of_field(const Frame& frame, const ImageF& color, const DofSettings& s,
                      const Exec& exec = {});

}  // namespace afterimage::post
