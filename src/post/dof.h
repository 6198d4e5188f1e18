// Depth of field as a post process over the G-buffer (issue 12; seed 004 "Depth of Field"):
// a single-pass "scatter as you gather" (Jimenez, "Next Generation Post Processing in Call of
// Duty: Advanced Warfare", SIGGRAPH 2014; McIntosh, Riecke, DiPaola 2012) over the signed
// circle of confusion of the thin lens the frame carries (Frame::lens, through the formula of
// circle_of_confusion_px that the ray tracer's reference follows, camera/camera.h).
//
// Every pixel q is a disc of radius r_q = |CoC_q| / 2 (clamped to max_radius) holding its
// color spread evenly (weight 1 / r_q^2). Pixel p gathers the taps q of a disc of radius R =
// the largest r in the 3x3 tiles around p (TileMax / NeighborMax, as for motion blur) whose
// disc covers p, with a one-pixel soft edge; the taps are a golden-angle spiral over that disc
// rounded to pixels, each pixel weighted by the spiral taps that fall on it (p itself too).
// A bladed lens (ThinLens::blades, or the blades setting) makes each pixel's disc its aperture
// polygon instead, point-reflected in front of the focus plane (Bokeh, bokeh_distance): the
// taps stay the disc's, a tap covering p as far as the polygon reaches. Measured against the
// ray tracer's thin-lens references (sparkle 640x360, 5 blades, `render --reference 256
// --reference-dof`, `eval --warmup 0`; FLIP / PSNR): near field (f/8, 200 mm, focus 40 m)
// polygon 0.0663 / 29.83 dB, disc 0.0877 / 27.65; far field (f/1.2, focus 0.5 m) 0.0472 /
// 25.87, disc 0.0514 / 26.26. The orientation too: with every polygon point-reflected (both
// sides wrong; taps=1024) 0.0700 / 29.02 and 0.0475 / 29.39 against 0.0622 / 31.28 and
// 0.0433 / 30.02. The demo's dof:bokeh section (scene `bokeh`, 320x180, 4 frames, 16 spp):
// polygon 0.0402 / 25.07, disc 0.0492 / 24.16, pinhole 0.0949 / 22.02.
// Depth order (Bukowski et al. 2013's near and far fields): a tap behind p covers p at most
// with p's own radius — a blurred background does not spread over a sharper nearer surface
// (the far field rejects nearer samples) — while a tap in front covers p with its full
// radius — the blurred near field spreads over the sharp background. Pixels whose
// neighbourhood is in focus (R < 0.5 px, the focus field) are copied.
//
// The circle of confusion (coc=lens, the default) is the thin lens of the frame's header, each
// of its values replaceable by a setting: a render from Blender or an engine carries no lens in
// its files (a pinhole, which the pass leaves unchanged). Or (coc=ranges) artist depth ranges,
// as HDRP's manual mode and UE's Gaussian DoF take them, with no lens: the radius falls from
// near_radius at near_start to 0 at near_end, stays 0 to far_start and grows to far_radius at
// far_end (range_radius).
//
// Commit 9a36536 counts p's own spiral taps (before, p weighed 1 tap whatever R, so a small disc
// gave its neighbours most of the weight: 3.2x the disc's variance at r = 0.75 px). FLIP / PSNR
// against thin-lens references (`render --reference 64 --reference-dof`, `eval --warmup 0`),
// before -> after: focus 320x180 0.01778 / 42.94 -> 0.01729 / 43.12, 960x540 0.01636 / 42.77
// -> 0.01617 / 42.99, 1920x1080 0.01729 / 41.28 -> 0.01701 / 41.41; held out at 960x540, f/2
// (subtle blur; the pinhole image in brackets): orbit 0.00306 / 50.56 -> 0.00239 / 52.21
// (0.00245 / 50.87), room 0.00129 / 52.76 -> 0.00078 / 55.34 (0.00082 / 54.89), blades
// 0.01495 / 43.62 -> 0.00709 / 47.81 (0.01081 / 39.93): the pass had been farther from the
// reference than no pass on the first two. Demo dof:focus: 0.0231 / 39.11 -> 0.0226 / 39.19.
// The figures in DofSettings below were measured before it.
//
// resolution=half: the tiles of large blur gathered at half resolution over a CoC-aware 2x2
// downsample, as a far and a near layer, upsampled and composited by CoC at full resolution
// (half_res_blend); the focus field keeps its pixels bit for bit.
//
// mode=diffusion: the heat-diffusion method of Kass, Lefohn, Owens 2006 instead of the gather
// (post/dof_diffusion.h), measured beside it in the demo's dof section.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "camera/camera.h"
#include "core/error.h"
#include "core/image.h"
#include "core/lanes.h"
#include "core/parallel.h"
#include "core/params.h"
#include "frame/frame.h"

