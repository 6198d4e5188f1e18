// Motion blur as a post process over the G-buffer (issue 12; seed 004 "Motion Blur"):
// McGuire, Hennessy, Bukowski, Osman, "A Reconstruction Filter for Plausible Motion Blur"
// (I3D 2012), with the mirrored sample pairs of Jimenez, "Next Generation Post Processing in
// Call of Duty: Advanced Warfare" (SIGGRAPH 2014).
//
// The exposure of a frame is `shutter` of the frame interval centred on the frame time, so a
// point moving by m pixels per frame sweeps m * shutter pixels, centred on where it is drawn.
// Velocities are clamped to `max_radius` pixels of half-length. Per tile of max_radius x
// max_radius pixels the largest velocity (TileMax), then the largest of the 3x3 tiles around
// (NeighborMax) bound what can blur into a pixel; pixels whose neighbourhood is still keep
// their color exactly (the early exit); a neighbourhood that moves as one is box-filtered along
// its motion (the fast path, no depth tests; taps at most fast_tap_spacing apart, at most
// `samples`). Otherwise (the full path) `samples` taps along the neighbourhood's dominant
// velocity, placed symmetrically in mirrored pairs with a per-pixel jitter of half a sample
// (against banding), each weighted by McGuire's cone (a tap moving over this
// pixel), the reverse cone (this pixel moving over the tap) and the cylinder pair (both moving
// together), each gated by a soft depth comparison so that a still background is never smeared over
// a moving foreground and a foreground smears over the background. The per-pixel work is in
// float, within 3e-7 of the double-precision form on the tests' frames: written plainly in
// motion_blur_reference.cpp (what --simd off runs), and on Highway lanes in blocks of one path
// in motion_blur_fast.cpp, the same bits.
//
// Sequence options (issue 12 list; seed 004 "Motion Blur" names camera orientation, camera
// position and object motion as separate sources of blur):
//  * Separate clamps: a pixel's motion splits into the camera-only part — the motion a still
//    point at the pixel's depth has between the previous and this frame's camera
//    (reproject::camera_displacement, the reverse of Rosado's GPU Gems 3 velocity from depth)
//    — and the rest, object motion. Each half vector is clamped to its own radius, then their
//    sum to max_radius (the tile size bounds any blur).
//  * camera_rotation=false: the camera part is recomputed as if the previous camera had this
//    frame's orientation, so only the camera's translation (parallax) and objects blur; a
//    pure camera turn gives no blur.
//  * Trail (seed 004's accumulation trick): a running sum over the last N outputs — add the
//    newest, subtract the one leaving the window, divide by the frames in it.
// All three need earlier frames, so they live in MotionBlurSequence; the stateless pass
// knows no previous camera and treats all motion as object motion (as MotionBlurSequence does
// on the first frame and after a camera cut).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/math.h"
#include "core/parallel.h"
#include "core/params.h"
#include "frame/frame.h"

namespace afterimage::post {

struct MotionBlurSettings {
  float shutter = 0.5f;      // fraction of the frame interval the shutter is open (180 degrees)
  int max_radius = 20;       // pixels: half-length clamp of the blur and the tile size
  int samples = 15;          // taps along the dominant velocity (odd: the centre is the pixel)
  float soft_depth = 0.02f;  // relative depth extent of the soft comparison
  // Separate clamps of the camera and object half vectors, pixels; 0 = no separate clamp (only
  // max_radius on the total, as before the split existed). Either > 0 makes the pass split the
  // motion. (A clamp equal to max_radius is not the same as none: a camera part and an object
  // part each longer than max_radius but opposed would be shortened before they cancel.)
  int camera_max_radius = 0;
  int object_max_radius = 0;
  bool camera_rotation = true;  // false: the camera's rotation does not blur (needs the split)
  // Running-sum trail over the pass's outputs of the last N frames; 1 = off. With shutter=0
  // it is seed 004's plain accumulation of the frames (stroboscopic copies).
  int trail_frames = 1;
  // NeighborMax read at a per-pixel offset of up to tile_jitter tiles (Jimenez 2014: hides
  // the tile grid); 0 = the pixel's own tile.
  float tile_jitter = 0.0f;
  // Fast path (Jimenez 2014): where every half vector of the 3x3 tiles around lies within a
  // box of this many pixels per axis, the whole neighbourhood translates together and the
  // exact blur is the box filter along the motion, so the taps are averaged with equal
  // weights and no depth test. 0 = always the full path. On the demo's 360-degree references
  // (motion, orbit, blades, cut, room at 320x180) it changes no metric in the third decimal
  // and halves the time where whole tiles move together.
  float uniform_tolerance = 0.5f;
  // Jimenez 2014's mirrored weights of a tap pair: the tap in front that moves at least as fast
  // as its partner is the foreground blurring over both, so the partner takes its weight (the
  // background behind a moving silhouette is guessed from the side it uncovers). Measured on
  // the same references: PSNR motion 42.51 -> 42.85, room 50.41 -> 51.15, orbit, blades and
  // cut equal within 0.02 dB and FLIP within 0.0001, so on by default.
  bool mirror_weights = true;
  // Fast path only: ceil(|v| / spacing) tap pairs per pixel (1 .. samples' pairs), taps at most
  // `spacing` pixels apart, so a short blur takes fewer taps (at |v| = 1 px, 15 samples put 14
  // taps on 3 pixels); 0 = always `samples`. Against the closed-form box of a uniformly moving
  // plane (post_motion_blur_test) 0.5 measured 44.15 / 45.40 / 39.53 dB at 2 / 4 / 16 px/frame
  // (shutter 1) vs 43.39 / 42.26 / 39.53 with all samples (1 px: 34.00 / 28.93 / 39.53); the
  // demo's ray-traced references (motion, orbit, cut, blades at 320x180) are unchanged at
  // printed precision; the 1080p bench frame's pass -35% CPU. So 0.5 by default.
  float fast_tap_spacing = 0.5f;

