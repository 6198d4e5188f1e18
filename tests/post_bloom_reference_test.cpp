// post/bloom: the fast schedule (bloom.cpp) against the pass written plainly
// (bloom_reference.cpp), bit for bit, for every setting, size, channel count and entry point,
// and --simd off running the plain statement.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"
#include "post/bloom.h"
#include "post/flare.h"
#include "post/tonemap.h"
#include "test_util.h"

namespace afterimage::bloom_reference_test {
namespace {

using post::BloomSettings;

// The fast schedule on two threads, SIMD on.
Exec fast_exec() {
  return test::with_threads(2);
}
// The plain statement on n threads (Exec::simd is not what it dispatches on).
Exec plain_exec(int threads) {
  Exec e;
  e.threads = threads;
  e.simd = false;
  return e;
}

// An HDR image of `nc` channels: uniform [0, 4) with a few spikes up to 2000 (light sources),
// and with `hostile` a NaN, +-Inf, negative values and a -0 among them.
ImageF hdr_input(int w, int h, int nc, unsigned seed, bool hostile) {
  ImageF img = test::random_image(w, h, nc, seed, 0.0f, 4.0f);
  std::mt19937 rng(seed + 7);
  std::uniform_int_distribution<int> ux(0, w - 1), uy(0, h - 1), uc(0, nc - 1);
  std::uniform_real_distribution<float> uv(50.0f, 2000.0f);
  for (int i = 0; i < 1 + w * h / 64; ++i) img.at(ux(rng), uy(rng), uc(rng)) = uv(rng);
  if (hostile) {
    const float specials[] = {std::numeric_limits<float>::quiet_NaN(),
                              std::numeric_limits<float>::infinity(),
                              -std::numeric_limits<float>::infinity(),
                              -3.0f,
                              -0.0f,
                              -1e-3f};
    for (const float v : specials) img.at(ux(rng), uy(rng), uc(rng)) = v;
  }
  return img;
}

struct NamedSettings {
  std::string name;
  BloomSettings s;
};
std::vector<NamedSettings> settings_cases() {
  std::vector<NamedSettings> cases;
  const auto add = [&](const std::string& name, auto change) {
    BloomSettings s;
    change(s);
    cases.push_back({name, s});
  };
  add("default", [](BloomSettings&) {});
  add("karis", [](BloomSettings& s) { s.karis = true; });
  add("threshold knee 0", [](BloomSettings& s) {
    s.threshold = 1.5f;
    s.knee = 0.0f;
  });
  add("threshold knee 0.5", [](BloomSettings& s) {
    s.threshold = 1.5f;
    s.knee = 0.5f;
  });
  add("karis threshold knee 1", [](BloomSettings& s) {
    s.karis = true;
    s.threshold = 2.0f;
    s.knee = 1.0f;
  });
  add("scale 3.5 intensity 0.7", [](BloomSettings& s) {
    s.scale = 3.5f;
    s.intensity = 0.7f;
  });
  add("intensity 0", [](BloomSettings& s) { s.intensity = 0.0f; });
  for (int levels = 1; levels <= 8; ++levels)
    add("levels " + std::to_string(levels), [&](BloomSettings& s) {
      s.levels = levels;
      s.intensity = 0.3f;
    });
  add("levels 12 karis", [](BloomSettings& s) {
    s.levels = 12;
    s.karis = true;
  });
  return cases;
}

struct Size {
  int w, h;
};
constexpr Size kSizes[] = {{1, 1}, {2, 3}, {7, 5}, {33, 17}, {64, 36}, {45, 29}, {301, 9}};

std::string run_name(const std::string& settings, Size z, int nc, bool hostile) {
  return settings + ", " + std::to_string(z.w) + "x" + std::to_string(z.h) + "x" +
         std::to_string(nc) + (hostile ? ", NaN/Inf/negative" : "");
}

// Every public step and the whole pass, fast against plain.
TEST(PostBloomReference, EveryStepIsThePlainStatementBitForBit) {
  const Exec fast = fast_exec(), plain = plain_exec(1);
  for (const NamedSettings& c : settings_cases())
    for (const Size z : kSizes)
      for (const int nc : {1, 3, 4})
        for (const bool hostile : {false, true}) {
          const std::string what = run_name(c.name, z, nc, hostile);
          const ImageF img = hdr_input(z.w, z.h, nc, unsigned(z.w * 31 + z.h + nc), hostile);
          const BloomSettings& s = c.s;
          const ImageF p = post::bloom_source_reference(img, s, plain);
          test::expect_same_bits(post::bloom_source(img, s, fast), p, "source, " + what);
          const std::vector<ImageF> mips = post::bloom_mips_reference(p, s, plain);
          const std::vector<ImageF> fast_mips = post::bloom_mips(p, s, fast);
          ASSERT_EQ(fast_mips.size(), mips.size()) << what;
          for (size_t k = 0; k < mips.size(); ++k)
            test::expect_same_bits(fast_mips[k], mips[k], "mip " + std::to_string(k) + ", " + what);
          const ImageF light = post::bloom_blur_reference(p, s, plain);
          test::expect_same_bits(post::bloom_blur(p, s, fast), light, "blur, " + what);
          test::expect_same_bits(post::bloom_composite(img, p, light, s, fast),
                                 post::bloom_composite_reference(img, p, light, s, plain),
                                 "composite, " + what);
          test::expect_same_bits(post::bloom(img, s, fast),
                                 post::bloom_mip_chain_reference(img, s, plain), "bloom, " + what);
          if (HasFatalFailure()) return;
        }
}

// bloom_blur also takes a source that is not a bright pass: negative values (a NaN or an
// infinity there would spread, and NaN payloads are not fixed by IEEE 754).
TEST(PostBloomReference, BlurOfAnySourceIsThePlainStatement) {
  const Exec fast = fast_exec(), plain = plain_exec(1);
  for (const bool karis : {false, true})
    for (const Size z : kSizes) {
      const ImageF source = test::random_image(z.w, z.h, 3, unsigned(z.w + z.h), -2.0f, 6.0f);
      BloomSettings s;
      s.karis = karis;
      s.levels = 4;
      test::expect_same_bits(
          post::bloom_blur(source, s, fast), post::bloom_blur_reference(source, s, plain),
          std::to_string(z.w) + "x" + std::to_string(z.h) + " karis " + std::to_string(karis));
    }
}

TEST(PostBloomReference, PlainStatementOnAnyThreadCountGivesTheSameBits) {
  for (const bool karis : {false, true}) {
    const ImageF img = hdr_input(131, 67, 3, 5, true);
    BloomSettings s;
    s.karis = karis;
    s.threshold = karis ? 1.0f : 0.0f;
    test::expect_same_bits(post::bloom_mip_chain_reference(img, s, plain_exec(3)),
                           post::bloom_mip_chain_reference(img, s, plain_exec(1)),
                           "karis " + std::to_string(karis));
  }
}

// --simd off (Exec::simd false) runs the plain statement from every entry point.
TEST(PostBloomReference, SimdOffRunsThePlainStatement) {
  const ImageF img = hdr_input(53, 31, 3, 11, true);
  BloomSettings s;
  s.threshold = 1.0f;
  const Exec off = plain_exec(2);
  const ImageF p = post::bloom_source_reference(img, s);
  EXPECT_EQ(post::bloom_source(img, s, off), p);
  EXPECT_EQ(post::bloom_mips(p, s, off), post::bloom_mips_reference(p, s));
  const ImageF light = post::bloom_blur_reference(p, s);
  EXPECT_EQ(post::bloom_blur(p, s, off), light);
  test::expect_same_bits(post::bloom_composite(img, p, light, s, off),
                         post::bloom_composite_reference(img, p, light, s), "composite, simd off");
  test::expect_same_bits(post::bloom(img, s, off), post::bloom_mip_chain_reference(img, s),
                         "bloom, simd off");
  // The same checks and messages as the fast schedule's.
  BloomSettings bad;
  bad.levels = 13;
  const auto settings_error = [](const std::function<void()>& fn) {
    return test::error_of<SettingsError>(fn, "no error");
  };
  EXPECT_EQ(settings_error([&] { (void)post::bloom(img, bad, off); }),
            settings_error([&] { (void)post::bloom(img, bad, fast_exec()); }));
  const auto input_error = [](const std::function<void()>& fn) {
    return test::error_of<InputError>(fn, "no error");
  };
  EXPECT_EQ(input_error([&] { (void)post::bloom(ImageF{}, s, off); }),
            input_error([&] { (void)post::bloom(ImageF{}, s, fast_exec()); }));
  EXPECT_EQ(
      input_error([&] { (void)post::bloom_composite(img, p, ImageF(2, 2, 3), s, off); }),
      input_error([&] { (void)post::bloom_composite(img, p, ImageF(2, 2, 3), s, fast_exec()); }));
  const ImageF one_channel(9, 7, 1, 1.0f);
  const post::RowPass then = post::tonemap_row_pass({}, fast_exec());
  EXPECT_EQ(input_error([&] { (void)post::bloom(one_channel, s, off, then); }),
            input_error([&] { (void)post::bloom(one_channel, s, fast_exec(), then); }));
}

// A RowPass with input hooks (as flare's) that doubles every value it is given: what it sees
// must be the final rows whether the input rows come (fast) or not (plain). input_row may come
// from several tasks at once: it does nothing; input_done counts its calls.
post::RowPass doubling_row_pass(int* input_done_calls) {
  post::RowPass pass([] {
    return post::RowFn([](int, int, float* const* rows, int n) {
      for (int c = 0; c < 3; ++c)
        for (int x = 0; x < n; ++x) rows[c][x] = rows[c][x] * 2.0f;
    });
  });
  pass.input_row = [](int) {};
  pass.input_done = [input_done_calls] { ++*input_done_calls; };
  return pass;
}

// The RowPass named `name` over `radiance` (flare's light is of the radiance, as in the chain).
post::RowPass named_row_pass(const std::string& name, const ImageF& radiance) {
  const post::RowPass tone = post::tonemap_row_pass({}, fast_exec());
  if (name == "tonemap") return tone;
  if (name == "flare then tonemap") {
    post::FlareSettings fs;
    fs.threshold = 50.0f;
    return post::row_pass_then(post::lens_flare_row_pass(radiance, fs, fast_exec()), tone);
  }
  return {};
}

// The overloads with a RowPass fused after the pass, and the one that writes over its input.
TEST(PostBloomReference, RowPassOverloadsAreThePlainStatement) {
  const ImageF img = hdr_input(291, 37, 3, 21, true);
  const Exec fast = fast_exec(), plain = plain_exec(1);
  for (const NamedSettings& c : settings_cases()) {
    if (c.s.levels > 6 && c.name != "levels 12 karis") continue;
    for (const std::string name : {"none", "tonemap", "flare then tonemap"}) {
      const std::string what = c.name + ", " + name;
      const ImageF expected =
          post::bloom_mip_chain_reference(img, c.s, plain, named_row_pass(name, img));
      test::expect_same_bits(post::bloom(img, c.s, fast, named_row_pass(name, img)), expected,
                             what);
      ImageF given = img;
      const post::RowPass then = named_row_pass(name, given);
      test::expect_same_bits(post::bloom(std::move(given), c.s, fast, then), expected,
                             what + ", over its input");
      ImageF given_plain = img;
      const float* const planes = given_plain.data().data();
      const post::RowPass then_plain = named_row_pass(name, given_plain);
      const ImageF over =
          post::bloom_mip_chain_reference(std::move(given_plain), c.s, plain, then_plain);
      test::expect_same_bits(over, expected, what + ", plain over its input");
      EXPECT_EQ(over.data().data(), planes) << what;
    }
    // A RowPass with input hooks: input_done comes once either way.
    int done_fast = 0, done_plain = 0;
    const ImageF doubled = post::bloom(img, c.s, fast, doubling_row_pass(&done_fast));
    test::expect_same_bits(
        doubled, post::bloom_mip_chain_reference(img, c.s, plain, doubling_row_pass(&done_plain)),
        c.name + ", doubling");
    EXPECT_EQ(done_fast, 1) << c.name;
    EXPECT_EQ(done_plain, 1) << c.name;
    if (HasFatalFailure()) return;
  }
}

}  // namespace
}  // namespace afterimage::bloom_reference_test
