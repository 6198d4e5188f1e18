// Forward reprojection (issue 13; seed 004 "Reprojection Techniques"): the pixels of a
// rendered frame are pushed ("splatted") into another frame's camera, instead of each target
// pixel pulling its history (history.h, the reverse direction). Nothing is shaded twice, but
// target pixels that no source pixel lands in are holes — disocclusions (what the source never
// saw) and stretched surfaces (one source pixel covering more than one target pixel) — and
// have to be guessed from their surroundings. The seed's point, measured in
// tests/reproject_forward_test.cpp: the hole fill is the weak part.
//
// Conventions (DESIGN.md §3): pixel centers at i + 0.5, y down; a source pixel (x, y) took its
// sample at (x + 0.5 + j_src.x, y + 0.5 + j_src.y) of the unjittered image plane; a
// displacement moves that sample to the target frame's unjittered image plane (motion_next =
// p_next - p_curr, motion = p_prev - p_curr, or the camera-only transfer through depth); the
// target pixel whose sample (y + 0.5 + j_dst) is nearest is floor(x + 0.5 + j_src + disp -
// j_dst) per axis. Several samples landing on one pixel: the nearest in the target view wins
// (a z-buffer; Mark, McMillan & Bishop 1997, "Post-rendering 3D warping", resolve occlusion
// by depth-ordered splats).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/math.h"
#include "core/parallel.h"
#include "frame/frame.h"
#include "reproject/history.h"

namespace afterimage::reproject {

// Where source pixel (x, y), sampled at jitter `source_jitter`, lands in the target frame:
// floor(x + 0.5 + source_jitter + displacement - target_jitter) per axis; nothing if that is
// outside the target image or the displacement is not finite.
std::optional<PixelCoord> splat_target_position(int x, int y, Vec2d source_jitter,
                                                Vec2d displacement, Vec2d target_jitter, int width,
                                                int height);

// The camera-only transfer between two frames of one size: a source sample at depth d is
// unprojected with the source's view and (unjittered) projection and projected with the
// target's. Objects that moved land where they were in the source frame (the cameras know
// nothing of them).
struct CameraTransfer {
  Mat4 source_projection;  // unjittered
  Mat4 source_to_world;    // inverse of the source view
  Mat4 target_view;
  Mat4 target_view_projection;  // unjittered
  int width = 0, height = 0;
  static CameraTransfer between(const FrameHeader& source, const FrameHeader& target);
};

struct Reprojected {
  bool valid = false;         // false: behind the target camera, or a degenerate projection
  Vec2d displacement;         // target position - source sample position, pixels, y down
  float target_depth = 0.0f;  // linear depth in the target view; kBackgroundDepth for sky
};

// Camera-only displacement of the sample at unjittered position `sample` (pixels) and linear
// depth `depth`. Sky (depth >= kBackgroundDepth) is a direction at infinity (w = 0; it moves
// with the camera's rotation only) under a perspective source; an orthographic source's sky
// is the point on its far plane, as the renderer takes it.
Reprojected camera_displacement(const CameraTransfer& t, Vec2d sample, float depth);

// Which displacement a source frame's pixels take to the target.
enum class DisplacementKind : uint8_t {
  motion_next,  // the source's motion_next channel (the target is the next frame)
  motion,       // the source's motion channel (the target is the previous frame)
  camera,       // camera_displacement through depth (any pair of frames, camera motion only)
};
const char* displacement_kind_name(DisplacementKind k);  // "motion_next", "motion", "camera"

// Per source pixel: displacement (2 planes; NaN where the sample lands nowhere) and depth in
// the target view (1 plane). With the motion kinds the target depth comes from the camera-only
// transfer (a moving object's depth change is ignored: it only orders samples that land on one
// pixel). Needs the source's depth, and the motion channel the kind names.
struct DisplacementField {
  ImageF displacement;
  ImageF target_depth;
};
DisplacementField displacement_field(const Frame& source, const FrameHeader& target,
                                     DisplacementKind kind, const Exec& ex = {});

// The result of splatting one or more frames into a target frame.
struct ForwardSplat {
  ImageF color;         // 3 planes; 0 at holes
  ImageF depth;         // linear depth of the winning sample in the target view; kBackgroundDepth
                        // at holes (and sky)
  ImageU32 sources;     // samples that landed on the pixel (any depth)
  Image<uint8_t> hole;  // 1 where no sample landed
  // Where the winning sample landed relative to the pixel's own sample position (y + 0.5 +
  // target jitter), pixels, 2 planes, each in [-0.5, 0.5); NaN at holes.
  ImageF sample_offset;
  // Stretched surfaces (Mark, McMillan & Bishop 1997: a sample's footprint is its neighbours'
  // spacing after the warp): hole pixels inside the warped quad of four neighbouring source
  // samples of one surface get that surface's color (the corner nearest the pixel, clamped
  // per channel to the range of the other three corners: a one-sample glint or firefly is not
  // copied) and depth here; fills use it before guessing. A hole stays a hole in `hole`.
  ImageF stretch_color;          // 3 planes
  ImageF stretch_depth;          // kBackgroundDepth where no quad covers the pixel
  Image<uint8_t> stretch_valid;  // 1 where a quad covers a hole pixel

