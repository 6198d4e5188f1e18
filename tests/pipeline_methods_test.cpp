// The method registry and run_sequence (run/methods.h, run/sequence.h): names,
// errors, and that running through them is exactly the technique run by hand.
#include <gtest/gtest.h>

#include <set>

#include "apps/demo/demo.h"
#include "core/error.h"
#include "post/sharpen.h"
#include "run/methods.h"
#include "run/sequence.h"
#include "taa/presets.h"
#include "taa/resolver.h"

using namespace afterimage;

namespace {

// A small moving G-buffer sequence: a bright square over a ramp, exact motion.
std::vector<Frame> moving_square(int frames, int w = 41, int h = 27) {
  std::vector<Frame> seq;
  for (int t = 0; t < frames; ++t) {
    Frame f = Frame::allocate(w, h);
    f.jitter = {0.25 * ((t % 3) - 1), -0.25 * ((t % 2) * 2 - 1)};
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const bool in = x >= 5 + 2 * t && x < 15 + 2 * t && y >= 8 && y < 18;
        for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = in ? 3.0f : 0.1f + 0.01f * (x + c);
        f.depth.at(x, y, 0) = in ? 2.0f : 10.0f;
        f.id.at(x, y, 0) = in ? 2 : 1;
        f.motion.at(x, y, 0) = in && t > 0 ? -2.0f : 0.0f;
      }
    seq.push_back(std::move(f));
  }
  return seq;
}

}  // namespace

TEST(Methods, NamesAreUniqueAndEveryOneBuilds) {
  const auto names = registered_method_names();
  EXPECT_EQ(std::set<std::string>(names.begin(), names.end()).size(), names.size());
  for (const auto& n : names) {
    auto m = make_method(n);
    EXPECT_EQ(m->name(), n);
    EXPECT_FALSE(m->required_channels().empty());
  }
  for (const auto& n : default_demo_methods())
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
  EXPECT_EQ(default_variant("taa"), "afterimage");
}

// Without --scenes the demo runs the registry's default demo scenes, not every scene.
TEST(Demo, DefaultSceneListIsTheRegistrysDemoSubset) {
  DemoSettings s;
  EXPECT_EQ(s.scene_list(),
            (std::vector<std::string>{"thin", "motion", "orbit", "light", "sparkle", "moire",
                                      "blades", "cut", "penumbra", "focus"}));
  s.scenes = {"cut", "light"};
  EXPECT_NO_THROW(s.validate());
  EXPECT_EQ(s.scene_list(), s.scenes);
}

TEST(Methods, SpecsParseAndLabel) {
  EXPECT_EQ(make_method("hdrp")->name(), "taa:hdrp");  // bare names are TAA presets
  EXPECT_EQ(method_label("taa:hdrp+alpha=0.2"), "TAA hdrp+alpha=0.2");
  EXPECT_EQ(method_command("taa:hdrp+alpha=0.2"),
            "afterimage resolve --preset hdrp --set alpha=0.2");
  const MethodSpec m = parse_method_spec("taa:ue4+alpha=0.1+history=bilinear");
  EXPECT_EQ(m.technique, "taa");
  EXPECT_EQ(m.variant, "ue4");
  EXPECT_EQ(m.overrides.size(), 2u);
  // A '+' inside a value (an exponent) stays in the value.
  const MethodSpec e = parse_method_spec("taa:hdrp+alpha=1e+0+history=bilinear");
  EXPECT_EQ(e.overrides, (std::vector<std::string>{"alpha=1e+0", "history=bilinear"}));
  EXPECT_NO_THROW(make_method("taa:hdrp+alpha=1e+0"));
}

TEST(Methods, BadSpecsAreSettingsErrors) {
  EXPECT_THROW(make_method("svgx:afterimage"), SettingsError);
  EXPECT_THROW(make_method("taa:nonesuch"), SettingsError);
  EXPECT_THROW(make_method("taa:hdrp+nonesuch=1"), SettingsError);
  EXPECT_THROW(make_method("taa:hdrp+alpha=7"), SettingsError);
  EXPECT_THROW(make_method("taa:hdrp+sharpen=9"), SettingsError);
  try {
    make_method("svgx:a");
    FAIL();
  } catch (const SettingsError& e) {
    EXPECT_NE(std::string(e.what()).find("taa"), std::string::npos) << e.what();  // lists valid
  }
}

TEST(Methods, RunSequenceEqualsTheResolverAndPostSharpenIsAppended) {
  const auto seq = moving_square(6);
  taa::TemporalResolver by_hand(taa::make_preset("ue4"));
  auto plain = make_method("taa:ue4");
  auto sharp = make_method("taa:ue4+sharpen=0.5");
  std::vector<ImageF> a, b;
  run_sequence(*plain, seq, [&](size_t, Frame&& f) { a.push_back(std::move(f.color)); });
  run_sequence(*sharp, seq, [&](size_t, Frame&& f) { b.push_back(std::move(f.color)); });
  ASSERT_EQ(a.size(), seq.size());
  for (size_t t = 0; t < seq.size(); ++t) {
    const ImageF expect = by_hand.process(seq[t]);
    EXPECT_EQ(a[t], expect) << t;
    // Sharpening sees the resolved frame and never feeds back into history.
    EXPECT_EQ(b[t], post::sharpen(expect, {0.5f})) << t;
    EXPECT_NE(b[t], a[t]) << t;
  }
}

TEST(Methods, OutputHasTheInputHeaderAndAdoptsItsGBuffer) {
  const auto seq = moving_square(2);
  auto m = make_method("taa:afterimage");
  m->process(seq[0]);
  Frame out = m->process(seq[1]);
  EXPECT_EQ(out.jitter, seq[1].jitter);
  EXPECT_EQ(out.width, seq[1].width);
  EXPECT_TRUE(out.has_color());
  EXPECT_FALSE(out.has_depth());  // only what the method produced
  EXPECT_NE(out.color, seq[1].color);
  const ImageF color = out.color;
  Frame in = seq[1];
  out.adopt_missing_channels(std::move(in));
  EXPECT_EQ(out.color, color);  // present channels are kept
  EXPECT_EQ(out.depth, seq[1].depth);
  EXPECT_EQ(out.motion, seq[1].motion);
  EXPECT_EQ(out.id, seq[1].id);
}
