// Registries (DESIGN.md §2: presets and built-in scenes are spelled in one place, and every
// reader — CLI help, validation, the demo, the tests — takes names from there).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>

#include "apps/bench/bench.h"
#include "core/error.h"
#include "post/dof.h"
#include "post/motion_blur.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "taa/presets.h"

using namespace afterimage;

TEST(TaaPresetRegistry, NamesUniqueOrderedAndRoundTrip) {
  const auto& presets = taa::taa_presets();
  std::set<std::string> seen;
  for (const auto& p : presets) {
    EXPECT_TRUE(seen.insert(p.name).second) << "duplicate preset " << p.name;
    EXPECT_NE(std::string(p.citation), "") << p.name;
    const taa::TaaSettings s = p.make();
    s.validate();
    EXPECT_EQ(taa::make_preset(p.name), s) << p.name;
  }
  EXPECT_EQ(taa::preset_names(), (std::vector<std::string>{"afterimage", "none", "uncharted4",
                                                           "ue4", "inside", "hdrp", "variance"}));
}

TEST(BuiltinSceneRegistry, NamesUniqueAndEveryEntryBuilds) {
  std::set<std::string> seen;
  std::vector<std::string> names;
  for (const auto& s : render::builtin_scenes()) {
    EXPECT_TRUE(seen.insert(s.name).second) << "duplicate scene " << s.name;
    EXPECT_NE(std::string(s.description), "") << s.name;
    names.emplace_back(s.name);
    const render::Scene animated = s.make(false);
    EXPECT_EQ(animated.name, s.name);
    EXPECT_FALSE(animated.is_static);
    const render::Scene frozen = s.make(true);
    EXPECT_TRUE(frozen.is_static);
    EXPECT_EQ(frozen.name, std::string(s.name) + "-static");
    EXPECT_EQ(render::make_builtin_scene(s.name, false).name, animated.name);
  }
  EXPECT_EQ(render::builtin_scene_names(), names);
  // The demo runs the default TAA preset's tuning scenes and its held-out scenes (issue 10);
  // room and room_light (tuning, but the path tracer's scenes) only by name.
  EXPECT_EQ(render::default_demo_scene_names(),
            (std::vector<std::string>{"thin", "motion", "orbit", "light", "sparkle", "moire",
                                      "blades", "cut", "penumbra", "focus"}));
  for (const auto& n : render::default_demo_scene_names())
    EXPECT_NE(render::taa_split_of(n), render::TaaSplit::None) << n;
  EXPECT_EQ(render::taa_split_of("thin"), render::TaaSplit::Tuning);
  EXPECT_EQ(render::taa_split_of("cut"), render::TaaSplit::Validation);
  EXPECT_EQ(render::taa_split_of("light"), render::TaaSplit::Tuning);
  EXPECT_EQ(render::taa_split_of("focus"), render::TaaSplit::Validation);
  EXPECT_EQ(render::taa_split_of("room"), render::TaaSplit::Tuning);
  EXPECT_EQ(render::taa_split_of("nope"), render::TaaSplit::None);
  EXPECT_EQ(names, (std::vector<std::string>{"thin", "motion", "orbit", "light", "sparkle", "moire",
                                             "blades", "cut", "penumbra", "focus", "bokeh", "room",
                                             "room_light"}));
  try {
    render::make_builtin_scene("nope");
    FAIL() << "expected SettingsError";
  } catch (const SettingsError& e) {
    for (const auto& n : names) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << n;
  }
}

// bench --filter: a substring of the pass name, or with a trailing '$' its end.
TEST(BenchFilter, SubstringOrAnchoredEnd) {
  using afterimage::bench_filter_matches;
  EXPECT_TRUE(bench_filter_matches("", "post.dof"));
  EXPECT_TRUE(bench_filter_matches("post.dof", "post.dof.half"));
  EXPECT_TRUE(bench_filter_matches("post.dof$", "post.dof"));
  EXPECT_FALSE(bench_filter_matches("post.dof$", "post.dof.half"));
  EXPECT_TRUE(bench_filter_matches("half$", "post.dof.half"));
  EXPECT_FALSE(bench_filter_matches("post.dof.half.x$", "half"));
  EXPECT_FALSE(bench_filter_matches("x", "post.dof"));
}

// The floor streams the planes a pass reports after prepare (a method's last_traffic), else its
// fixed read_planes / write_planes.
TEST(BenchFloor, StreamsThePlanesThePassReports) {
  afterimage::BenchPass p;
  p.name = "test.pass";
  p.read_planes = 2;
  p.write_planes = 1;
  int prepared = 0;
  p.prepare = [&](int, int) { ++prepared; };
  p.run = [](const afterimage::Exec&) {};
  afterimage::BenchSettings s;
  s.sizes = {{64, 8}};
  s.repeats = 1;
  auto rows = afterimage::run_bench({p}, s);
  ASSERT_FALSE(rows.empty());
  EXPECT_EQ(rows[0].read_planes, 2);
  EXPECT_EQ(rows[0].write_planes, 1);
  p.streamed_planes = [&] { return std::pair(prepared > 0 ? 9 : 0, 4); };
  rows = afterimage::run_bench({p}, s);
  ASSERT_FALSE(rows.empty());
  EXPECT_EQ(rows[0].read_planes, 9);  // asked after prepare
  EXPECT_EQ(rows[0].write_planes, 4);
  p.streamed_planes = [] { return std::pair(0, 0); };  // not reported: the fixed planes
  rows = afterimage::run_bench({p}, s);
  EXPECT_EQ(rows[0].read_planes, 2);
}

// bench's post.dof.focus and post.chain.focus time the passes on `focus` frame 1 at 1080p
// (bench_passes.cpp): that frame must carry the scene's lens and motion, or the rows would time a
// DoF that returns its input and a motion blur that exits early. At the rows' size: the camera
// drifts slowly, and at 96x54 motion blur leaves frame 1 unchanged.
TEST(BenchFocusRows, TheirFrameIsChangedByTheDofAndTheMotionBlur) {
  render::RenderSettings rs;
  rs.width = 1920;
  rs.height = 1080;
  const Frame f = render::render_gbuffer(render::make_builtin_scene("focus"), 1, rs, Exec{});
  const auto changed = [&](const ImageF& out) {
    float most = 0.0f;
    for (size_t i = 0; i < out.data().size(); ++i)
      most = std::max(most, std::abs(out.data()[i] - f.color.data()[i]));
    return most;
  };
  EXPECT_GT(changed(post::depth_of_field(f, f.color, post::DofSettings{}, Exec{})), 1e-3f);
  EXPECT_GT(changed(post::motion_blur(f, f.color, post::MotionBlurSettings{}, Exec{})), 1e-3f);
}
