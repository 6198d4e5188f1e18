#include <gtest/gtest.h>

#include <set>
#include <string>

#include "frame/frame.h"
#include "frame/layout.h"
#include "test_util.h"

using namespace afterimage;

TEST(FrameChannels, TableInvariants) {
  std::set<std::string> keys, exr;
  size_t n_exr = 0;
  for (size_t i = 0; i < kChannelTable.size(); ++i) {
    const ChannelInfo& r = kChannelTable[i];
    EXPECT_EQ(size_t(r.key), i) << r.name;  // channel_info(c) indexes by key
    EXPECT_TRUE(keys.insert(r.name).second) << "duplicate key " << r.name;
    int names = 0;
    for (const char* e : r.exr)
      if (e) {
        ++names;
        ++n_exr;
        EXPECT_TRUE(exr.insert(e).second) << "duplicate EXR name " << e;
      }
    EXPECT_EQ(r.planes, names) << r.name;
    EXPECT_NE(std::string(r.description), "") << r.name;
    EXPECT_EQ(&channel_info(r.key), &r);
  }
  EXPECT_EQ(exr.size(), n_exr);
}

TEST(FrameChannels, CoreRowsKeepTheFileOrderAndNames) {
  // Files written before the table existed list exactly these, in this order.
  const std::vector<std::pair<std::string, std::vector<std::string>>> legacy = {
      {"color", {"R", "G", "B"}},           {"depth", {"Z"}},
      {"normal", {"N.X", "N.Y", "N.Z"}},    {"albedo", {"albedo.R", "albedo.G", "albedo.B"}},
      {"motion", {"motion.X", "motion.Y"}}, {"id", {"id"}}};
  ASSERT_GE(kChannelTable.size(), legacy.size());
  for (size_t i = 0; i < legacy.size(); ++i) {
    const ChannelInfo& r = kChannelTable[i];
    EXPECT_EQ(r.name, legacy[i].first);
    EXPECT_TRUE(r.core) << r.name;
    ASSERT_EQ(size_t(r.planes), legacy[i].second.size()) << r.name;
    for (int p = 0; p < r.planes; ++p) EXPECT_EQ(r.exr[size_t(p)], legacy[i].second[size_t(p)]);
    EXPECT_EQ(r.type, r.key == Channel::id ? PixelType::U32 : PixelType::F32) << r.name;
  }
  for (size_t i = legacy.size(); i < kChannelTable.size(); ++i)
    EXPECT_FALSE(kChannelTable[i].core) << kChannelTable[i].name;
}

TEST(FrameChannels, FindByName) {
  ASSERT_NE(find_channel("motion_next"), nullptr);
  EXPECT_EQ(find_channel("motion_next")->key, Channel::motion_next);
  EXPECT_EQ(find_channel("depth")->key, Channel::depth);
  EXPECT_EQ(find_channel("R"), nullptr);  // EXR names are not keys
  EXPECT_EQ(find_channel("nope"), nullptr);
}

TEST(FrameChannels, AllocateCoreOnlyByDefault) {
  Frame f = Frame::allocate(7, 5);
  for (const ChannelInfo& r : kChannelTable) EXPECT_EQ(f.has(r.key), r.core) << r.name;
  EXPECT_TRUE(f.emission.empty());
  EXPECT_EQ(f.depth.at(6, 4, 0), kBackgroundDepth);
  EXPECT_EQ(f.color.at(6, 4, 2), 0.0f);
  EXPECT_EQ(f.id.at(3, 2, 0), 0u);
  EXPECT_EQ(f.motion.channels(), 2);

  Frame g = Frame::allocate(7, 5, {Channel::color, Channel::motion_next, Channel::variance});
  EXPECT_TRUE(g.has(Channel::color));
  EXPECT_TRUE(g.has(Channel::motion_next));
  EXPECT_TRUE(g.has(Channel::variance));
  EXPECT_FALSE(g.has(Channel::depth));
  EXPECT_FALSE(g.has(Channel::id));
  EXPECT_EQ(g.motion_next.channels(), 2);
  EXPECT_EQ(g.variance.width(), 7);
  EXPECT_EQ(g.variance.height(), 5);
}

TEST(FrameChannels, GenericAccessReachesTheNamedMember) {
  Frame f = Frame::allocate(3, 2, test::every_channel());
  // Spelled out on purpose: a mix-up in the generated switch would show here.
  EXPECT_EQ(f.plane_set(Channel::color), &f.color);
  EXPECT_EQ(f.plane_set(Channel::depth), &f.depth);
  EXPECT_EQ(f.plane_set(Channel::normal), &f.normal);
  EXPECT_EQ(f.plane_set(Channel::albedo), &f.albedo);
  EXPECT_EQ(f.plane_set(Channel::motion), &f.motion);
  EXPECT_EQ(f.plane_set(Channel::id), nullptr);
  EXPECT_EQ(f.plane_set_u32(Channel::id), &f.id);
  EXPECT_EQ(f.plane_set_u32(Channel::color), nullptr);
  EXPECT_EQ(f.plane_set(Channel::emission), &f.emission);
  EXPECT_EQ(f.plane_set(Channel::diffuse), &f.diffuse);
  EXPECT_EQ(f.plane_set(Channel::specular), &f.specular);
  EXPECT_EQ(f.plane_set(Channel::variance), &f.variance);
  EXPECT_EQ(f.plane_set(Channel::depth_gradient), &f.depth_gradient);
  EXPECT_EQ(f.plane_set(Channel::roughness), &f.roughness);
  EXPECT_EQ(f.plane_set(Channel::motion_next), &f.motion_next);
  const Frame& cf = f;
  EXPECT_EQ(cf.plane_set(Channel::motion_next), &f.motion_next);
  EXPECT_EQ(cf.plane_set_u32(Channel::id), &f.id);
  for (const ChannelInfo& r : kChannelTable) {
    EXPECT_TRUE(f.has(r.key)) << r.name;
    int planes = 0;
    f.visit(r.key, [&](auto& img) { planes = img.channels(); });
    EXPECT_EQ(planes, r.planes) << r.name;
  }
  EXPECT_TRUE(f.has_color() && f.has_depth() && f.has_normal() && f.has_albedo() &&
              f.has_motion() && f.has_id());
}