  static const ParamTable<MotionBlurSettings>& params();
  void set_assignment(const std::string& assignment);
  void validate() const;
};

// ---- Per-pixel functions (McGuire et al. 2012, Sec. 3) ------------------------------------

// Half-length blur vector of a pixel: motion m (p_prev - p_curr) reversed to the direction of
// travel, times the shutter, halved, clamped to `max_radius` (keeps direction).
inline Vec2d blur_half_vector(float mx, float my, float shutter, int max_radius) {
  Vec2d v{-0.5 * shutter * mx, -0.5 * shutter * my};
  const double len = std::sqrt(v.x * v.x + v.y * v.y);
  if (!(len <= max_radius))
    v = len > 0 && std::isfinite(len) ? v * (max_radius / len) : Vec2d{0, 0};
  return v;
}
// 1 - |x - y| / |v|, clamped: a tap y whose blur of half-length |v| reaches x.
inline double cone_weight(double distance, double v_len) {
  return std::clamp(1.0 - distance / std::max(v_len, 1e-6), 0.0, 1.0);
}
// 1 - smoothstep(0.95 |v|, 1.05 |v|, distance): both inside the same blur.
inline double cylinder_weight(double distance, double v_len) {
  const double a = 0.95 * v_len, b = 1.05 * v_len;
  if (distance <= a) return 1.0;
  if (distance >= b) return 0.0;
  const double t = (distance - a) / (b - a);
  return 1.0 - t * t * (3.0 - 2.0 * t);
}
// `v` shortened to length `radius` if longer; radius <= 0: unchanged. Non-finite: zero.
inline Vec2d clamp_length(Vec2d v, double radius) {
  const double len = std::sqrt(v.x * v.x + v.y * v.y);
  if (!std::isfinite(len)) return {0, 0};
  return radius > 0 && len > radius ? v * (radius / len) : v;
}
// Half vector of a pixel with motion `motion` whose camera-only part is `camera_motion`
// (both p_prev - p_curr): the object part motion - camera_motion and the camera part the blur
// uses, `blurred_camera_motion` (camera_motion, or its translation-only twin), each turned
// into a half vector as blur_half_vector does and clamped to its own radius (0: unclamped),
// their sum clamped to max_radius.
inline Vec2d split_blur_half_vector(Vec2d motion, Vec2d camera_motion, Vec2d blurred_camera_motion,
                                    float shutter, int camera_max_radius, int object_max_radius,
                                    int max_radius) {
  const double k = -0.5 * shutter;
  const Vec2d cam = clamp_length(blurred_camera_motion * k, camera_max_radius);
  const Vec2d obj = clamp_length((motion - camera_motion) * k, object_max_radius);
  return clamp_length(cam + obj, max_radius);
}
// The view matrix of a camera at `previous`'s position with `current`'s orientation: the
// previous camera with its rotation undone, for camera_rotation=false. Rigid views only.
Mat4 view_without_rotation_change(const Mat4& previous, const Mat4& current);

// clamp(1 - (z_a - z_b) / (extent * min(z_a, z_b)), 0, 1): 1 when a is in front of b (or level).
inline double soft_depth_compare(double z_a, double z_b, double extent) {
  return std::clamp(1.0 - (z_a - z_b) / (extent * std::min(z_a, z_b)), 0.0, 1.0);
}

// The per-pixel tap jitter in [-0.5, 0.5) (against banding): a hash of the pixel,
// deterministic and thread-independent, n = h >> 8 < 2^24 scaled to (n - 2^23) 2^-24 (exact in
// float). The fast schedule computes it on lanes (pixel_jitter_lanes), the same values.
inline float tap_jitter(int x, int y) {
  uint32_t h = uint32_t(x) * 0x8da6b343u ^ uint32_t(y) * 0xd8163841u;
  h ^= h >> 15;
  h *= 0x2c1b3c6du;
  h ^= h >> 12;
  return float(int32_t(h >> 8) - (1 << 23)) * (1.0f / 16777216.0f);
}
// A second, independent per-pixel value in [-0.5, 0.5) (other constants, a salt per axis):
// the tile lookup's jitter must not correlate with the tap jitter.
inline double tile_jitter_hash(int x, int y, uint32_t salt) {
  uint32_t h = (uint32_t(x) * 0x9e3779b1u + salt) ^ uint32_t(y) * 0x85ebca77u;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return double(h >> 8) * (1.0 / 16777216.0) - 0.5;
}
// Tile of the NeighborMax lookup for pixel coordinate x (tiles of k pixels): its own, or
// (Jimenez 2014) the one under x + 0.5 + an offset of up to `offset_tiles` tiles, inside the
// grid.
inline int jittered_tile(int x, double offset_tiles, int k, int tiles) {
  if (offset_tiles == 0.0) return x / k;
  const int t = int(std::floor((x + 0.5) / k + offset_tiles));
  return std::clamp(t, 0, tiles - 1);
}

// True when the settings split camera from object motion (a separate clamp or
// camera_rotation=false), which needs the previous frame's camera.
bool splits_camera_motion(const MotionBlurSettings& s);
// InputError when the settings split the camera's motion from the objects' (above) and the
// frame carries no camera (h.camera_known false: another renderer's files, no view and
// projection in a camera sidecar): the split would find no camera motion and blur all of it
// as object motion, the settings silently doing nothing.
void check_motion_blur_camera(const FrameHeader& h, const MotionBlurSettings& s);
// True when the pass depends on earlier frames (the split or the trail).
bool keeps_frames(const MotionBlurSettings& s);

// InputError for a frame without depth or motion, or (color given) a color of another size.
void check_motion_blur_input(const Frame& frame, const ImageF* color);

// The pass written plainly, pixel by pixel (motion_blur_reference.cpp): the specification the
// fast schedule (motion_blur_fast.cpp) equals bit for bit, for any thread count and every
// setting; what --simd off runs. The trail is not applied here (MotionBlurSequence).
ImageF motion_blur_reference(const Frame& frame, const ImageF& color, const MotionBlurSettings& s,
                             const FrameHeader* previous = nullptr, const Exec& exec = {});

// The pass: `frame` gives color, depth and motion. SettingsError for bad settings, InputError
// for a frame without depth or motion, or without the camera a split needs. Non-finite motion
// counts as still. With the defaults (no split, no trail) the result depends on this frame alone.
ImageF motion_blur(const Frame& frame, const ImageF& color, const MotionBlurSettings& s,
                   const Exec& exec = {});
// The same with the previous frame's camera for the split; `previous` null (first frame,
// camera cut, or unknown): all motion is object motion. The trail is not applied here.
ImageF motion_blur(const Frame& frame, const ImageF& color, const MotionBlurSettings& s,
                   const FrameHeader* previous, const Exec& exec = {});
// The per-pixel half vectors the pass blurs along (2 planes, pixels, direction of travel),
// after the split and the clamps.
ImageF motion_blur_half_vectors(const Frame& frame, const MotionBlurSettings& s,
                                const FrameHeader* previous, const Exec& exec = {});
// TileMax (McGuire et al. 2012) of those half vectors: per tile of max_radius pixels square
// (row-major; the last row and column of tiles clipped to the image) the first of the longest
// in row order and the box holding all of them.
struct MotionTile {
  Vec2d longest;
  double min_x, max_x, min_y, max_y;
};
std::vector<MotionTile> motion_blur_tile_max(const Frame& frame, const MotionBlurSettings& s,
                                             const FrameHeader* previous, const Exec& exec = {});

// Seed 004's running sum over a moving window of frames: push() adds the newest image,
// subtracts the one that leaves the window and returns the sum divided by the frames in it
// (fewer than N at the start). Sums are double; non-finite values count as 0 (one would
// poison the sum for good). Every time the window has turned over once the sum is rebuilt
// from the stored frames, so rounding from adding and subtracting cannot drift. Memory:
// N images.
class RunningSumTrail {
 public:
  ImageF push(const ImageF& image, int frames, const Exec& exec = {});
  void reset();
  int size() const { return int(window_.size()); }

 private:
  std::deque<ImageF> window_;
  std::vector<double> sum_;
  int pushes_since_rebuild_ = 0;
};

// The pass over a sequence, frame by frame in order: remembers the previous frame's camera
// for the split and the trail window. A frame with camera_cut, or of another size than the
// previous one, starts afresh (no previous camera: all motion is object motion; the trail
// restarts from this frame).
class MotionBlurSequence {
 public:
  ImageF process(const Frame& frame, const ImageF& color, const MotionBlurSettings& s,
                 const Exec& exec = {});
  void reset();

 private:
  bool has_previous_ = false;
  FrameHeader previous_;
  RunningSumTrail trail_;
};

}  // namespace afterimage::post