namespace afterimage::post {

enum class DofMode : uint8_t { gather, diffusion };
// Where the circle of confusion comes from: the (overridable) thin lens, or artist ranges.
enum class DofCoc : uint8_t { lens, ranges };
// The gather's resolution: full, or half (the gather over a CoC-aware 2x2 downsample, its
// far and near layers upsampled and composited by CoC at full resolution; see depth_of_field).
enum class DofResolution : uint8_t { full, half };

struct DofSettings {
  int max_radius = 16;  // pixels: clamp of the CoC radius, also the tile size
  // Gather taps over the neighbourhood's disc (golden-angle spiral). The count matters only for
  // discs of more pixels than taps (R > ~5.5 px), whose blur fewer taps sample more coarsely.
  // FLIP / PSNR against the thin-lens references (`render --reference 256 --reference-dof`,
  // 640x360, 2 frames; the dof pass on `reference/`, `eval --warmup 0`), 48 / 64 / 96 / 128
  // taps: focus 0.0188 / 43.17, 0.0168 / 43.99, 0.0147 / 43.97, 0.0150 / 44.51; bokeh 0.0217 /
  // 33.31, 0.0192 / 34.33, 0.0201 / 35.27, 0.0188 / 35.91; sparkle near (5 blades, f/8, 200 mm,
  // focus 40) 0.0453 / 30.80, 0.0422 / 31.94, 0.0396 / 33.03, 0.0345 / 33.98; sparkle far (f/1.2,
  // focus 0.5) 0.0334 / 27.28, 0.0285 / 28.58, 0.0270 / 29.85, 0.0279 / 30.26; orbit, room and
  // blades at 960x540 f/2 (subtle blur, 64 spp) within 0.0004 FLIP. The `focus` DoF at 1080p
  // (`run --pipeline dof`, 2 threads of a Zen 3 VM, medians of 4): ~58 / ~64 / ~83 / ~95 ms. 96 is
  // a middle: 64 loses 1.1-1.3 dB on sparkle, 128 gains 0.4-1 dB for ~15% more time on large blurs.
  int taps = 96;
  // gather stays the default: it measured closer to the thin-lens reference on `focus` than the
  // diffusion (FLIP 0.0233 vs 0.0242, PSNR 39.07 vs 38.22 dB), and it is also the faster on a
  // CPU: `bench --filter post.dof`, 2 threads, gather / diffusion (4 steps) 0.13 / 1.41 ms at
  // 320x180, 1.59 / 15.2 at 960x540, 11.6 / 70 at 1920x1080; 1.64 / 18.0 at 960x540,
  // 10.9 / 80 at 1920x1080, 71 / 370 at 3840x2160 (another run, a slower hour). The diffusion's
  // cost does not grow with the blur, but each of its 4 steps streams 18 full-resolution
  // planes.
  DofMode mode = DofMode::gather;
  // diffusion: conductivity multiplier (1 = the disc's second moment, dof_diffusion.h)
  float diffusion_scale = 1.0f;
  // diffusion: implicit time steps sharing the same blur (1 = the paper's single ADI step).
  // Measured on `focus` (320x180, frame 0, 16 spp; FLIP / PSNR vs the thin-lens reference):
  // 1 step 0.0279 / 37.16 dB, 2 0.0255 / 37.84, 4 0.0242 / 38.22, 8 0.0235 / 38.41, 16 0.0232 /
  // 38.51; the gather 0.0233 / 39.07. 4: most of the gain at a quarter of 16's cost.
  int diffusion_steps = 4;
  // diffusion: the near field diffused as its own layer over the rest (dof_diffusion.h).
  // Off by default: measured worse on `focus` (1 step 0.0288 / 36.20 dB with it, 0.0279 /
  // 37.16 without; 4 steps 0.0253 / 36.96 vs 0.0242 / 38.22).
  bool diffusion_near_layer = false;
  // gather: half runs the gather of the large blurs at half resolution (UE4, HDRP and Jimenez
  // 2014 gather DoF at half resolution): tiles whose neighbourhood radius reaches half_from
  // take the half-resolution layers, the others the full-resolution gather (blurs under ~4 px
  // are what the 2x2 box and the bilinear upsample cannot render). Measured (demo dof:focus,
  // mean FLIP / PSNR vs the thin-lens reference; 320x180 4 frames 64 spp, 640x360 2 frames
  // 16 spp): full 0.0231 / 39.11 dB and 0.0204 / 39.71; half (half_from 4) 0.0238 / 38.77 and
  // 0.0211 / 39.89; half_from 0 (every blurred tile) 0.0355 / 37.19 and 0.0225 / 39.58.
  // Thresholds 2.5 / 3 / 4 / 5 at 320x180 (frame 0, 16 spp, HDR-FLIP): 0.0537 / 0.0440 /
  // 0.0358 / 0.0347 (= full). 1080p, perf task-clock samples in post:: (1 thread): `focus`
  // full 376-427, half 176-197 (2.1x less); the bench frame (radii mostly <= 3 px, gathered at
  // full resolution either way) full 615-628, half 487-509 (-20%); wall-clock medians (bench,
  // loaded machine, 5 runs) -5 to -16% (50-58 vs 48-51 ms; 82-86 vs 70-73 ms); half_from 0
  // -35 to -40%. full stays the default: half is not clearly faster on the bench frame, and
  // half_from 0 loses 0.012 FLIP at 320x180.
  DofResolution resolution = DofResolution::full;
  // resolution=half: tiles whose neighbourhood radius (full pixels) is at least this take the
  // half-resolution layers, the rest the full-resolution gather (figures above).
  float half_from = 4.0f;
  DofCoc coc = DofCoc::lens;
  // coc=lens: values replacing the frame's lens, 0 = the frame's (f-number, focal length and
  // sensor width in mm, focus distance in scene units as view depth).
  float f_number = 0.0f, focal_length = 0.0f, focus_distance = 0.0f, sensor_width = 0.0f;
  // coc=ranges: view depths (scene units) near_start < near_end <= far_start < far_end, and
  // the radii (pixels, before the max_radius clamp) at near_start and nearer, at far_end and
  // farther. Defaults: a starting point (0-4 and 10-20 units, 8 px either side); the ranges
  // belong to the shot.
  float near_start = 0.0f, near_end = 4.0f, far_start = 10.0f, far_end = 20.0f;
  float near_radius = 8.0f, far_radius = 8.0f;
  // The bokeh's shape: -1 = the frame's lens (its blades and rotation); 0 = disc; 3..16 = a
  // regular polygon of that many blades, a vertex at blade_rotation degrees counter-clockwise
  // from the view's +x (camera/camera.h ThinLens). Also with coc=ranges.
  int blades = -1;
  float blade_rotation = 0.0f;

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

// A gather tap's weight before 1 / r_q^2: `count` merged spiral taps times disc_coverage(r, d),
// as clamp(count r + tap_edge, 0, count) with tap_edge = count (0.5 - d) per tap: one fused
// multiply-add and the clamp per tap and pixel instead of five operations (the same value up to
// rounding; the gather's kernels and the tests' plain gather compute it so).
inline float tap_edge(float count, float d) {
  return count * (0.5f - d);
}
inline float tap_coverage(float count, float r, float edge) {
  const float c = std::fma(count, r, edge);
  return c < 0.0f ? 0.0f : (c > count ? count : c);
}

// The radius with which tap q covers p (depth order): a tap behind p at most p's own radius.
inline float effective_radius(float r_q, float z_q, float r_p, float z_p) {
  return z_q > z_p ? (r_q < r_p ? r_q : r_p) : r_q;
}

// The gather radius of a pixel at view depth `depth`: half the thin lens's CoC diameter
// (circle_of_confusion_px, camera/camera.h; seed 004), clamped to max_radius, 0 where the depth
// is not finite or 0. In float as h |1 - s / z| (h = 0.5 k, k the lens's constant factor): one
// float division a vector of 16 pixels where the double form 0.5 k (z - s) / z took two double
// divisions of 8 (~8 against ~26 cycles of the divider, which had bound the DoF setup). Within
// a few float ulps of circle_of_confusion_px (test: PostDof.GatherRadiusIsTheLensCoc), and each
// operation is monotone in z, so the radius is non-increasing in z in front of the focus plane
// and non-decreasing behind it for every z > 0 (the gather's depth classes rely on it).
struct CocLens {
  // The constant factor a f 1e3 width / ((s - f) sensor_w) of circle_of_confusion_px (in
  // double, then halved and rounded once to float, at most the largest float, so that on the
  // focus plane h t is 0, never infinity times 0) and the focus distance in float.
  double k;
  float h, s, max_radius;
  CocLens(const ThinLens& l, int image_width, int max_radius)
      : k(l.focal_length_mm * 1e-3 / l.f_number * (l.focal_length_mm * 1e-3) /
          (l.focus_distance - l.focal_length_mm * 1e-3) * 1e3 * image_width / l.sensor_width_mm),
        h(float(std::min(0.5 * k, double(std::numeric_limits<float>::max())))),
        s(float(l.focus_distance)),
        max_radius(float(max_radius)) {}
};
// min(h |1 - s / z|, max_radius) of float lanes, 0 where z is 0 or not finite (where
// circle_of_confusion_px is not finite either).
template <class D>
HWY_INLINE V<D> gather_radius_lanes(D d, V<D> depth, const CocLens& c) {
  const V<D> t = hn::Sub(hn::Set(d, 1.0f), hn::Div(hn::Set(d, c.s), depth));
  const V<D> r = hn::Min(hn::Abs(hn::Mul(hn::Set(d, c.h), t)), hn::Set(d, c.max_radius));
  return hn::IfThenElseZero(hn::And(hn::IsFinite(depth), hn::Ne(depth, hn::Zero(d))), r);
}
inline float gather_radius(float depth, const CocLens& c) {
  const OneTag d;
  return hn::GetLane(gather_radius_lanes(d, hn::Set(d, depth), c));
}

// The frame's lens with the settings' replacements (coc=lens; the blades whatever coc).
ThinLens dof_lens(const ThinLens& frame_lens, const DofSettings& s);

// dof_lens for a frame with header `h`, checked as the pass checks it (coc=lens; coc=ranges
// needs no lens). InputError when the frame carries no lens (h.lens_known false: another
// renderer's files, no "lens" in their camera sidecar) and the settings do not give f_number,
// focal_length and focus_distance: ThinLens's defaults are nobody's camera, and blurring by
// them would be a silently wrong image. InputError for an unusable lens (validate_lens).
// `note` hears that a pinhole (f-number 0) leaves the frame unchanged.
ThinLens checked_dof_lens(const FrameHeader& h, const DofSettings& s, const WarnFn& note = {});

// The bokeh of the gather (seed 004: the aperture's shape, as the ray tracer's thin lens
// samples it, camera/aperture.h). A pixel q spreads over q + r_q B: B is the aperture, unit
// circumradius, upright behind the focus plane and point-reflected in front of it (a thin
// lens maps aperture point a to an image offset a (z - s) / (z s), renderer.cpp
// thin_lens_ray), in view coordinates (y up; the image's y runs down). bokeh_distance is B's
// gauge of p - q for the tap at image offset (dx, dy) = q - p: 1 on B's boundary at unit
// circumradius, so a tap covers p as for a disc (disc_coverage) with this distance; the
// Euclidean length for a disc. Never below the Euclidean length (B lies in the unit disc; the
// max keeps a float rounding from letting a 0.5 px pixel reach its neighbour).
struct Bokeh {
  int blades = 0;  // 0: disc; 3..16: polygon
  double rotation_rad = 0.0;
  bool polygon() const { return blades >= 3; }
  // Front and back differ (an odd blade count: the polygon is not point-symmetric).
  bool flips() const { return polygon() && blades % 2 == 1; }
};
Bokeh lens_bokeh(const ThinLens& lens);
float bokeh_distance(const Bokeh& b, int dx, int dy, bool in_front);

// coc=ranges: the gather radius of a pixel at view depth `depth`, min(r, max_radius) with r =
// near_radius clamp((near_end - z) / (near_end - near_start), 0, 1) for z < near_end,
// far_radius clamp((z - far_start) / (far_end - far_start), 0, 1) for z > far_start, else 0
// (also for NaN). Each operation is monotone in z, so the radius is non-increasing up to
// far_start and non-decreasing from near_end on (the gather's depth classes need that).
struct CocRanges {
  float near_end, far_start, inv_near, inv_far, near_radius, far_radius, max_radius;
  explicit CocRanges(const DofSettings& s)
      : near_end(s.near_end),
        far_start(s.far_start),
        inv_near(1.0f / (s.near_end - s.near_start)),
        inv_far(1.0f / (s.far_end - s.far_start)),
        near_radius(s.near_radius),
        far_radius(s.far_radius),
        max_radius(float(s.max_radius)) {}
};
template <class D>
HWY_INLINE V<D> range_radius_lanes(D d, V<D> depth, const CocRanges& c) {
  const V<D> zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  const auto unit = [&](V<D> t) { return hn::Min(hn::Max(t, zero), one); };
  const V<D> near =
      hn::Mul(hn::Set(d, c.near_radius),
              unit(hn::Mul(hn::Sub(hn::Set(d, c.near_end), depth), hn::Set(d, c.inv_near))));
  const V<D> far =
      hn::Mul(hn::Set(d, c.far_radius),
              unit(hn::Mul(hn::Sub(depth, hn::Set(d, c.far_start)), hn::Set(d, c.inv_far))));
  const V<D> r = hn::IfThenElse(hn::Lt(depth, hn::Set(d, c.near_end)), near,
                                hn::IfThenElseZero(hn::Gt(depth, hn::Set(d, c.far_start)), far));
  return hn::Min(r, hn::Set(d, c.max_radius));
}
inline float range_radius(float depth, const CocRanges& c) {
  const OneTag d;
  return hn::GetLane(range_radius_lanes(d, hn::Set(d, depth), c));
}
// The signed CoC diameter (pixels, negative in front) of the pass's source at a view depth:
// the lens's circle_of_confusion_px, or -2 / +2 range_radius (unclamped by max_radius) in front
// of near_end / behind far_start. Made once per frame; the diffusion mode reads it per pixel.
class SignedCoc {
 public:
  SignedCoc(const DofSettings& s, const ThinLens& lens);
  double operator()(double depth, int width) const {
    if (!ranges_) return circle_of_confusion_px(lens_, depth, width);
    const double r = range_radius(float(depth), range_);
    return depth < range_.near_end ? -2.0 * r : 2.0 * r;
  }