TEST(FrameChannels, ValidateRejectsAnyChannelWithTheWrongShape) {
  const Frame good = Frame::allocate(6, 4, test::every_channel());
  EXPECT_NO_THROW(validate_frame(good, "good"));
  for (const ChannelInfo& r : kChannelTable) {
    for (int variant = 0; variant < 2; ++variant) {
      Frame f = good;
      // Wrong width, or one plane too many.
      f.visit(r.key, [&](auto& img) {
        using Img = std::remove_reference_t<decltype(img)>;
        img = variant == 0 ? Img(7, 4, r.planes) : Img(6, 4, r.planes + 1);
      });
      try {
        validate_frame(f, "frame.0003.exr");
        ADD_FAILURE() << r.name << " variant " << variant << " accepted";
      } catch (const InputError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("frame.0003.exr"), std::string::npos) << m;
        EXPECT_NE(m.find(r.name), std::string::npos) << m;
      }
    }
    // Absent is fine for every channel but color.
    Frame f = good;
    f.visit(r.key, [](auto& img) { img = {}; });
    if (r.key == Channel::color)
      EXPECT_THROW(validate_frame(f, "x"), InputError);
    else
      EXPECT_NO_THROW(validate_frame(f, "x")) << r.name;
  }
  Frame j = good;
  j.jitter = {0.6, 0.0};
  EXPECT_THROW(validate_frame(j, "x"), InputError);
}

TEST(FrameChannels, ChannelSet) {
  ChannelSet s{Channel::depth, Channel::motion_next};
  EXPECT_TRUE(s.contains(Channel::depth));
  EXPECT_TRUE(s.contains(Channel::motion_next));
  EXPECT_FALSE(s.contains(Channel::color));
  EXPECT_FALSE(s.empty());
  EXPECT_TRUE(ChannelSet{}.empty());
  EXPECT_EQ(core_channels(), (ChannelSet{Channel::color, Channel::depth, Channel::normal,
                                         Channel::albedo, Channel::motion, Channel::id}));
}

TEST(FrameLayout, DefaultLayoutIsTheTableWithoutConversion) {
  const Layout& l = afterimage_layout();
  EXPECT_EQ(l.name(), "afterimage");
  ASSERT_EQ(l.sources().size(), kChannelTable.size());
  for (const ChannelInfo& r : kChannelTable) {
    const ChannelSource* s = l.find(r.key);
    ASSERT_NE(s, nullptr) << r.name;
    ASSERT_EQ(s->planes.size(), size_t(r.planes));
    for (int p = 0; p < r.planes; ++p) {
      EXPECT_EQ(s->planes[size_t(p)].file_name, r.exr[size_t(p)]);
      EXPECT_TRUE(s->planes[size_t(p)].identity());
    }
  }
}

TEST(FrameLayout, MapChecksCountsAndKeepsTableOrder) {
  Layout l("tool");
  l.map(Channel::motion, {"V.X", "V.Y"}, {{"", 1.0, 0.0, ""}, {"", -1.0, 0.0, ""}});
  l.map(Channel::color, {"C.R", "C.G", "C.B"});
  // Color brings the coverage alpha beside its R (run/alpha.h), last in table order.
  ASSERT_EQ(l.sources().size(), 3u);
  EXPECT_EQ(l.sources()[0].key, Channel::color);
  EXPECT_EQ(l.sources()[1].key, Channel::motion);
  EXPECT_EQ(l.sources()[2].key, Channel::alpha);
  EXPECT_EQ(l.find(Channel::alpha)->planes[0].file_name, "C.A");
  l.map(Channel::color, {"D.R", "D.G", "D.B"});  // follows the color while not given
  EXPECT_EQ(l.find(Channel::alpha)->planes[0].file_name, "D.A");
  l.map(Channel::alpha, {"mask.Y"});  // given: stays
  l.map(Channel::color, {"C.R", "C.G", "C.B"});
  EXPECT_EQ(l.find(Channel::alpha)->planes[0].file_name, "mask.Y");
  Layout bare("bare");
  bare.unmap(Channel::alpha).map(Channel::color, {"R", "G", "B"});  // unmapped: stays so
  EXPECT_EQ(bare.find(Channel::alpha), nullptr);
  l.unmap(Channel::alpha);
  EXPECT_EQ(l.find(Channel::motion)->planes[1].file_name, "V.Y");
  EXPECT_EQ(l.find(Channel::motion)->planes[1].scale, -1.0);
  EXPECT_EQ(l.find(Channel::depth), nullptr);
  // Remapping replaces; unmap drops.
  l.map(Channel::color, {"R", "G", "B"});
  EXPECT_EQ(l.sources().size(), 2u);
  EXPECT_EQ(l.find(Channel::color)->planes[0].file_name, "R");
  l.unmap(Channel::color);
  EXPECT_EQ(l.find(Channel::color), nullptr);

  EXPECT_THROW(l.map(Channel::motion, {"V.X"}), SettingsError);
  EXPECT_THROW(l.map(Channel::color, {"R", "G", "B"}, {{}}), SettingsError);
  EXPECT_THROW(l.map(Channel::id, {"obj"}, {{"", 2.0, 0.0, ""}}), SettingsError);
  EXPECT_NO_THROW(l.map(Channel::id, {"obj"}));
}
