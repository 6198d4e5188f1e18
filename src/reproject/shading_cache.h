// Reverse reprojection shading cache (issue 13; seed 004 "Reprojection Techniques"; Nehab,
// Sander, Lawrence, Tatarchuk, Isidoro, "Accelerating Real-Time Shading with Reverse
// Reprojection Caching", Graphics Hardware 2007). The renderer draws the cheap G-buffer of
// every pixel each frame; the cache decides which pixels' expensive shading (the direct light
// through shadow rays) is computed anew and which reuse the previous frame's value, looked up
// at p + motion (the seed's screen-space velocity-buffer variant: every test is done with the
// two G-buffers, no second transform of the geometry).
//
// A lookup is a hit only if every in-image tap of its 2x2 bilinear footprint shows the same
// surface (object id, depth with a slope-scaled tolerance, normal angle): conservative, so a
// point whose previous surface was not visible is a miss (Nehab et al. Sec. 3.2 test depth at
// the reprojected point; requiring all four taps also rejects edges a point lies next to).
// Reused shading goes stale when lights or objects move ("do not reuse shading over too many
// frames"), so every pixel is also re-shaded on a stratified schedule and whenever the value
// it would reuse is `refresh` frames old (a bilinear value's age: its taps' ages by weight). The
// running-average mode instead shades every pixel each frame (with few light samples) and blends it
// into the reprojected value, retiring old values exponentially (the seed's running-average filter;
// Nehab et al. Sec. 4.2, Scherzer et al. 2007 for shadows).
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/parallel.h"
#include "core/params.h"
#include "frame/frame.h"

namespace afterimage::reproject {

enum class CacheMode : uint8_t {
  Reuse,    // shade misses and refreshes; hits reuse the cached value
  Average,  // shade every pixel; blend into the reprojected value (running average)
};

struct ShadingCacheSettings {
  CacheMode mode = CacheMode::Reuse;
  // Reuse: every pixel re-shaded at least every `refresh` frames (1 = every frame).
  int refresh = 8;
  // Average: weight of the new sample once the history holds 1 / alpha samples (before, the
  // plain mean 1 / n so a miss converges fast, as SVGF's alpha = max(alpha, 1/n)).
  float alpha = 0.1f;
  // Consistency tests of each tap (Nehab et al. 2007 Sec. 3.2; SVGF Sec. 4.1).
  float depth_tolerance = 0.02f;  // relative: |d_prev - d| <= tol * d + slope term
  float depth_slope = 1.0f;       // times |grad d| (depth per pixel) times the tap distance
  float normal_cos = 0.9f;        // dot(n_prev, n) >= this per tap (about 25 degrees)
  // The previous normal interpolated at the lookup position against the current one: a
  // surface that turned (a rotating object) is shaded anew, since N.L changed, while curved
  // still surfaces interpolate to their own normal. cos(2 degrees).
  float turn_cos = 0.99939f;
  // Surfaces that move on their own (motion differs from what the camera alone explains by
  // more than `object_motion` pixels) are re-shaded every `object_refresh` frames: their
  // light and shadows change as they move through the scene's light (Nehab et al. 2007
  // refresh everything on one period; a moving object goes stale much faster than still
  // geometry under a moving camera).
  float object_motion = 0.05f;
  int object_refresh = 2;
  // Change detection: a refresh that finds its shading changed by more than this fraction
  // (of the larger luminance) marks its 8x8 tile, and the next frame re-shades every hit in
  // and next to marked tiles. Shadows of moving objects and moving lights change shading on
  // still surfaces, which no geometric test sees; the refreshes are samples of that change
  // (the idea of A-SVGF's temporal gradients, Schied et al. 2018). 0 disables.
  float change_threshold = 0.1f;

