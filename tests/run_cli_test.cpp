// `afterimage run --pipeline` (issue 12): stages in the DESIGN.md order whatever the order
// given, settings per stage through the tables, the same output as resolve + tonemap applied by
// hand, and one-line errors for unknown stages and settings.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "cli_util.h"
#include "io/io.h"
#include "pipeline/post_pipeline.h"
#include "post/tonemap.h"
#include "test_util.h"

namespace afterimage {
namespace {

namespace fs = std::filesystem;

TEST(PostPipeline, ParsesStagesInChainOrderAndRoutesSettings) {
  const PipelineSpec p =
      parse_pipeline("tonemap,taa:hdrp", {"tonemap.operator=agx", "taa.alpha=0.2"});
  EXPECT_EQ(p.temporal, "taa:hdrp");
  EXPECT_EQ(p.post, std::vector<std::string>{"tonemap"});
  const PipelineSpec q = parse_pipeline("taa", {});
  EXPECT_EQ(q.temporal.rfind("taa:", 0), 0u);
  EXPECT_THROW(parse_pipeline("taa,taau", {}), SettingsError);
  EXPECT_THROW(parse_pipeline("taa,glow", {}), SettingsError);
  EXPECT_THROW(parse_pipeline("tonemap,tonemap", {}), SettingsError);
  EXPECT_THROW(parse_pipeline("", {}), SettingsError);
  // Chain order, whatever the listed order.
  EXPECT_EQ(parse_pipeline("tonemap,bloom,motion_blur,dof", {}).post,
            (std::vector<std::string>{"dof", "motion_blur", "bloom", "tonemap"}));
  EXPECT_THROW(parse_pipeline("tonemap", {"taa.alpha=0.2"}), SettingsError);
  EXPECT_THROW(parse_pipeline("tonemap", {"operator=agx"}), SettingsError);
  EXPECT_THROW(make_pipeline_method(parse_pipeline("tonemap", {"tonemap.operator=filmic"}), {}),
               SettingsError);
  EXPECT_THROW(make_pipeline_method(parse_pipeline("taa", {"taa.alpha=7"}), {}), SettingsError);
}

TEST(PostPipeline, TonemapOnlyEqualsThePassAppliedByHand) {
  Frame f = Frame::allocate(6, 4);
  f.color = test::random_image(6, 4, 3, 7, 0.0f, 8.0f);
  auto m = make_pipeline_method(parse_pipeline("tonemap", {"tonemap.operator=reinhard"}), {});
  post::TonemapSettings s;
  s.op = post::TonemapOperator::Reinhard;
  EXPECT_EQ(m->process(f).color, post::tonemap(f.color, s));
}

TEST(RunCli, TaaThenTonemapMatchesResolvePlusTonemap) {
  const fs::path dir = test::fresh_temp_dir("run_cli");
  const std::string in = (dir / "in").string();
  ASSERT_EQ(test::run("render --scene motion --frames 3 --size 48x27 --out " + in).code, 0);
  auto r = test::run("run --in " + in + " --out " + (dir / "run").string() +
                     " --pipeline tonemap,taa:hdrp --set tonemap.operator=agx");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("taa:hdrp,tonemap"), std::string::npos) << r.out;
  r = test::run("resolve --in " + in + " --out " + (dir / "taa").string() + " --preset hdrp");
  ASSERT_EQ(r.code, 0) << r.err;
  post::TonemapSettings s;
  s.op = post::TonemapOperator::AgX;
  for (int k = 0; k < 3; ++k) {
    const Frame a = io::read_frame(io::frame_path((dir / "run").string(), k));
    const Frame b = io::read_frame(io::frame_path((dir / "taa").string(), k));
    EXPECT_EQ(a.color, post::tonemap(b.color, s)) << k;
  }
  // 8-bit output after a tonemap stage: written, encoded once.
  r = test::run("run --in " + in + " --out " + (dir / "png").string() +
                " --pipeline taa,tonemap --out-format png");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "png" / "frame.0002.png"));

  const std::string base = "run --in " + in + " --out " + (dir / "bad").string();
  test::expect_one_line_error(test::run(base + " --pipeline taa,glow"), "glow");
  test::expect_one_line_error(test::run(base + " --pipeline taa --set tonemap.exposure=2"),
                              "tonemap");
  test::expect_one_line_error(test::run(base + " --pipeline tonemap --set tonemap.exposure=-1"),
                              "exposure");
  EXPECT_FALSE(fs::exists(dir / "bad"));
}

}  // namespace
}  // namespace afterimage
