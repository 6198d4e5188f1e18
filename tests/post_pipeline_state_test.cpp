// Post stages with state in `afterimage run` (issue 12): the motion_blur stage's trail runs
// over the frames the pipeline is given, PipelineMethod::reset() restarts it, and a pipeline
// whose post stage keeps frames refuses to save or load state (one-line SettingsError naming
// the stage) instead of continuing with an empty history.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "core/error.h"
#include "run/post_pipeline.h"

namespace afterimage {
namespace {

Frame numbered_frame(int t) {
  Frame f = Frame::allocate(16, 8);
  f.index = t;
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x)
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = float(t) + 0.25f * float(c);
  return f;
}

TEST(PostPipelineState, MotionBlurTrailRunsOverTheSequenceAndResets) {
  auto m = make_pipeline_method(
      parse_pipeline("motion_blur", {"motion_blur.trail_frames=3", "motion_blur.shutter=0"}), {});
  std::vector<float> seen;
  for (int t = 0; t < 5; ++t) seen.push_back(m->process(numbered_frame(t)).color.at(3, 2, 0));
  // Box average of the last three frames (fewer at the start): 0, 0.5, 1, 2, 3.
  EXPECT_EQ(seen, (std::vector<float>{0.0f, 0.5f, 1.0f, 2.0f, 3.0f}));
  m->reset();
  EXPECT_EQ(m->process(numbered_frame(9)).color.at(3, 2, 0), 9.0f);
  try {
    m->save_state("/nonexistent/state.bin");
    ADD_FAILURE() << "save_state accepted a stage with state";
  } catch (const SettingsError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("motion_blur"), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
  EXPECT_THROW(m->load_state("/nonexistent/state.bin"), SettingsError);
  auto with_taa = make_pipeline_method(
      parse_pipeline("taa,motion_blur", {"motion_blur.camera_rotation=false"}), {});
  EXPECT_THROW(with_taa->save_state("/nonexistent/state.bin"), SettingsError);
}

TEST(PostPipelineState, DefaultMotionBlurStageIsStateless) {
  auto m = make_pipeline_method(parse_pipeline("motion_blur", {}), {});
  const Frame a = numbered_frame(1);
  const Frame b = numbered_frame(4);
  m->process(a);
  EXPECT_EQ(m->process(b).color, b.color);  // no motion: unchanged, nothing of frame a
}

}  // namespace
}  // namespace afterimage