 private:
  bool ranges_;
  ThinLens lens_;
  CocRanges range_;  // max_radius unbounded
};

// Half resolution: the 2x2 box of the downsample and the bilinear upsample blur by themselves,
// with a variance of about 1 full pixel^2 per axis (1/3 for the box, 2/3 for the tent). A disc
// of radius r has r^2 / 4 per axis, so the half-resolution gather uses the radius whose disc
// adds the rest: sqrt(r^2 - 4) full pixels, in half pixels (0 for r <= 2).
// The resampling's blur in px^2 per axis. Measured on `focus` (frame 0, 16 spp, HDR-FLIP at
// 320x180 / 640x360 with half_from 0): 0.25 0.0731 / 0.0375, 0.5 0.0663 / 0.0358, 1 0.0528 /
// 0.0335, 1.5 0.0464 / 0.0339, 2 0.0602 / 0.0383; with half_from 4: 1 is within 0.0005 of the
// best at both sizes.
constexpr float kHalfResVariance = 1.0f;
inline float half_res_radius(float r) {
  const float e = r * r - 4.0f * kHalfResVariance;
  return e > 0.0f ? 0.5f * std::sqrt(e) : 0.0f;
}
// The composite of the half-resolution gather at a full-resolution pixel of gather radius r
// (full pixels): far and near layers (premultiplied by their share of the gather's weight;
// their sum is the plain gather) and the near layer's share nf, all upsampled. The blurred
// far layer weighs a, the sharp color (1 - a)(1 - nf), under the near layer with its own alpha
// so the blurred foreground still spreads over sharp pixels (Bukowski et al. 2013; HDRP and UE4
// composite their half-resolution layers by CoC so): near + a far + (1 - a)(1 - nf) sharp.
// a matches the variances: the resampled blur's 1 px^2 times a is the disc's r^2 / 4 up to
// r = 2; 0 in the focus field (r <= 0.5), so the focus field keeps its color.
template <class D>
HWY_INLINE V<D> half_res_blend_lanes(D d, V<D> r) {
  const V<D> a = hn::Div(hn::Sub(hn::Mul(r, r), hn::Set(d, 0.25f)),
                         hn::Set(d, 4.0f * kHalfResVariance - 0.25f));
  return hn::Min(hn::Max(a, hn::Zero(d)), hn::Set(d, 1.0f));
}
inline float half_res_blend(float r) {
  const OneTag d;
  return hn::GetLane(half_res_blend_lanes(d, hn::Set(d, r)));
}

// Each tile's largest value over its 3x3 tiles (`tile` is tw x th, row-major, values >= 0):
// how far a disc from a neighbouring tile can reach into this one (the gather's NeighborMax).
std::vector<float> tile_neighbor_max(const std::vector<float>& tile, int tw, int th);

// The pass's checks and its lens (checked_dof_lens): SettingsError for bad settings, InputError
// for a frame without depth, a color of another size, or no usable lens. nullopt where the pass
// returns the color unchanged: coc=lens and a lens, after the settings' replacements, that is a
// pinhole (f_number 0).
std::optional<ThinLens> checked_dof_input(const Frame& frame, const ImageF& color,
                                          const DofSettings& s);

// The gather (mode=gather, full or half resolution) written plainly, pixel by pixel: the
// specification the pass's fast schedule (dof_gather_fast.cpp) equals bit for bit, for any
// thread count. SettingsError for mode=diffusion, which it does not state.
ImageF dof_reference(const Frame& frame, const ImageF& color, const DofSettings& s,
                     const Exec& exec = {});

// The pass: checked_dof_input, then the gather or the diffusion (mode). With exec.simd false
// (--simd off) the gather is dof_reference.
ImageF depth_of_field(const Frame& frame, const ImageF& color, const DofSettings& s,
                      const Exec& exec = {});

}  // namespace afterimage::post
