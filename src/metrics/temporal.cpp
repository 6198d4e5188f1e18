#include "metrics/temporal.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <optional>
#include <utility>

#include "core/error.h"
#include "reproject/history.h"

namespace afterimage::metrics {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void check_sequences(const std::vector<ImageF>& output, const std::vector<ImageF>& reference,
                     const char* what) {
  if (output.size() != reference.size())
    throw InputError(fmt::format("{}: output has {} frames, reference {}", what, output.size(),
                                 reference.size()));
}

// History pixel of pixel (x, y): the nearest previous pixel (reproject/history.h, half-open
// on-screen test), nothing if off-screen or the motion is not finite.
std::optional<reproject::PixelCoord> history_pixel(const ImageF& motion, int x, int y, int w,
                                                   int h) {
  return reproject::nearest_history_pixel(x, y, motion.at(x, y, 0), motion.at(x, y, 1), w, h);
}

}  // namespace

double temporal_error_frame(const ImageF& output_prev, const ImageF& output,
                            const ImageF& reference_prev, const ImageF& reference, const Exec& ex) {
  check_same_shape(output, reference, "temporal_error");
  check_same_shape(output_prev, output, "temporal_error");
  check_same_shape(reference_prev, reference, "temporal_error");
  const int w = output.width(), nc = output.channels();
  const double sum = parallel_sum_rows(ex, output.height(), [&](int y) {
    double s = 0.0;
    for (int c = 0; c < nc; ++c) {
      const float *o0 = output_prev.row(c, y), *o1 = output.row(c, y);
      const float *r0 = reference_prev.row(c, y), *r1 = reference.row(c, y);
      for (int x = 0; x < w; ++x) s += std::abs((double(o1[x]) - o0[x]) - (double(r1[x]) - r0[x]));
    }
    return s;
  });
  return sum / (double(output.plane_size()) * nc);
}

double display_error_frame(const ImageF& output, const ImageF& reference,
                           const DisplaySettings& display, const Exec& ex) {
  check_same_shape(output, reference, "display_error");
  const int w = output.width(), nc = output.channels();
  const double sum = parallel_sum_rows(ex, output.height(), [&](int y) {
    double s = 0.0;
    for (int c = 0; c < nc; ++c) {
      const float *o = output.row(c, y), *r = reference.row(c, y);
      for (int x = 0; x < w; ++x)
        s += std::abs(double(display_value(o[x], display)) - display_value(r[x], display));
    }
    return s;
  });
  return sum / (double(output.plane_size()) * nc);
}

std::vector<double> display_error_per_frame(const std::vector<ImageF>& output,
                                            const std::vector<ImageF>& reference,
                                            const DisplaySettings& display, const Exec& ex) {
  check_sequences(output, reference, "display_error");
  std::vector<double> e;
  for (size_t t = 0; t < output.size(); ++t)
    e.push_back(display_error_frame(output[t], reference[t], display, ex));
  return e;
}

int lag_frames(const std::vector<double>& error, int step, int steady_frames, double tolerance) {
  const int n = int(error.size());
  if (step < 0 || steady_frames < 1 || step + steady_frames > n || !(tolerance >= 1.0))
    throw InputError(fmt::format(
        "lag_frames: step {}, {} steady frames, tolerance {} on {} frames (need 0 <= step, "
        "step + steady frames <= frames, tolerance >= 1)",
        step, steady_frames, tolerance, n));
  double steady = 0.0;
  for (int t = n - steady_frames; t < n; ++t) steady += error[size_t(t)];
  steady /= steady_frames;
  for (int t = step; t < n; ++t)
    if (error[size_t(t)] <= tolerance * steady) return t - step;
  return n - step;
}

double temporal_error(const std::vector<ImageF>& output, const std::vector<ImageF>& reference,
                      int warmup, const DisplaySettings& display, const Exec& ex) {
  check_sequences(output, reference, "temporal_error");
  const size_t first = size_t(std::max(warmup, 0)) + 1;  // e(t) for t > warmup
  if (first >= output.size()) return kNaN;
  ImageF out_prev = to_display(output[first - 1], display, ex);
  ImageF ref_prev = to_display(reference[first - 1], display, ex);
  double sum = 0.0;
  for (size_t t = first; t < output.size(); ++t) {
    ImageF out_cur = to_display(output[t], display, ex);
    ImageF ref_cur = to_display(reference[t], display, ex);
    sum += temporal_error_frame(out_prev, out_cur, ref_prev, ref_cur, ex);
    out_prev = std::move(out_cur);
    ref_prev = std::move(ref_cur);
  }
  return sum / double(output.size() - first);
}

