// TemporalResolver: the TAA pass (DESIGN.md §2: a class owning the history; process(frame),
// reset(), save_state(), load_state()). Per pixel, in this order:
//   1. sanitize the current color (non-finite -> mean of finite 3x3 neighbours or 0,
//      negative -> 0) so NaN / Inf never enter history; a pixel whose input was not finite
//      keeps its history unchanged for that frame (there is no current sample);
//   2. optional current-color filter at the actual jittered sample distances (seed 003);
//   3. velocity dilation (seed 002/003), reprojection p + motion (DESIGN.md §3), off-screen
//      rejection;
//   4. history fetch (bilinear / Catmull-Rom 5 / 9 / 16, point Load in static mode), with
//      optional anti-ringing; non-finite history is reset;
//   5. geometry rejection (depth, object id, velocity) on the 2x2 footprint;
//   6. rectification against the neighbourhood (clamp / clip / variance / convex hull, in
//      RGB or YCoCg);
//   7. blend factor (fixed alpha or sample count, adaptive rules, then raised by the frame's
//      temporal_change channel, A-SVGF's lambda, when present), blend (Eq.2, optionally
//      luma-weighted);
// Sharpening (seed 000 Eq.5) is not part of the resolve: it is the stateless post/sharpen
// pass, which pipelines append after any temporal method.
// History is reset on the first frame, on a resolution change and on Frame::camera_cut.
// Results are bit-identical for any thread count (rows are independent).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/parallel.h"
#include "frame/frame.h"
#include "frame/sequence_method.h"
#include "taa/settings.h"

namespace afterimage::taa {

class TemporalResolver {
 public:
  // Throws SettingsError if `settings` do not validate.
  explicit TemporalResolver(const TaaSettings& settings = {}, Exec exec = {});

  // Resolves one frame: returns the anti-aliased RGB (3 planes, frame size), which is also
  // the next frame's history. Needs color; depth, motion and id are used when present (absent
  // motion = static, absent depth / id disables what needs them; temporal_change raises alpha).
  // Throws InputError on inconsistent channel shapes.
  ImageF process(const Frame& frame);

  // Forgets all history: the next frame starts fresh.
  void reset();

  // Binary state file (core/state_file.h, kind "taa": versioned header, named sections,
  // checksum; written atomically). Saving after frame k and loading into a resolver with the
  // same settings continues bit-identically. save_state throws OutputError if the file cannot
  // be written; load_state throws InputError for unreadable, truncated, corrupted, foreign or
  // newer-version files and then leaves the resolver unchanged.
  void save_state(const std::string& path) const;
  void load_state(const std::string& path);

  const TaaSettings& settings() const { return settings_; }
  void set_settings(const TaaSettings& s);  // validates; keeps history
  const Exec& exec() const { return exec_; }
  void set_exec(Exec e) { exec_ = e; }

  bool has_history() const { return valid_; }
  // Resolved color of the last frame (3 planes) and per-pixel effective sample
  // count N = 1 / alpha used (1 plane). Empty before the first frame.
  const ImageF& history() const { return history_; }
  const ImageF& sample_count() const { return count_; }
  long frames_processed() const { return frames_; }
  // The planes the last process() read and wrote per pixel (the bench's floor; the set
  // depends on the settings, the channels present and whether history existed).
  PlaneTraffic last_traffic() const { return traffic_; }

 private:
  // Path of the state file loaded since the last frame, for the size check of the next frame.
  std::string loaded_from_;
  TaaSettings settings_;
  Exec exec_;

  // --- State (what save_state writes) ---
  int width_ = 0, height_ = 0;
  bool valid_ = false;  // history_ may be used by the next frame
  long frames_ = 0;
  ImageF history_;      // 3 planes RGB
  ImageF count_;        // 1 plane, effective sample count
  ImageF prev_depth_;   // 1 plane (empty if the previous frame had no depth)
  ImageF prev_motion_;  // 2 planes (empty if absent)
  ImageU32 prev_id_;    // 1 plane (empty if absent)
  ImageF moments_;      // kLumaMomentPlanes planes: luma statistics of the raw samples
  ImageF spreads_;      // kSpreadPlanes planes derived from moments_ (what neighbours read)

  // --- Scratch (not state) ---
  ImageF next_history_, next_count_, next_moments_, sanitized_, invalid_, zero_motion_,
      background_depth_;
  ImageF next_spreads_;
  ImageF next_prev_depth_, next_prev_motion_;  // this frame's G-buffer, swapped into prev_*
  ImageU32 next_prev_id_;
  std::vector<uint8_t> row_needs_sanitize_;  // per row: input color needs sanitising
  PlaneTraffic traffic_;                     // of the last frame (last_traffic)
};

}  // namespace afterimage::taa