  static const ParamTable<ShadingCacheSettings>& params();
  void set_assignment(const std::string& assignment);  // "key=value"
  void validate() const;                               // SettingsError naming the field
  std::string describe() const;
  std::string to_json() const;
};

const char* to_string(CacheMode m);

// Why a pixel is shaded this frame (or not). Misses are counted by their first failing test
// in this order.
enum class CacheOutcome : uint8_t {
  Background,  // sky: no surface, nothing to shade
  Hit,         // reused (reuse mode) or blended (average mode)
  NoHistory,   // first frame, camera cut, size change
  Offscreen,   // p + motion outside the previous frame
  IdMiss,      // a tap shows another object
  DepthMiss,   // a tap's depth differs
  NormalMiss,  // a tap's normal differs, or the surface turned (turn_cos)
  Scheduled,   // a hit re-shaded by the stratified schedule (reuse mode)
  Moving,      // a hit on a surface moving on its own, re-shaded (object_refresh)
  Changed,     // a hit near where last frame's refreshes found the shading changed
  Stale,       // a hit whose value would be `refresh` frames old (reuse mode)
};

struct ShadingCacheCounters {
  int64_t pixels = 0;
  int64_t background = 0;  // sky pixels (never shaded, no cost)
  int64_t hits = 0;  // values taken from the cache without shading (reuse) / blended (average)
  int64_t no_history = 0, offscreen = 0, id_miss = 0, depth_miss = 0, normal_miss = 0;
  int64_t scheduled = 0, stale = 0;  // refreshes of hits (reuse mode)
  int64_t moving = 0;                // refreshes of hits on moving objects (reuse mode)
  int64_t changed = 0;               // refreshes of hits near detected change (reuse mode)
  int64_t shaded = 0;                // pixels whose shading ran this frame
  int max_age = 0;                   // oldest value in the output (frames since shaded)
  int64_t misses() const { return no_history + offscreen + id_miss + depth_miss + normal_miss; }
  double shaded_fraction() const { return pixels > 0 ? double(shaded) / double(pixels) : 0.0; }
  ShadingCacheCounters& operator+=(const ShadingCacheCounters& o);
};

// ---- Per-pixel functions -------------------------------------------------------------------

// Where the surface seen by pixel (x, y) of the current frame was sampled in the previous
// frame's pixel grid (DESIGN.md §3): the current sample sits at x + 0.5 + j_cur in the
// unjittered image plane, motion m = p_prev - p_curr moves it into the previous frame, and
// the previous frame's sample of pixel i sits at i + 0.5 + j_prev. Returned in "pixel-center"
// coordinates: the previous pixel i's sample is at i + 0.5.
inline void cache_lookup_position(int x, int y, double jx, double jy, float mx, float my,
                                  double prev_jx, double prev_jy, double* px, double* py) {
  *px = x + 0.5 + jx + double(mx) - prev_jx;
  *py = y + 0.5 + jy + double(my) - prev_jy;
}

// Stratified refresh phase of pixel (x, y) for period k: the 8x8 Bayer (ordered dither) rank
// scaled to [0, k), so each frame re-shades an evenly spread 1/k of every 8x8 block
// (Nehab et al. 2007 Sec. 4.1 refresh the cache in a staggered pattern for an even load).
inline int refresh_phase(int x, int y, int k) {
  // Bayer rank by bit interleaving (x ^ y, y) (Ulichney 1987).
  const unsigned a = unsigned(x ^ y) & 7u, b = unsigned(y) & 7u;
  const unsigned rank = ((a & 1u) << 5) | ((b & 1u) << 4) | ((a & 2u) << 2) | ((b & 2u) << 1) |
                        ((a & 4u) >> 1) | ((b & 4u) >> 2);
  return int(rank * unsigned(k) / 64u);
}
inline bool refresh_scheduled(int x, int y, int frame, int k) {
  return k <= 1 || (frame + refresh_phase(x, y, k)) % k == 0;
}

// Weight of a new sample in the running average of `n` samples (n >= 1 counting the new
// one): 1/n until 1/n < alpha, then alpha.
inline float running_average_weight(int n, float alpha) {
  return std::max(alpha, 1.0f / float(std::max(n, 1)));
}

// ---- The cache ------------------------------------------------------------------------------

// One instance per sequence. Per frame: plan() on the G-buffer (every channel but the
// shading), shade the pixels it marks, then resolve() with the shaded values.
class ShadingCache {
 public:
  explicit ShadingCache(const ShadingCacheSettings& s, const Exec& exec = {});

  // Marks in `mask` (width * height, set to 0/1) the pixels to shade this frame, from the
  // frame's depth, normal, id, motion and jitter against the cached previous frame.
  void plan(const Frame& g, std::vector<uint8_t>& mask);

  // `g` as plan() saw it plus `diffuse` / `specular` (the demodulated direct light, render::
  // compose_shading) valid where the mask was set. Replaces them with the cache's output at
  // every pixel, stores the frame as the next frame's history, and returns the counters.
  ShadingCacheCounters resolve(Frame& g);

  // Age in frames of each output value of the last resolve (0 = shaded this frame).
  const std::vector<uint16_t>& ages() const { return age_; }
  // Outcome of each pixel in the last plan().
  const std::vector<CacheOutcome>& outcomes() const { return outcome_; }
  void reset();

 private:
  struct Lookup {
    float w[4];
    int32_t i[4];  // flat indices of the taps (weight 0: unused)
  };
  ShadingCacheSettings s_;
  Exec exec_;
  int frame_ = 0;  // frames resolved since the last reset (the schedule's clock)
  // The previous frame as cached.
  bool have_ = false;
  int width_ = 0, height_ = 0;
  FrameHeader prev_header_;  // camera and jitter of the cached frame
  ImageF depth_, normal_, diffuse_, specular_;
  ImageU32 id_;
  std::vector<uint16_t> age_, count_;
  std::vector<uint8_t> changed_tiles_;  // kChangeTile tiles of the cached frame
  // This frame's plan.
  std::vector<CacheOutcome> outcome_;
  std::vector<Lookup> lookup_;
  std::vector<uint16_t> planned_age_;  // age a hit's reused value would have
};

}  // namespace afterimage::reproject