void DisocclusionSettings::validate() const {
  if (!(depth_tolerance >= 0.0f) || !std::isfinite(depth_tolerance))
    throw SettingsError(
        fmt::format("disocclusion: depth_tolerance must be >= 0, got {}", depth_tolerance));
}

Mask disocclusion_mask(const ImageF& depth, const ImageU32& id, const ImageF& motion,
                       const ImageF& prev_depth, const ImageU32& prev_id,
                       const DisocclusionSettings& s, const Exec& ex) {
  s.validate();
  const int w = depth.width(), h = depth.height();
  auto shape_ok = [&](int cw, int ch, int cc, int want) {
    return cw == w && ch == h && cc == want;
  };
  if (!shape_ok(depth.width(), depth.height(), depth.channels(), 1) ||
      !shape_ok(id.width(), id.height(), id.channels(), 1) ||
      !shape_ok(motion.width(), motion.height(), motion.channels(), 2) ||
      !shape_ok(prev_depth.width(), prev_depth.height(), prev_depth.channels(), 1) ||
      !shape_ok(prev_id.width(), prev_id.height(), prev_id.channels(), 1))
    throw InputError(fmt::format(
        "disocclusion_mask: G-buffer planes must all be {}x{} (depth, id, prev depth, prev id: 1 "
        "channel; motion: 2)",
        w, h));
  Mask m(w, h, 1, 0);
  parallel_rows(ex, h, [&](int y) {
    uint8_t* out = m.row(0, y);
    for (int x = 0; x < w; ++x) {
      const auto hp = history_pixel(motion, x, y, w, h);
      if (!hp) {
        out[x] = 1;
        continue;
      }
      const int hx = hp->x, hy = hp->y;
      const float d = depth.at(x, y, 0), dp = prev_depth.at(hx, hy, 0);
      const bool other_object = prev_id.at(hx, hy, 0) != id.at(x, y, 0);
      const bool other_depth = std::abs(dp - d) > s.depth_tolerance * d;
      out[x] = (other_object || other_depth) ? 1 : 0;
    }
  });
  return m;
}

DisocclusionAge::DisocclusionAge(int max_age) : max_age_(max_age) {
  if (max_age < 1 || max_age > 254)
    throw SettingsError(fmt::format("ghosting: max_age must be in [1, 254], got {}", max_age));
}

void DisocclusionAge::update(const Mask& disoccluded, const ImageF* motion, const Exec& ex) {
  const int w = disoccluded.width(), h = disoccluded.height();
  if (motion && (motion->width() != w || motion->height() != h || motion->channels() != 2))
    throw InputError("disocclusion age: motion must be 2 planes of the mask's size");
  if (age_.width() != w || age_.height() != h) age_ = Image<uint8_t>(w, h, 1, 0);
  const Image<uint8_t> prev = age_;
  parallel_rows(ex, h, [&](int y) {
    const uint8_t* m = disoccluded.row(0, y);
    uint8_t* a = age_.row(0, y);
    for (int x = 0; x < w; ++x) {
      if (m[x]) {
        a[x] = 1;
        continue;
      }
      int hx = x, hy = y;
      if (motion) {
        const auto hp = history_pixel(*motion, x, y, w, h);
        if (!hp) {
          a[x] = 0;
          continue;
        }
        hx = hp->x;
        hy = hp->y;
      }
      const int p = prev.at(hx, hy, 0);
      a[x] = (p >= 1 && p < max_age_) ? uint8_t(p + 1) : uint8_t(0);
    }
  });
}

GhostingAccumulator::GhostingAccumulator(int max_age) {
  if (max_age < 1 || max_age > 254)
    throw SettingsError(fmt::format("ghosting: max_age must be in [1, 254], got {}", max_age));
  sum_.assign(size_t(max_age), 0.0);
  count_.assign(size_t(max_age), 0);
}

