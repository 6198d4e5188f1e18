// Layouts as data: the Blender layout's table, JSON layouts, --map overrides, automatic
// recognition, and frame-file listing of other tools' names.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "io/io.h"
#include "io/layouts.h"
#include "test_util.h"

using namespace afterimage;
namespace fs = std::filesystem;

TEST(Layouts, BlenderMapsPassesAndFoldsTheVectorSigns) {
  const Layout l = blender_layout("Layer2");
  const ChannelSource* c = l.find(Channel::color);
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->planes[2].file_name, "Layer2.Combined.B");
  EXPECT_EQ(l.find(Channel::depth)->planes[0].file_name, "Layer2.Depth.Z");
  EXPECT_EQ(l.find(Channel::id)->planes[0].file_name, "Layer2.IndexOB.X");
  // Vector.XY = previous - current, +y up -> ours (x, -y); ZW = current - next -> (-z, w).
  const ChannelSource* m = l.find(Channel::motion);
  EXPECT_EQ(m->planes[1].file_name, "Layer2.Vector.Y");
  EXPECT_EQ(m->planes[0].scale, 1.0);
  EXPECT_EQ(m->planes[1].scale, -1.0);
  const ChannelSource* n = l.find(Channel::motion_next);
  EXPECT_EQ(n->planes[0].file_name, "Layer2.Vector.Z");
  EXPECT_EQ(n->planes[0].scale, -1.0);
  EXPECT_EQ(n->planes[1].scale, 1.0);
  EXPECT_TRUE(n->convention.empty());  // pixel conventions are folded into the planes
  const ChannelSource* d = l.find(Channel::diffuse);
  EXPECT_EQ(d->planes[0].file_name, "Layer2.DiffDir.R");
  EXPECT_EQ(d->planes[0].plus_name, "Layer2.DiffInd.R");
  EXPECT_FALSE(l.camera_in_header());
  EXPECT_TRUE(afterimage_layout().camera_in_header());
}

TEST(Layouts, ConventionsOnlyWhereTheyMeanSomething) {
  Layout l = blender_layout();
  EXPECT_THROW(l.set_convention(Channel::color, "unity"), SettingsError);
  EXPECT_THROW(l.set_convention(Channel::motion, "nope"), SettingsError);
  l.set_convention(Channel::motion, "unity");  // UV: needs the size, kept as a name
  EXPECT_EQ(l.find(Channel::motion)->convention, "unity");
  l.set_convention(Channel::depth, "hardware-reversed:0.1:100");
  EXPECT_EQ(l.find(Channel::depth)->convention, "hardware-reversed:0.1:100");
  // Integer ids cannot be summed or scaled.
  EXPECT_THROW(l.map(Channel::id, {"a"}, {PlaneSource{"", 1.0, 0.0, "b"}}), SettingsError);
}

TEST(Layouts, MapOverridesAndJson) {
  Layout l = afterimage_layout();
  io::apply_map(l, "motion=vel.x,vel.y:unity");
  EXPECT_EQ(l.find(Channel::motion)->planes[0].file_name, "vel.x");
  EXPECT_EQ(l.find(Channel::motion)->convention, "unity");
  io::apply_map(l, "diffuse=a.R+b.R,a.G+b.G,a.B+b.B");
  EXPECT_EQ(l.find(Channel::diffuse)->planes[1].plus_name, "b.G");
  EXPECT_THROW(io::apply_map(l, "color=R,G"), SettingsError);  // 3 planes needed
  // Fuzz finding F5: an empty channel name skipped a plane and the loader read past its plan.
  EXPECT_THROW(io::apply_map(l, "color=,G,B"), SettingsError);
  EXPECT_THROW(io::apply_map(l, "color=+R,G,B"), SettingsError);
  EXPECT_THROW(io::apply_map(l, "colour=R,G,B"), SettingsError);
  EXPECT_THROW(io::apply_map(l, "R,G,B"), SettingsError);

  const Layout j = io::layout_from_json_text(R"({"name": "tool", "channels": {
      "color": ["C.r", "C.g", "C.b"],
      "depth": {"names": ["D"], "convention": "ray"},
      "motion": {"names": ["M.x", "M.y"], "scale": [2, 2], "offset": [0, 1]}}})",
                                             "test.json");
  EXPECT_EQ(j.name(), "tool");
  EXPECT_EQ(j.find(Channel::color)->planes[1].file_name, "C.g");
  EXPECT_EQ(j.find(Channel::depth)->convention, "ray");
  EXPECT_EQ(j.find(Channel::motion)->planes[1].offset, 1.0);
  EXPECT_EQ(j.find(Channel::normal), nullptr);
  EXPECT_THROW(io::layout_from_json_text("{", "bad.json"), SettingsError);
  EXPECT_THROW(io::layout_from_json_text(R"({"channels": {"nope": ["x"]}})", "bad.json"),
               SettingsError);
}

TEST(Layouts, DetectFromChannelNames) {
  std::string why;
  EXPECT_EQ(io::detect_layout({"B", "G", "R", "Z"}, &why).name(), "afterimage");
  EXPECT_EQ(io::detect_layout({"Foo.Depth.Z", "Foo.Combined.R", "Bar.Combined.R"}, &why).name(),
            "blender:Foo");
  EXPECT_EQ(why, "Foo.Combined.R");
  EXPECT_THROW(io::detect_layout({"Y", "A"}), InputError);
}

TEST(Layouts, ListFramesAcceptsDotAndUnderscore) {
  const fs::path d = test::fresh_temp_dir("layout_list");
  for (const char* n : {"quad_0012.exr", "quad_0003.exr", "quad_0100.exr", "other.0001.exr",
                        "notes.txt", "quad_x.exr"})
    std::ofstream(d / n) << "x";
  const auto q = io::scan_sequence(d.string(), "quad");
  ASSERT_EQ(q.size(), 3u);
  EXPECT_EQ(q[0].number, 3);
  EXPECT_EQ(q[2].number, 100);
  EXPECT_EQ(fs::path(q[1].path).filename(), "quad_0012.exr");
  EXPECT_EQ(io::scan_sequence(d.string(), "other").size(), 1u);
  EXPECT_THROW(io::scan_sequence(d.string()), InputError);  // two stems: ambiguous
  EXPECT_THROW(io::scan_sequence(d.string(), "none"), InputError);
  fs::remove(d / "other.0001.exr");
  EXPECT_EQ(io::scan_sequence(d.string()).size(), 3u);  // the only stem
}
