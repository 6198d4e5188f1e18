#include "reproject/shading_cache.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "reproject/forward.h"

namespace afterimage::reproject {

namespace {

constexpr int kChangeTile = 8;  // the schedule's 8x8 block: K-th of its pixels refresh per frame

// Relative change of shading between the cached and the new value (demodulated, so albedo
// does not count): |l_new - l_old| / max(l_new, l_old), l = luminance of diffuse + specular.
float relative_shading_change(const float (&old_v)[6], const float (&new_v)[6]) {
  auto lum = [](const float* v) {
    return 0.2126f * (v[0] + v[3]) + 0.7152f * (v[1] + v[4]) + 0.0722f * (v[2] + v[5]);
  };
  const float a = lum(old_v), b = lum(new_v), m = std::max(a, b);
  return m > 1e-6f ? std::abs(b - a) / m : 0.0f;
}

constexpr EnumNames<CacheMode, 2> kModeNames{
    {{CacheMode::Reuse, "reuse"}, {CacheMode::Average, "average"}}};

ParamTable<ShadingCacheSettings> make_table() {
  using S = ShadingCacheSettings;
  ParamTable<S> t("shading_cache");
  t.add_enum("mode", &S::mode, kModeNames,
             "reuse: shade misses and refreshes only; average: shade all, running average");
  t.add_int("refresh", &S::refresh, 1, 1000,
            "reuse: every pixel re-shaded at least every K frames (staggered)");
  t.add_float("alpha", &S::alpha, 0.001f, 1.0f,
              "average: weight of the new sample once 1/alpha samples are averaged");
  t.add_float("depth_tolerance", &S::depth_tolerance, 0.0f, 1.0f,
              "relative depth difference a tap may have");
  t.add_float("depth_slope", &S::depth_slope, 0.0f, 16.0f,
              "extra depth tolerance per pixel of tap distance, times the depth gradient");
  t.add_float("normal_cos", &S::normal_cos, -1.0f, 1.0f, "minimum dot(n_prev, n) of a tap");
  t.add_float("turn_cos", &S::turn_cos, -1.0f, 1.0f,
              "minimum cosine between the interpolated previous normal and the current one");
  t.add_float("object_motion", &S::object_motion, 0.0f, 1e6f,
              "pixels of motion beyond the camera's that mark a surface as moving");
  t.add_int("object_refresh", &S::object_refresh, 1, 1000,
            "reuse: moving surfaces re-shaded at least every K frames");
  t.add_float("change_threshold", &S::change_threshold, 0.0f, 1.0f,
              "reuse: relative shading change a refresh detects; re-shades its tiles next "
              "frame (0: off)");
  return t;
}

float at_or(const ImageF& img, int x, int y, int c, float fallback) {
  return x >= 0 && y >= 0 && x < img.width() && y < img.height() ? img.at(x, y, c) : fallback;
}

// Depth change per pixel at (x, y): per axis the smaller one-sided difference, so a silhouette
// (a jump on one side) does not widen the tolerance of the surface beside it.
float depth_gradient_length(const ImageF& depth, int x, int y) {
  const float d = depth.at(x, y, 0), inf = std::numeric_limits<float>::infinity();
  const float gx = std::min(std::abs(at_or(depth, x + 1, y, 0, inf) - d),
                            std::abs(d - at_or(depth, x - 1, y, 0, inf)));
  const float gy = std::min(std::abs(at_or(depth, x, y + 1, 0, inf) - d),
                            std::abs(d - at_or(depth, x, y - 1, 0, inf)));
  const float g =
      std::sqrt((std::isfinite(gx) ? gx * gx : 0.0f) + (std::isfinite(gy) ? gy * gy : 0.0f));
  return std::isfinite(g) ? g : 0.0f;
}

}  // namespace

const ParamTable<ShadingCacheSettings>& ShadingCacheSettings::params() {
  static const ParamTable<ShadingCacheSettings> kTable = make_table();  // immutable
  return kTable;
}
void ShadingCacheSettings::set_assignment(const std::string& assignment) {
  params().set_assignment(*this, assignment);
}
void ShadingCacheSettings::validate() const {
  params().validate(*this);
}
std::string ShadingCacheSettings::describe() const {
  return params().describe(*this);
}
std::string ShadingCacheSettings::to_json() const {
  return params().to_json(*this);
}
const char* to_string(CacheMode m) {
  return enum_name(kModeNames, m);
}

ShadingCacheCounters& ShadingCacheCounters::operator+=(const ShadingCacheCounters& o) {
  pixels += o.pixels;
  background += o.background;
  hits += o.hits;
  no_history += o.no_history;
  offscreen += o.offscreen;
  id_miss += o.id_miss;
  depth_miss += o.depth_miss;
  normal_miss += o.normal_miss;
  scheduled += o.scheduled;
  stale += o.stale;
  moving += o.moving;
  changed += o.changed;
  shaded += o.shaded;
  max_age = std::max(max_age, o.max_age);
  return *this;
}

ShadingCache::ShadingCache(const ShadingCacheSettings& s, const Exec& exec) : s_(s), exec_(exec) {
  s_.validate();
}

void ShadingCache::reset() {
  have_ = false;
  frame_ = 0;
}

void ShadingCache::plan(const Frame& g, std::vector<uint8_t>& mask) {
  for (Channel c : {Channel::depth, Channel::normal, Channel::id, Channel::motion})
    if (!g.has(c))
      throw InputError(
          fmt::format("shading cache: frame {} has no {} channel", g.index, channel_info(c).name));
  const int w = g.width, h = g.height;
  const size_t n = size_t(w) * size_t(h);
  mask.assign(n, 0);
  outcome_.assign(n, CacheOutcome::NoHistory);
  lookup_.assign(n, Lookup{});
  std::vector<uint16_t> reuse_age(n, 0);
  const bool history = have_ && !g.camera_cut && w == width_ && h == height_;
  const bool average = s_.mode == CacheMode::Average;
  // The motion the camera alone would give (forward.h's camera-only transfer, from this frame
  // into the cached one): where motion differs, the surface moved on its own.
  const CameraTransfer to_prev = CameraTransfer::between(g, prev_header_);
  const int tw = (w + kChangeTile - 1) / kChangeTile, th = (h + kChangeTile - 1) / kChangeTile;
  // A marked tile of the previous frame, or one next to it, around (x, y).
  auto near_change = [&](int x, int y) {
    if (!history || changed_tiles_.size() != size_t(tw) * size_t(th)) return false;
    const int cx = x / kChangeTile, cy = y / kChangeTile;
    for (int ty = std::max(cy - 1, 0); ty <= std::min(cy + 1, th - 1); ++ty)
      for (int tx = std::max(cx - 1, 0); tx <= std::min(cx + 1, tw - 1); ++tx)
        if (changed_tiles_[size_t(ty) * size_t(tw) + size_t(tx)]) return true;
    return false;
  };
  parallel_rows(exec_, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      const uint32_t id = g.id.at(x, y, 0);
      if (id == 0) {
        outcome_[i] = CacheOutcome::Background;
        continue;
      }
      mask[i] = 1;
      if (!history) continue;  // NoHistory
      double px, py;
      cache_lookup_position(x, y, g.jitter.x, g.jitter.y, g.motion.at(x, y, 0),
                            g.motion.at(x, y, 1), prev_header_.jitter.x, prev_header_.jitter.y, &px,
                            &py);
      if (!(px >= 0.0 && px < w && py >= 0.0 && py < h)) {  // NaN motion lands here too
        outcome_[i] = CacheOutcome::Offscreen;
        continue;
      }
      // 2x2 bilinear footprint over the previous samples (pixel i's at i + 0.5); taps outside
      // the image carry no weight.
      const double tx = px - 0.5, ty = py - 0.5;
      const int x0 = int(std::floor(tx)), y0 = int(std::floor(ty));
      const float fx = float(tx - x0), fy = float(ty - y0);
      const float wts[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
      const float d = g.depth.at(x, y, 0);
      const float grad = depth_gradient_length(g.depth, x, y);
      Lookup& L = lookup_[i];
      bool id_bad = false, depth_bad = false, normal_bad = false;
      float wsum = 0.0f;
      float age = 0.0f;  // the taps' ages, weighted as their values blend
      float n_interp[3] = {0, 0, 0};
      for (int k = 0; k < 4; ++k) {
        const int qx = x0 + (k & 1), qy = y0 + (k >> 1);
        L.w[k] = 0.0f;
        L.i[k] = 0;
        if (qx < 0 || qy < 0 || qx >= w || qy >= h || wts[k] <= 0.0f) continue;
        const size_t q = size_t(qy) * size_t(w) + size_t(qx);
        const double dist = std::hypot(qx + 0.5 - px, qy + 0.5 - py);
        const float dq = depth_.at(qx, qy, 0);
        float dot = 0.0f;
        for (int c = 0; c < 3; ++c) {
          dot += normal_.at(qx, qy, c) * g.normal.at(x, y, c);
          n_interp[c] += wts[k] * normal_.at(qx, qy, c);
        }
        id_bad |= id_.at(qx, qy, 0) != id;
        depth_bad |=
            !(std::abs(dq - d) <= s_.depth_tolerance * d + s_.depth_slope * grad * float(dist));
        normal_bad |= !(dot >= s_.normal_cos);
        L.w[k] = wts[k];
        L.i[k] = int32_t(q);
        wsum += wts[k];
        age += wts[k] * float(age_[q]);
      }
      if (!id_bad && !depth_bad && !normal_bad) {
        const float len2 =
            n_interp[0] * n_interp[0] + n_interp[1] * n_interp[1] + n_interp[2] * n_interp[2];
        float dot = 0.0f;
        for (int c = 0; c < 3; ++c) dot += n_interp[c] * g.normal.at(x, y, c);
        // dot / |n_interp| >= turn_cos, without the division (dot must be positive).
        normal_bad = !(dot > 0.0f && dot * dot >= s_.turn_cos * s_.turn_cos * len2);
      }
      if (id_bad) {
        outcome_[i] = CacheOutcome::IdMiss;
      } else if (depth_bad) {
        outcome_[i] = CacheOutcome::DepthMiss;
      } else if (normal_bad) {
        outcome_[i] = CacheOutcome::NormalMiss;
      } else {
        for (float& wk : L.w) wk /= wsum;  // wsum > 0: the tap nearest (px, py) is in-image
        // Age of the blended value: its taps' ages by weight, rounded (a tap shaded last
        // frame and one shaded 7 frames ago make a value 4 frames old), plus this frame.
        const int reused = int(std::lround(age / wsum)) + 1;
        outcome_[i] = CacheOutcome::Hit;
        reuse_age[i] = uint16_t(std::min(reused, 65535));
        if (average) continue;  // shaded and blended
        const Vec2d p{x + 0.5 + g.jitter.x, y + 0.5 + g.jitter.y};
        const Reprojected cam = camera_displacement(to_prev, p, d);
        const double ox = g.motion.at(x, y, 0) - cam.displacement.x,
                     oy = g.motion.at(x, y, 1) - cam.displacement.y;
        const bool moving =
            !cam.valid || !(ox * ox + oy * oy <= double(s_.object_motion) * s_.object_motion);
        if (reused >= s_.refresh)
          outcome_[i] = CacheOutcome::Stale;
        else if (moving && (reused >= s_.object_refresh ||
                            refresh_scheduled(x, y, g.index, s_.object_refresh)))
          outcome_[i] = CacheOutcome::Moving;
        else if (near_change(x, y))
          outcome_[i] = CacheOutcome::Changed;
        else if (refresh_scheduled(x, y, g.index, s_.refresh))
          outcome_[i] = CacheOutcome::Scheduled;
        else
          mask[i] = 0;
      }
    }
  });
  planned_age_ = std::move(reuse_age);
}