void GhostingAccumulator::add(const ImageF& output, const ImageF& reference,
                              const Image<uint8_t>& age, const Exec& ex) {
  check_same_shape(output, reference, "ghosting");
  if (age.width() != output.width() || age.height() != output.height())
    throw InputError("ghosting: age image size differs from the frames");
  const int w = output.width(), h = output.height(), nc = output.channels();
  const size_t kmax = sum_.size();
  // Per-row partial sums, combined in row order: deterministic for any thread count.
  std::vector<double> row_sum(size_t(h) * kmax, 0.0);
  std::vector<uint64_t> row_count(size_t(h) * kmax, 0);
  parallel_rows(ex, h, [&](int y) {
    const uint8_t* a = age.row(0, y);
    double* s = row_sum.data() + size_t(y) * kmax;
    uint64_t* n = row_count.data() + size_t(y) * kmax;
    for (int x = 0; x < w; ++x) {
      if (a[x] == 0 || a[x] > kmax) continue;
      double e = 0.0;
      for (int c = 0; c < nc; ++c)
        e += std::abs(double(output.at(x, y, c)) - reference.at(x, y, c));
      s[a[x] - 1] += e / nc;
      n[a[x] - 1] += 1;
    }
  });
  for (int y = 0; y < h; ++y)
    for (size_t k = 0; k < kmax; ++k) {
      sum_[k] += row_sum[size_t(y) * kmax + k];
      count_[k] += row_count[size_t(y) * kmax + k];
    }
}

GhostingCurve GhostingAccumulator::curve() const {
  GhostingCurve c;
  c.samples = count_;
  c.error.resize(sum_.size());
  for (size_t k = 0; k < sum_.size(); ++k)
    c.error[k] = count_[k] > 0 ? sum_[k] / double(count_[k]) : kNaN;
  return c;
}

GhostingCurve ghosting_curve(const std::vector<ImageF>& output,
                             const std::vector<ImageF>& reference, const std::vector<Mask>& masks,
                             const std::vector<ImageF>& motions, int warmup,
                             const DisplaySettings& display, int max_age, const Exec& ex) {
  check_sequences(output, reference, "ghosting");
  if (masks.size() != output.size())
    throw InputError(fmt::format("ghosting: {} masks for {} frames", masks.size(), output.size()));
  if (!motions.empty() && motions.size() != output.size())
    throw InputError(
        fmt::format("ghosting: {} motion images for {} frames", motions.size(), output.size()));
  DisocclusionAge age(max_age);
  GhostingAccumulator acc(max_age);
  for (size_t t = 0; t < output.size(); ++t) {
    age.update(masks[t], motions.empty() ? nullptr : &motions[t], ex);
    if (int(t) >= warmup)
      acc.add(to_display(output[t], display, ex), to_display(reference[t], display, ex), age.age(),
              ex);
  }
  return acc.curve();
}

double gradient_energy(PlaneView p, const Exec& ex) {
  const int w = p.width, h = p.height;
  return parallel_sum_rows(ex, h, [&](int y) {
    double s = 0.0;
    for (int x = 0; x + 1 < w; ++x) {
      const double d = double(p.at(x + 1, y)) - p.at(x, y);
      s += d * d;
    }
    if (y + 1 < h)
      for (int x = 0; x < w; ++x) {
        const double d = double(p.at(x, y + 1)) - p.at(x, y);
        s += d * d;
      }
    return s;
  });
}

double luma_gradient_energy(const ImageF& display, const Exec& ex) {
  const ImageF l = luma(display, ex);
  return gradient_energy(view(l, 0), ex);
}

double sharpness_ratio(const ImageF& output, double reference_energy, const Exec& ex) {
  const double eo = luma_gradient_energy(output, ex), er = reference_energy;
  if (er == 0.0) return eo == 0.0 ? 1.0 : std::numeric_limits<double>::infinity();
  return eo / er;
}

double sharpness_ratio(const ImageF& output, const ImageF& reference, const Exec& ex) {
  check_same_shape(output, reference, "sharpness");
  return sharpness_ratio(output, luma_gradient_energy(reference, ex), ex);
}

}  // namespace afterimage::metrics