  static ForwardSplat empty(int width, int height);
  int width() const { return color.width(); }
  int height() const { return color.height(); }
  size_t hole_count() const;
  double hole_fraction() const;
};

// The depth test of one target pixel: a sample nearer than the current one by more than
// kSameSurfaceDepthRatio (relative) wins, a farther one loses; within that ratio both lie on
// one surface and the sample whose position is nearer the pixel's own sample position wins
// (`offset`: squared distance in pixels), strictly, so the earlier sample keeps a tie.
// Measured on `motion` (96x54, Halton jitter): a pure z-buffer picked, among the several
// samples of one surface that land on a pixel when splatting the next frame back or two
// frames at once, whichever was marginally nearer; the offset rule lowered the error of
// interpolated frames (tests/reproject_forward_test.cpp).
inline constexpr float kSameSurfaceDepthRatio = 0.01f;
bool sample_wins(float depth, float offset, float current_depth, float current_offset);

// Splats every pixel of `source` (color) into `into` along `field` (displacement_field of
// the same source), each sample to the pixel splat_target_position gives, through the depth
// test sample_wins (sources in call order, pixels in row-major order). Serial: O(pixels), and
// bit-identical for any thread count. `target_jitter` is the target frame's jitter.
void splat_frame(const Frame& source, const DisplacementField& field, Vec2d target_jitter,
                 ForwardSplat& into);

// The hole fills. Each returns the splat's color with every hole pixel replaced; other pixels
// are copied unchanged.
//  * naive (the baseline): the nearest non-hole pixel in the same row, either side, ties to
//    the left, depth ignored; a row without any takes the value the nearest such row has in
//    the same column (ties upward); all black if the splat is empty.
//  * background (Mark, McMillan & Bishop 1997: a disocclusion reveals what lies behind, so
//    fill from the far side; cracks are not disocclusions). The first sample in each of the
//    8 directions. (0) A stretched surface: a hole inside the warped quad of four neighbouring
//    source samples of one surface (ForwardSplat::stretch_*) takes the nearest corner's color,
//    clamped per channel to the range of the other three corners (a corner outside it is a
//    feature smaller than the sample spacing, which the hole's own sample most likely misses).
//    (1) A crack: all of them within kBackgroundDepthRatio of each other (one
//    surface around the hole, stretched past the one-pixel splats) -> their mean weighted
//    by 1 / d^4 (d: distance to where each sample really landed, sample_offset). (2) A crack
//    across one axis: the two samples facing each other in the row (else the column) on one
//    surface -> their 1 / d^4 mean. (3) Otherwise a disocclusion: of the row's samples (all
//    8 if the row has none), those within kBackgroundDepthRatio of the farthest, and of
//    those a copy of the one that landed nearest. Measured (FillComparison, 192x108, frames
//    1-8 extrapolated from frame 0, mean hole error over the 8 moving scenes of the time):
//    (3) alone 0.0581, + (1) 0.0467, + (1) and (2) 0.0427, + (0) on all 9 scenes 0.0383
//    (0.0412 without); naive 0.0669. With 11 moving scenes: (0) copying the nearest corner
//    0.0338, clamped 0.0324, naive 0.0594; the clamp turned `sparkle` (0.0446 -> 0.0367,
//    naive 0.0430) into a win, so the default beats naive on every scene; held out (256x144,
//    frames 13-20 from frame 12, never used to choose): 0.0260 -> 0.0246, naive 0.0537,
//    also a win on every scene. The row comes first in (3):
//    holes of horizontal motion are vertical strips, and perspective compresses ground
//    textures vertically.
//  * push_pull (Gortler et al. 1996 "The Lumigraph", Grossman & Dally 1998 "Point sample
//    rendering"): pull: a pyramid of 2x2 weighted means, each level's weight the children's
//    sum clamped to 1; push: from the coarsest level down, a pixel of weight w becomes
//    w * own + (1 - w) * the coarser level bilinearly upsampled. Smooth, depth-blind.
//  * push_pull_background: push-pull whose pull keeps, of the 2x2 children, only those within
//    kBackgroundDepthRatio of the farthest: coarse levels hold the background, so a
//    disocclusion is filled from behind the occluder, and a crack in a surface still from
//    that surface.
// Which wins is measured (tests/reproject_forward_test.cpp "FillComparison"); the default is
// the winner.
inline constexpr float kBackgroundDepthRatio = 0.9f;  // depth >= 0.9 * farthest: background
ImageF fill_holes_naive(const ForwardSplat& s, const Exec& ex = {});
ImageF fill_holes_background(const ForwardSplat& s, const Exec& ex = {});
ImageF fill_holes_push_pull(const ForwardSplat& s, bool background_only, const Exec& ex = {});

enum class HoleFill : uint8_t { naive, background, push_pull, push_pull_background };

// The fill registry: one row per fill, its CLI name and a one-line description.
struct HoleFillInfo {
  HoleFill fill;
  const char* name;
  const char* description;
};
const std::vector<HoleFillInfo>& hole_fills();
std::vector<std::string> hole_fill_names();
const char* hole_fill_name(HoleFill f);
HoleFill parse_hole_fill(const std::string& name);  // throws SettingsError listing the names

struct FillSettings {
  // Chosen by measurement on the 11 moving built-in scenes (issue 13; 192x108, frames 1-8
  // from frame 0; tests/reproject_forward_test.cpp "FillComparison"): mean display-space error
  // over hole pixels background 0.0324, naive 0.0594, push-pull 0.0497, push-pull-background
  // 0.0481, the lowest over the whole image too, and below naive on every scene; the held-out
  // configuration (256x144, frames 13-20 from frame 12) agrees: 0.0246, 0.0537, 0.0455,
  // 0.0434.
  HoleFill fill = HoleFill::background;
};
ImageF fill_holes(const ForwardSplat& s, const FillSettings& settings, const Exec& ex = {});

}  // namespace afterimage::reproject