ShadingCacheCounters ShadingCache::resolve(Frame& g) {
  const int w = g.width, h = g.height;
  const size_t n = size_t(w) * size_t(h);
  AI_CHECK(outcome_.size() == n && lookup_.size() == n && planned_age_.size() == n);
  for (Channel c : {Channel::diffuse, Channel::specular})
    if (!g.has(c))
      throw InputError(
          fmt::format("shading cache: frame {} has no {} channel", g.index, channel_info(c).name));
  const bool average = s_.mode == CacheMode::Average;
  std::vector<uint16_t> age(n, 0), count(n, 0);
  std::vector<uint8_t> changed(n, 0);  // a refresh found its shading changed
  // Hits read the previous values (diffuse_ / specular_) and write the frame's planes, which
  // then become the cache: no pixel reads what another writes.
  parallel_rows(exec_, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      const CacheOutcome o = outcome_[i];
      if (o == CacheOutcome::Background) continue;
      const bool refresh = o == CacheOutcome::Scheduled || o == CacheOutcome::Stale ||
                           o == CacheOutcome::Moving || o == CacheOutcome::Changed;
      if (o != CacheOutcome::Hit && !refresh) {  // shaded anew: miss or no history
        age[i] = 0;
        count[i] = 1;
        continue;
      }
      const Lookup& L = lookup_[i];
      // The reprojected cached value: bilinear over the taps (weights renormalised).
      float prev[6] = {0, 0, 0, 0, 0, 0};
      uint16_t n_prev = 65535;
      for (int k = 0; k < 4; ++k) {
        if (L.w[k] <= 0.0f) continue;
        const int qx = L.i[k] % w, qy = L.i[k] / w;
        for (int c = 0; c < 3; ++c) {
          prev[c] += L.w[k] * diffuse_.at(qx, qy, c);
          prev[3 + c] += L.w[k] * specular_.at(qx, qy, c);
        }
        n_prev = std::min(n_prev, count_[size_t(L.i[k])]);
      }
      if (refresh) {  // shaded anew; compare with what the cache would have reused
        float now[6];
        for (int c = 0; c < 3; ++c) {
          now[c] = g.diffuse.at(x, y, c);
          now[3 + c] = g.specular.at(x, y, c);
        }
        changed[i] =
            s_.change_threshold > 0.0f && relative_shading_change(prev, now) > s_.change_threshold;
        age[i] = 0;
        count[i] = 1;
        continue;
      }
      if (!average) {  // reuse
        for (int c = 0; c < 3; ++c) {
          g.diffuse.at(x, y, c) = prev[c];
          g.specular.at(x, y, c) = prev[3 + c];
        }
        age[i] = planned_age_[i];
        count[i] = 1;
        continue;
      }
      // Running average: prev + a (new - prev), exact when new == prev.
      const int nn = std::min(int(n_prev) + 1, 65535);
      const float a = running_average_weight(nn, s_.alpha);
      for (int c = 0; c < 3; ++c) {
        float& dv = g.diffuse.at(x, y, c);
        float& sv = g.specular.at(x, y, c);
        dv = prev[c] + a * (dv - prev[c]);
        sv = prev[3 + c] + a * (sv - prev[3 + c]);
      }
      age[i] = 0;
      count[i] = uint16_t(nn);
    }
  });

  ShadingCacheCounters k;
  k.pixels = int64_t(n);
  for (size_t i = 0; i < n; ++i) {
    switch (outcome_[i]) {
      case CacheOutcome::Background:
        ++k.background;
        break;
      case CacheOutcome::Hit:
        ++k.hits;
        break;
      case CacheOutcome::NoHistory:
        ++k.no_history;
        break;
      case CacheOutcome::Offscreen:
        ++k.offscreen;
        break;
      case CacheOutcome::IdMiss:
        ++k.id_miss;
        break;
      case CacheOutcome::DepthMiss:
        ++k.depth_miss;
        break;
      case CacheOutcome::NormalMiss:
        ++k.normal_miss;
        break;
      case CacheOutcome::Scheduled:
        ++k.scheduled;
        break;
      case CacheOutcome::Stale:
        ++k.stale;
        break;
      case CacheOutcome::Moving:
        ++k.moving;
        break;
      case CacheOutcome::Changed:
        ++k.changed;
        break;
    }
    k.max_age = std::max(k.max_age, int(age[i]));
  }
  k.shaded = k.pixels - k.background - (average ? 0 : k.hits);

  // This frame becomes the cache.
  width_ = w;
  height_ = h;
  const int tw = (w + kChangeTile - 1) / kChangeTile, th = (h + kChangeTile - 1) / kChangeTile;
  changed_tiles_.assign(size_t(tw) * size_t(th), 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (changed[size_t(y) * size_t(w) + size_t(x)])
        changed_tiles_[size_t(y / kChangeTile) * size_t(tw) + size_t(x / kChangeTile)] = 1;
  prev_header_ = static_cast<const FrameHeader&>(g);
  depth_ = g.depth;
  normal_ = g.normal;
  id_ = g.id;
  diffuse_ = g.diffuse;
  specular_ = g.specular;
  age_ = std::move(age);
  count_ = std::move(count);
  have_ = true;
  ++frame_;
  return k;
}

}  // namespace afterimage::reproject
