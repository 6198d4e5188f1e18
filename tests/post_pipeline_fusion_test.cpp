// run_post_stages fuses the stages that run row by row into the rows of the stage before them
// (post/row_pass.h): tonemap into flare's or bloom's rows, flare's light (of bloom's input) into
// bloom's. The chain's output must be the unfused computation's bit for bit, whatever the
// settings (stages off included), thread count or SIMD width.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "apps/bench/bench_passes.h"
#include "core/error.h"
#include "post/bloom.h"
#include "post/flare.h"
#include "post/tonemap.h"
#include "run/post_pipeline.h"
#include "test_util.h"

namespace afterimage {
namespace {

std::unique_ptr<PostStage> make_stage(const std::string& name) {
  for (const PostStageInfo& info : post_stages())
    if (info.name == name) return info.make();
  ADD_FAILURE() << "no stage " << name;
  return nullptr;
}

bool same_bits(const ImageF& a, const ImageF& b) {
  return a.same_shape(b) &&
         std::memcmp(a.data().data(), b.data().data(), a.data().size() * sizeof(float)) == 0;
}

TEST(PostPipelineFusion, TonemapOnFlaresRowsIsTheUnfusedChainBitForBit) {
  // Odd sizes (partial lane blocks, uneven flare bands) with the bench frame's bright lights.
  const Frame frame = synthetic_post_frame(203, 117, 0);
  const std::vector<std::vector<std::string>> settings{
      {},
      {"tonemap.operator=agx", "tonemap.srgb=false", "flare.streak_lines=3"},
      // Every flare intensity 0: lens_flare returns its input, the tonemap still runs.
      {"flare.sprite_intensity=0", "flare.ghost_intensity=0", "flare.halo_intensity=0",
       "flare.streak_intensity=0", "flare.glare_intensity=0"},
  };
  for (const auto& sets : settings)
    for (const Exec& ex : {Exec{}, Exec{2, true}, test::scalar_exec()}) {
      auto flare = make_stage("flare");
      auto tonemap = make_stage("tonemap");
      for (const std::string& a : sets) {
        const size_t dot = a.find('.');
        (a.substr(0, dot) == "flare" ? flare : tonemap)->set(a.substr(dot + 1));
      }
      ASSERT_TRUE(flare->fuses_row_pass());
      ASSERT_TRUE(tonemap->row_pass(ex, frame.color));
      const ImageF unfused = tonemap->process(frame, flare->process(frame, frame.color, ex), ex);
      const ImageF fused = run_post_stages({flare.get(), tonemap.get()}, frame, frame.color, ex);
      EXPECT_TRUE(same_bits(fused, unfused))
          << "settings " << sets.size() << ", threads " << ex.threads << ", simd " << ex.simd;
      // And the fused chain is not a no-op: the tonemap ran (display values <= 1).
      float most = 0.0f;
      for (float v : fused.data()) most = std::max(most, v);
      EXPECT_LE(most, 1.0f);
      EXPECT_GT(most, 0.0f);
    }
}

TEST(PostPipelineFusion, BloomRowsTakeTheFlareOfBloomsInputAndTheTonemapBitForBit) {
  const Frame frame = synthetic_post_frame(203, 117, 0);
  const std::vector<std::vector<std::string>> settings{
      {},
      {"tonemap.operator=reinhard", "flare.streak_lines=3", "bloom.levels=3"},
      // Karis: bloom composites the whole frame first, then runs the row passes over it.
      {"bloom.karis=true", "bloom.threshold=1"},
      {"bloom.intensity=0"},  // bloom returns its input: the row passes still run
      {"flare.sprite_intensity=0", "flare.ghost_intensity=0", "flare.halo_intensity=0",
       "flare.streak_intensity=0", "flare.glare_intensity=0"},  // flare adds nothing
  };
  for (const auto& sets : settings)
    for (const Exec& ex : {Exec{}, Exec{2, true}, test::scalar_exec()}) {
      auto bloom = make_stage("bloom"), flare = make_stage("flare"),
           tonemap = make_stage("tonemap");
      post::BloomSettings bs;
      post::FlareSettings fs;
      post::TonemapSettings ts;
      for (const std::string& a : sets) {
        const size_t dot = a.find('.');
        const std::string stage = a.substr(0, dot), kv = a.substr(dot + 1);
        if (stage == "bloom") {
          bloom->set(kv);
          post::BloomSettings::params().set_assignment(bs, kv);
        } else if (stage == "flare") {
          flare->set(kv);
          post::FlareSettings::params().set_assignment(fs, kv);
        } else {
          tonemap->set(kv);
          post::TonemapSettings::params().set_assignment(ts, kv);
        }
      }
      // The unfused computation: bloom's output plus the flare light of bloom's input (none
      // when every intensity is 0: lens_flare's copy), then the tonemap.
      ImageF expected = post::bloom(frame.color, bs, ex);
      const ImageF bloomed = expected;
      const bool flare_on = fs.sprite_intensity > 0.0f || fs.ghost_intensity > 0.0f ||
                            fs.halo_intensity > 0.0f || fs.streak_intensity > 0.0f ||
                            fs.glare_intensity > 0.0f;
      if (flare_on) {
        const ImageF light = post::lens_flare_light(frame.color, fs, ex);
        for (size_t i = 0; i < expected.data().size(); ++i) expected.data()[i] += light.data()[i];
      }
      const std::string what = fmt::format("settings {}, threads {}, simd {}", fmt::join(sets, " "),
                                           ex.threads, ex.simd);
      const ImageF fused2 = run_post_stages({bloom.get(), flare.get()}, frame, frame.color, ex);
      EXPECT_TRUE(same_bits(fused2, expected)) << "bloom,flare: " << what;
      const ImageF fused3 =
          run_post_stages({bloom.get(), flare.get(), tonemap.get()}, frame, frame.color, ex);
      EXPECT_TRUE(same_bits(fused3, post::tonemap(expected, ts, ex)))
          << "bloom,flare,tonemap: " << what;
      const ImageF bloom_tonemap =
          run_post_stages({bloom.get(), tonemap.get()}, frame, frame.color, ex);
      EXPECT_TRUE(same_bits(bloom_tonemap, post::tonemap(bloomed, ts, ex)))
          << "bloom,tonemap: " << what;
      // The flare is of bloom's input, not of its output: those differ where bloom spreads the
      // lights (the bright pass sees the bloomed halo too).
      if (flare_on && bs.intensity > 0.0f) {
        EXPECT_FALSE(same_bits(fused2, post::lens_flare(bloomed, fs, ex))) << what;
      }
    }
}

TEST(PostPipelineFusion, BloomAndFlareFuseAndFlareAndTonemapRunRowByRow) {
  for (const PostStageInfo& info : post_stages()) {
    const auto stage = info.make();
    const ImageF img(8, 8, 3, 1.0f);
    EXPECT_EQ(stage->fuses_row_pass(), info.name == "bloom" || info.name == "flare") << info.name;
    EXPECT_EQ(bool(stage->row_pass(Exec{}, img)), info.name == "flare" || info.name == "tonemap")
        << info.name;
  }
}

// With threads, flare's light is made in a task while bloom runs (lens_flare_row_pass), and
// bloom's composite tasks wait for it. A first version waited inside std::call_once with a
// task_group wait, during which the waiting thread ran another composite task that reached
// the same call_once: the bench hung after ~250 chains at 1080p on 2 threads. Many chains on
// small frames, more tasks than cores: every one must finish with the unfused values. (A hang
// fails through ctest's timeout.)
TEST(PostPipelineFusion, FlareMadeBesideBloomNeverWaitsOnItself) {
  const Frame frame = synthetic_post_frame(96, 64, 0);
  auto bloom = make_stage("bloom"), flare = make_stage("flare");
  for (const Exec& ex : {Exec{2, true}, Exec{4, true}}) {
    ImageF expected = post::bloom(frame.color, post::BloomSettings{}, ex);
    const ImageF light = post::lens_flare_light(frame.color, post::FlareSettings{}, ex);
    for (size_t i = 0; i < expected.data().size(); ++i) expected.data()[i] += light.data()[i];
    tbb::task_arena arena(ex.threads);
    arena.execute([&] {
      for (int i = 0; i < 400; ++i) {
        const ImageF fused = run_post_stages({bloom.get(), flare.get()}, frame, frame.color, ex);
        ASSERT_TRUE(same_bits(fused, expected)) << "threads " << ex.threads << ", chain " << i;
      }
    });
  }
}

TEST(PostPipelineFusion, FlaresRowPassRejectsARowOutsideItsLight) {
  const Frame frame = synthetic_post_frame(64, 48, 0);
  const post::RowPass pass = post::lens_flare_row_pass(frame.color, post::FlareSettings{}, Exec{});
  const post::RowFn fn = pass();
  std::vector<float> row(3 * 64, 0.0f);
  float* const rows[3] = {row.data(), row.data() + 64, row.data() + 128};
  EXPECT_NO_THROW(fn(47, 0, rows, 64));
  EXPECT_NO_THROW(fn(47, 0, rows, 40));  // a row in pieces
  EXPECT_NO_THROW(fn(47, 40, rows, 24));
  EXPECT_THROW(fn(48, 0, rows, 64), InputError);
  EXPECT_THROW(fn(0, 1, rows, 64), InputError);
  EXPECT_THROW(fn(0, -1, rows, 8), InputError);
}

// A RowFn given each row in pieces of any sizes (post/row_pass.h: increasing x0, the first at 0)
// gives the bits it gives the rows whole: flare's (the bench frame's lights, so sprite and
// glare rows too) and tonemap's, against one call a row.
TEST(PostPipelineFusion, RowFnsGiveTheSameRowsInPieces) {
  const Frame frame = synthetic_post_frame(203, 117, 0);
  post::FlareSettings fs;
  fs.glare_intensity = 0.05f;
  const std::vector<std::pair<std::string, post::RowPass>> passes{
      {"flare", post::lens_flare_row_pass(frame.color, fs, Exec{})},
      {"tonemap", post::tonemap_row_pass(post::TonemapSettings{}, Exec{})}};
  for (const auto& [name, pass] : passes) {
    ImageF whole = frame.color, pieces = frame.color;
    const post::RowFn a = pass(), b = pass();
    for (int y = 0; y < frame.height; ++y) {
      float* const rows[3] = {whole.row(0, y), whole.row(1, y), whole.row(2, y)};
      a(y, 0, rows, frame.width);
      int x0 = 0;
      for (int n : {1, 7, 33, 16, 64}) {  // then the rest
        float* const at[3] = {pieces.row(0, y) + x0, pieces.row(1, y) + x0, pieces.row(2, y) + x0};
        b(y, x0, at, n);
        x0 += n;
      }
      float* const rest[3] = {pieces.row(0, y) + x0, pieces.row(1, y) + x0, pieces.row(2, y) + x0};
      b(y, x0, rest, frame.width - x0);
    }
    EXPECT_FALSE(same_bits(whole, frame.color)) << name;
    EXPECT_TRUE(same_bits(pieces, whole)) << name;
  }
}

// Flare's RowPass gives the same rows whether the pass it is fused into hands over the
// radiance's rows (input_row, in any order, repeats ignored) or not (it then reads
// them itself), or hands over only some (the same: it reads them all again; here every row but
// those of the bench frame's first bright light, at h / 4).
TEST(PostPipelineFusion, FlaresLightIsTheSameFromHandedOverInputRows) {
  const Frame frame = synthetic_post_frame(203, 117, 0);
  const int h = frame.height;
  for (const Exec& ex : {Exec{1, true}, Exec{2, true}, test::scalar_exec()}) {
    const ImageF base(frame.width, h, 3, 0.25f);
    const ImageF expected =
        post::apply_row_pass(base, post::lens_flare_row_pass(frame.color, {}, ex), ex);
    ASSERT_FALSE(same_bits(expected, base));
    for (const char* handed : {"all", "all but a light's", "none"}) {
      const post::RowPass pass = post::lens_flare_row_pass(frame.color, {}, ex);
      ASSERT_TRUE(pass.input_row && pass.input_done);
      const bool all = std::strcmp(handed, "all") == 0, none = std::strcmp(handed, "none") == 0;
      for (int k = 0; k < h && !none; ++k) {
        const int y = (h / 2 + k * 37) % h;  // rows from the middle, in a scattered order
        if (all || std::abs(y - h / 4) > 2) pass.input_row(y);
      }
      for (int y = 0; y < 5 && all; ++y) pass.input_row(y);  // repeats
      pass.input_done();
      EXPECT_TRUE(same_bits(post::apply_row_pass(base, pass, ex), expected))
          << "threads " << ex.threads << ", rows handed: " << handed;
    }
  }
}

// bloom hands each row of its input to its RowPass as its first downsample reads it (at least
// once: the downsample's bands overlap), then says it is done before the first RowFn; on the
// paths that read no rows (Karis average, intensity 0) it hands none and says so at once.
TEST(PostPipelineFusion, BloomHandsItsInputRowsToItsRowPass) {
  const Frame frame = synthetic_post_frame(97, 61, 0);
  for (const Exec& ex : {Exec{1, true}, Exec{2, true}}) {
    for (const char* set : {"", "karis=true", "intensity=0"}) {
      post::BloomSettings s;
      if (*set) post::BloomSettings::params().set_assignment(s, set);
      std::vector<std::atomic<int>> calls(size_t(frame.height));
      std::atomic<int> done{0}, made_before_done{0};
      post::RowPass pass([&]() -> post::RowFn {
        made_before_done += done.load() == 0;
        return [](int, int, float* const*, int) {};
      });
      pass.input_row = [&](int y) { ++calls[size_t(y)]; };
      pass.input_done = [&] { ++done; };
      post::bloom(frame.color, s, ex, pass);
      EXPECT_EQ(done.load(), 1) << set;
      EXPECT_EQ(made_before_done.load(), 0) << set;
      const bool reads = *set == '\0';
      for (int y = 0; y < frame.height; ++y)
        ASSERT_TRUE(reads ? calls[size_t(y)] >= 1 : calls[size_t(y)] == 0)
            << set << ", row " << y << ": " << calls[size_t(y)];
    }
  }
}

// bloom and flare write over an input they are given (their ImageF&& overloads, which
// run_post_stages uses for the frames it owns): the same bits as into a new image, for every
// path; the output in the input's planes where the composite runs (the point of it); and no
// row written before the RowPass's first RowFn exists. The RowPass below checks the input when
// its first RowFn is made and holds every other maker until then (as flare's light, which is
// what reads the input): a task that wrote a row before making its RowFn would fail it.
TEST(PostPipelineFusion, BloomAndFlareWriteOverAGivenInputWithTheSameBits) {
  const Frame frame = synthetic_post_frame(203, 117, 0);
  // For flare, every pixel over its threshold: its light (ghosts of the whole frame) then
  // changes every row, so a row written early shows (the bench frame's top rows get none).
  ImageF bright = frame.color;
  for (float& v : bright.data()) v += 12.0f;
  const std::vector<std::pair<std::string, std::string>> cases{
      {"bloom", ""}, {"bloom", "levels=3"},      {"bloom", "karis=true"}, {"bloom", "intensity=0"},
      {"flare", ""}, {"flare", "streak_lines=3"}};
  for (const auto& [stage, set] : cases)
    for (const Exec& ex : {Exec{1, true}, Exec{2, true}, Exec{4, true}, test::scalar_exec()}) {
      const std::string what =
          fmt::format("{} {}, threads {}, simd {}", stage, set, ex.threads, ex.simd);
      post::BloomSettings bs;
      post::FlareSettings fs;
      if (!set.empty()) {
        if (stage == "bloom")
          post::BloomSettings::params().set_assignment(bs, set);
        else
          post::FlareSettings::params().set_assignment(fs, set);
      }
      const ImageF& src = stage == "bloom" ? frame.color : bright;
      ImageF in = src;
      const float* const planes = in.data().data();
      const auto halve = [](int, int, float* const* rows, int n) {
        for (int c = 0; c < 3; ++c)
          for (int x = 0; x < n; ++x) rows[c][x] *= 0.5f;  // the rows come: it shows
      };
      std::once_flag first;
      bool whole_at_first = false;
      int made = 0;
      std::mutex made_mutex;
      const post::RowPass checking([&]() -> post::RowFn {
        std::call_once(first, [&] { whole_at_first = same_bits(in, src); });
        std::lock_guard<std::mutex> lock(made_mutex);
        ++made;
        return halve;
      });
      const post::RowPass pass([&]() -> post::RowFn { return halve; });
      const ImageF expected =
          stage == "bloom" ? post::bloom(src, bs, ex, pass) : post::lens_flare(src, fs, ex, pass);
      ASSERT_FALSE(same_bits(expected, src)) << what;
      const ImageF out = stage == "bloom" ? post::bloom(std::move(in), bs, ex, checking)
                                          : post::lens_flare(std::move(in), fs, ex, checking);
      EXPECT_TRUE(same_bits(out, expected)) << what;
      EXPECT_TRUE(whole_at_first) << what;
      EXPECT_GT(made, 0) << what;
      // The composite over the input: bloom's Karis path composites a frame of its own.
      if (set != "karis=true") {
        EXPECT_EQ(out.data().data(), planes) << what;
      }
      // An empty RowPass.
      ImageF again = src;
      const ImageF plain = stage == "bloom" ? post::bloom(std::move(again), bs, ex, {})
                                            : post::lens_flare(std::move(again), fs, ex, {});
      EXPECT_TRUE(same_bits(
          plain, stage == "bloom" ? post::bloom(src, bs, ex) : post::lens_flare(src, fs, ex)))
          << what;
    }
}

// The whole chain the issue times, as run_post_stages runs it (bloom composites over motion
// blur's output, which the chain owns; flare's light of that frame and the tonemap on its
// rows), and from a color the caller gives up, against each stage run on its own copy; with
// bloom on each of its paths and flare adding nothing. bloom.intensity=0 once moved its input
// away before flare's light, made of that input in a task of its own, had read it.
TEST(PostPipelineFusion, TheChainOverItsOwnFramesIsTheStagesOneByOne) {
  const Frame frame = synthetic_post_frame(203, 117, 0);
  const std::vector<std::vector<std::string>> settings{
      {},
      {"bloom.intensity=0"},
      {"bloom.karis=true", "bloom.threshold=1"},
      {"flare.sprite_intensity=0", "flare.ghost_intensity=0", "flare.halo_intensity=0",
       "flare.streak_intensity=0", "flare.glare_intensity=0"},
  };
  const std::vector<std::string> names{"dof", "motion_blur", "bloom", "flare", "tonemap"};
  for (const auto& sets : settings)
    for (const Exec& ex : {Exec{1, true}, Exec{2, true}, test::scalar_exec()}) {
      std::vector<std::unique_ptr<PostStage>> owned;
      std::vector<PostStage*> chain;
      for (const std::string& name : names) {
        owned.push_back(make_stage(name));
        chain.push_back(owned.back().get());
      }
      post::FlareSettings fs;
      for (const std::string& a : sets) {
        const size_t dot = a.find('.');
        const std::string stage = a.substr(0, dot), kv = a.substr(dot + 1);
        owned[size_t(std::find(names.begin(), names.end(), stage) - names.begin())]->set(kv);
        if (stage == "flare") post::FlareSettings::params().set_assignment(fs, kv);
      }
      const bool flare_on = fs.sprite_intensity > 0.0f || fs.ghost_intensity > 0.0f ||
                            fs.halo_intensity > 0.0f || fs.streak_intensity > 0.0f ||
                            fs.glare_intensity > 0.0f;
      // One by one: flare's light is of bloom's input, added to bloom's output.
      const ImageF blurred =
          owned[1]->process(frame, owned[0]->process(frame, frame.color, ex), ex);
      ImageF expected = owned[2]->process(frame, blurred, ex);
      if (flare_on) {
        const ImageF light = post::lens_flare_light(blurred, fs, ex);
        for (size_t i = 0; i < expected.data().size(); ++i) expected.data()[i] += light.data()[i];
      }
      expected = owned[4]->process(frame, expected, ex);
      const std::string what =
          fmt::format("{}: threads {}, simd {}", fmt::join(sets, " "), ex.threads, ex.simd);
      EXPECT_TRUE(same_bits(run_post_stages(chain, frame, frame.color, ex), expected)) << what;
      EXPECT_TRUE(same_bits(run_post_stages(chain, frame, ImageF(frame.color), ex), expected))
          << "given up: " << what;
      // From bloom on, the frame given up is bloom's input; and flare's, without bloom.
      const std::vector<PostStage*> tail(chain.begin() + 2, chain.end());
      EXPECT_TRUE(same_bits(run_post_stages(tail, frame, ImageF(blurred), ex), expected))
          << "bloom first: " << what;
      ImageF flared = blurred;
      if (flare_on) {
        const ImageF light = post::lens_flare_light(blurred, fs, ex);
        for (size_t i = 0; i < flared.data().size(); ++i) flared.data()[i] += light.data()[i];
      }
      const std::vector<PostStage*> no_bloom{chain[0], chain[1], chain[3], chain[4]};
      EXPECT_TRUE(same_bits(run_post_stages(no_bloom, frame, frame.color, ex),
                            owned[4]->process(frame, flared, ex)))
          << "without bloom: " << what;
    }
}

}  // namespace
}  // namespace afterimage
