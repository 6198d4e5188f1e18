// Synthetic test inputs shared by the test files: seeded random images, linear ramps, the
// full channel set and fresh temp directories. Header-only; every helper is deterministic, so
// a test that switches to one keeps exactly the data it had (same sizes, seeds, values).
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <system_error>
#include <vector>

#include "core/image.h"
#include "core/parallel.h"
#include "frame/frame.h"

namespace afterimage::test {

// One thread, every pixel through the 1-lane path: the reference of the tests that a pass gives
// the same bits with SIMD on and off and at any thread count.
inline Exec scalar_exec() {
  Exec e;
  e.threads = 1;
  e.simd = false;
  return e;
}

// `n` threads (0: all), SIMD on.
inline Exec with_threads(int n) {
  Exec e;
  e.threads = n;
  return e;
}

// A w x h x `channels` image of uniform values in [lo, hi): one std::mt19937(seed) and one
// std::uniform_real_distribution<float>(lo, hi), drawn in data() order (plane by plane, row by
// row). Used for random colors ([0, 4) or [0, 1)) and random motion fields ([-6, 6)).
inline ImageF random_image(int w, int h, int channels, unsigned seed, float lo = 0.0f,
                           float hi = 1.0f) {
  ImageF img(w, h, channels);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  for (float& v : img.data()) v = u(rng);
  return img;
}

// A one-channel linear ramp sampled at pixel centers: ax * (x + 0.5) + ay * (y + 0.5) + b.
// With dyadic coefficients every value is exact in float, so interpolators with linear
// precision must reproduce it.
// Fails (once, at the first difference) unless every value of `out` has the bits of
// `expected`: a fast pass against its plain statement. `what` names the run (threads, simd).
inline void expect_same_bits(const ImageF& out, const ImageF& expected, const std::string& what) {
  ASSERT_EQ(out.width(), expected.width()) << what;
  ASSERT_EQ(out.height(), expected.height()) << what;
  ASSERT_EQ(out.channels(), expected.channels()) << what;
  for (int y = 0; y < out.height(); ++y)
    for (int x = 0; x < out.width(); ++x)
      for (int c = 0; c < out.channels(); ++c)
        ASSERT_EQ(std::bit_cast<uint32_t>(out.at(x, y, c)),
                  std::bit_cast<uint32_t>(expected.at(x, y, c)))
            << "pixel " << x << " " << y << " channel " << c << ", " << what;
}

inline ImageF ramp_image(int w, int h, float ax, float ay, float b) {
  ImageF img(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.at(x, y, 0) = ax * (x + 0.5f) + ay * (y + 0.5f) + b;
  return img;
}

// Every row of the channel table (core and optional).
inline ChannelSet every_channel() {
  ChannelSet s;
  for (const ChannelInfo& r : kChannelTable) s.insert(r.key);
  return s;
}

// The directories fresh_temp_dir made in this process, removed when the process ends with no
// test failed (a failure keeps them for inspection; so does a crash, which runs no destructor).
struct TempDirsOfThisProcess {
  std::vector<std::filesystem::path> dirs;
  ~TempDirsOfThisProcess() {
    if (::testing::UnitTest::GetInstance()->failed_test_count() > 0) return;
    std::error_code ec;
    for (const auto& d : dirs) std::filesystem::remove_all(d, ec);
  }
};
inline TempDirsOfThisProcess& temp_dirs_of_this_process() {
  static TempDirsOfThisProcess dirs;
  return dirs;
}

// <system temp>/afterimage_<tag>_<pid>, emptied and created: the pid keeps two test runs on one
// machine (two build trees, CI's two suites, a developer's run beside CI) out of each other's
// files, which fixed tags did not.
inline std::filesystem::path fresh_temp_dir(const std::string& tag) {
  const std::filesystem::path d = std::filesystem::temp_directory_path() /
                                  ("afterimage_" + tag + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  temp_dirs_of_this_process().dirs.push_back(d);
  return d;
}

// A directory of this process's own (the pid in its tag, as several test processes run at
// once): removed at the end of its tests when they passed (kept for inspection after a
// failure), so test runs do not pile copies up in the temp directory (1.2 GB in ~1100
// directories on the development VM before this). remove_if_passed for a suite's TearDownTestSuite;
// RemoveIfPassed at the top of a test that makes one.
inline void remove_if_passed(const std::filesystem::path& d) {
  if (::testing::Test::HasFailure() || ::testing::UnitTest::GetInstance()->failed_test_count() > 0)
    return;
  std::error_code ec;
  std::filesystem::remove_all(d, ec);
}
struct RemoveIfPassed {
  std::filesystem::path dir;
  ~RemoveIfPassed() { remove_if_passed(dir); }
};

// The message of the `E` that fn() throws, or `none` if it throws nothing.
template <class E>
std::string error_of(const std::function<void()>& fn, const std::string& none = "") {
  try {
    fn();
  } catch (const E& e) {
    return e.what();
  }
  return none;
}

// An SVGF-style sequence frame: a square of `side` px (id 2, depth 2) moving right by `speed`
// px per frame over a still background ramp (id 1, depth 10), normal +z, with uniform
// multiplicative color noise of amplitude `noise` (0: noise-free) from std::mt19937(77 + t).
inline Frame moving_square_frame(int w, int h, int t, int side, int speed, float noise = 0.2f) {
  Frame f = Frame::allocate(w, h);
  f.index = t;
  std::mt19937 rng(77 + unsigned(t));
  std::uniform_real_distribution<float> u(-noise, noise);
  const int x0 = 4 + speed * t, y0 = 6;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool in = x >= x0 && x < x0 + side && y >= y0 && y < y0 + side;
      for (int c = 0; c < 3; ++c) {
        f.color.at(x, y, c) = (in ? 2.0f : 0.5f + 0.01f * float(x)) * (1.0f + u(rng));
        f.albedo.at(x, y, c) = in ? 0.8f : 0.5f;
      }
      f.depth.at(x, y, 0) = in ? 2.0f : 10.0f;
      f.normal.at(x, y, 2) = 1.0f;
      f.id.at(x, y, 0) = in ? 2 : 1;
      f.motion.at(x, y, 0) = in && t > 0 ? -float(speed) : 0.0f;
    }
  return f;
}

}  // namespace afterimage::test
