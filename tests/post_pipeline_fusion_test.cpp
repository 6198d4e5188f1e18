// run_post_stages fuses tonemap into the rows flare composites (post/row_pass.h): the chain's
// output must be the unfused chain's bit for bit, whatever the settings (flare off included),
// thread count or SIMD width.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "pipeline/bench_passes.h"
#include "pipeline/post_pipeline.h"
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
      ASSERT_TRUE(tonemap->row_pass(ex));
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

TEST(PostPipelineFusion, OnlyFlareFusesAndOnlyTonemapIsAPerPixelStage) {
  for (const PostStageInfo& info : post_stages()) {
    const auto stage = info.make();
    EXPECT_EQ(stage->fuses_row_pass(), info.name == "flare") << info.name;
    EXPECT_EQ(bool(stage->row_pass(Exec{})), info.name == "tonemap") << info.name;
  }
}

}  // namespace
}  // namespace afterimage
