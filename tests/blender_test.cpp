// The Blender test set (tests/data/blender, made by make_blender_set.py): the layout reads
// it in our conventions, checked against what the scene was built to do (a quad moving
// exactly +4 px right and 2 px down per frame; a camera whose matrices are in the sidecar),
// and TAA on the jittered sequence beats the raw frames against the Blender reference.
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "camera/camera.h"
#include "cli_util.h"
#include "eval/evaluate.h"
#include "io/io.h"
#include "io/sequence_input.h"
#include "run/alpha.h"
#include "run/methods.h"
#include "run/sequence.h"
#include "test_util.h"

using namespace afterimage;

namespace {

const std::string kDir = std::string(AFTERIMAGE_TESTDATA_DIR) + "/blender";

io::SequenceInput input(const std::string& seq) {
  io::SequenceInput in;
  in.dir = kDir + "/" + seq;
  return in;
}

const ChannelSet kAll{Channel::color,  Channel::depth,  Channel::normal,
                      Channel::albedo, Channel::motion, Channel::id};

// Cycles averages Vector and Normal over a pixel's samples (the pixel filter spans 1.5 px)
// while Depth and IndexOB keep one sample, so only pixels whose 5x5 neighbours share the id carry
// one object's motion unmixed (5x5: a 1.5 px filter footprint plus the id's own sample).
bool interior(const Frame& f, int x, int y) {
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx) {
      const int u = std::clamp(x + dx, 0, f.width - 1), v = std::clamp(y + dy, 0, f.height - 1);
      if (f.id.at(u, v, 0) != f.id.at(x, y, 0)) return false;
    }
  return true;
}

}  // namespace

TEST(Blender, QuadMotionDepthIdAndNamesInOurConventions) {
  std::vector<std::string> notes;
  const io::SequenceReader r(input("quad"), [&](const std::string& n) { notes.push_back(n); });
  ASSERT_EQ(r.size(), 6u);
  EXPECT_EQ(r.files()[0].number, 1);
  EXPECT_EQ(r.layout().name(), "blender:ViewLayer");
  for (size_t t = 0; t < r.size(); ++t) {
    const Frame f = r.read(t, kAll, "test");
    EXPECT_EQ(f.index, int(t) + 1);
    int quad = 0, interior_px = 0;
    for (int y = 0; y < f.height; ++y)
      for (int x = 0; x < f.width; ++x) {
        const uint32_t id = f.id.at(x, y, 0);
        // At edges the 4 samples mix quad and backdrop: k/4 of the quad's motion.
        const float k = -f.motion.at(x, y, 0) / 4.0f;
        EXPECT_NEAR(k * 4.0f, std::round(k * 4.0f), 1e-4);
        EXPECT_NEAR(f.motion.at(x, y, 1), -2.0f * k, 1e-4);
        if (id == 1 && interior(f, x, y)) {  // came from 4 px left, 2 up; goes 4 right, 2 down
          ++interior_px;
          EXPECT_NEAR(f.motion.at(x, y, 0), -4.0f, 1e-4);
          EXPECT_NEAR(f.motion.at(x, y, 1), -2.0f, 1e-4);
          EXPECT_NEAR(f.motion_next.at(x, y, 0), 4.0f, 1e-4);
          EXPECT_NEAR(f.motion_next.at(x, y, 1), 2.0f, 1e-4);
          // Normal is a sample mean in which some samples write nothing (measured: 0.75 or
          // 1.0 on the quad's interior with 4 samples): only its direction is reliable.
          EXPECT_GE(f.normal.at(x, y, 2), 0.5f);
          EXPECT_EQ(f.normal.at(x, y, 0), 0.0f);
        } else if (interior(f, x, y)) {
          EXPECT_NEAR(f.motion.at(x, y, 0), 0.0f, 1e-5);  // Cycles float noise ~1e-6
        }
        if (id == 1) {
          ++quad;
          EXPECT_EQ(f.depth.at(x, y, 0), 10.0f);  // planar distance to the camera
        } else if (id == 0) {
          EXPECT_EQ(f.depth.at(x, y, 0), kBackgroundDepth);
        } else {
          EXPECT_EQ(id, 2u);
          EXPECT_EQ(f.depth.at(x, y, 0), 11.0f);
        }
      }
    // 20 x 16 px, rendered without sub-pixel offset: exact coverage, one id per pixel.
    EXPECT_EQ(quad, 20 * 16) << "frame " << t;
    EXPECT_GE(interior_px, 16 * 12) << "frame " << t;
    // Where the quad is: frame 1 spans x in [0, 20), y in [6, 22); +4, +2 per frame.
    EXPECT_EQ(f.id.at(int(4 * t) + 1, int(2 * t) + 7, 0), 1u);
    EXPECT_EQ(f.id.at(int(4 * t) + 18, int(2 * t) + 20, 0), 1u);
  }
  // The camera is unknown and said once.
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_NE(notes[0].find("layout blender:ViewLayer"), std::string::npos);
  EXPECT_NE(notes[1].find("camera unknown"), std::string::npos);
}

TEST(Blender, DiffuseIsTheSumOfDirectAndIndirect) {
  const io::SequenceReader r(input("quad"));
  const Frame f = r.read(2, {Channel::color, Channel::diffuse}, "test");
  const ImageF raw = io::read_channels(r.files()[2].path);
  const auto names = io::channel_names(r.files()[2].path);
  auto plane = [&](const std::string& n) {
    for (size_t i = 0; i < names.size(); ++i)
      if (names[i] == n) return int(i);
    return -1;
  };
  const int dr = plane("ViewLayer.DiffDir.G"), ir = plane("ViewLayer.DiffInd.G");
  ASSERT_GE(dr, 0);
  ASSERT_GE(ir, 0);
  double total = 0;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const float want = raw.at(x, y, dr) + raw.at(x, y, ir);
      EXPECT_EQ(f.diffuse.at(x, y, 1), want);
      total += want;
    }
  EXPECT_GT(total, 1.0);
}

TEST(Blender, CameraSequenceMotionAgreesWithTheSidecarCamera) {
  io::SequenceInput in = input("camera");
  in.jitter_file = in.dir + "/jitter.json";
  const io::SequenceReader r(in);
  ASSERT_TRUE(r.camera_known());
  const auto cams = io::read_camera_sidecar(in.jitter_file);
  for (size_t t = 1; t < r.size(); ++t) {
    const Frame f = r.read(t, kAll, "test");
    const Mat4 prev_vp = cams[t - 1].projection * cams[t - 1].view;
    const Mat4 to_world = (f.projection * f.view).inverse();
    int surface = 0, sky = 0;
    for (int y = 0; y < f.height; y += 3)
      for (int x = 0; x < f.width; x += 3) {
        if (!interior(f, x, y)) continue;
        const Vec2d p{x + 0.5, y + 0.5};
        const Vec2d m{f.motion.at(x, y, 0), f.motion.at(x, y, 1)};
        const double d = f.depth.at(x, y, 0);
        // Truth: the surface point under the pixel centre, from depth and this camera,
        // projected with the previous camera. Sky: a point 1e7 away along the ray.
        const double z_view = d < kBackgroundDepth ? -d : -1e7;
        const Vec4d ndc0 =
            to_world * Vec4d(2.0 * p.x / f.width - 1, 1 - 2.0 * p.y / f.height, -1.0, 1.0);
        const Vec3d near_w{ndc0.x / ndc0.w, ndc0.y / ndc0.w, ndc0.z / ndc0.w};
        const Vec3d eye = f.view.inverse().transform_point({0, 0, 0});
        const Vec3d dir = near_w - eye;
        const double along = -f.view.transform_dir(dir).z;  // view depth per unit of dir
        const Vec3d world = eye + dir * (-z_view / along);
        const Vec2d q = project_to_pixel(prev_vp, world, f.width, f.height);
        const double tol = d < kBackgroundDepth ? 0.02 : 0.01;
        EXPECT_NEAR(m.x, q.x - p.x, tol) << x << "," << y << " frame " << t;
        EXPECT_NEAR(m.y, q.y - p.y, tol) << x << "," << y << " frame " << t;
        (d < kBackgroundDepth ? surface : sky)++;
      }
    EXPECT_GT(surface, 50);
    EXPECT_GT(sky, 5);  // the sky's motion comes from the camera (Blender writes zero)
  }
}

TEST(Blender, JitterFileMatchesHalton16) {
  io::SequenceInput a = input("jitter"), b = input("jitter");
  a.jitter_file = a.dir + "/jitter.json";
  b.jitter = "halton16";
  const io::SequenceReader ra(a), rb(b);
  for (size_t t = 0; t < ra.size(); ++t) {
    const Frame fa = ra.read(t, {Channel::color}, "test");
    const Frame fb = rb.read(t, {Channel::color}, "test");
    EXPECT_NEAR(fa.jitter.x, fb.jitter.x, 1e-12);
    EXPECT_NEAR(fa.jitter.y, fb.jitter.y, 1e-12);
  }
  EXPECT_NE(ra.read(1, {Channel::color}, "test").jitter, Vec2d(0, 0));
}

TEST(Blender, ResolvedJitterSequenceBeatsTheRawFramesAgainstTheReference) {
  const auto out = test::fresh_temp_dir("blender_resolve");
  io::SequenceInput in = input("jitter");
  in.layout = "blender";
  in.jitter_file = in.dir + "/jitter.json";
  auto method = make_method("taa:" + default_variant("taa"));
  SequenceFiles files;
  files.in = in;
  files.out_dir = out.string();
  const SequenceRunStats st = run_sequence(*method, files);
  EXPECT_EQ(st.frames, 12u);

  EvalOptions o;
  o.outputs = {out.string(), in.dir};  // resolved, raw (recognised as Blender)
  o.labels = {"resolved", "raw"};
  o.reference = in.dir + "/reference";
  o.metrics.warmup = 4;
  const EvalResult r = run_eval(o, {});
  ASSERT_EQ(r.methods.size(), 2u);
  const auto resolved = to_summary(r.methods[0]).aggregate,
             raw = to_summary(r.methods[1]).aggregate;
  EXPECT_GT(resolved.at("psnr"), raw.at("psnr") + 3.0);
  EXPECT_LT(resolved.at("flip"), raw.at("flip"));
}

// eval reads a Blender G-buffer with --jitter as resolve does, names the layout it chose, and
// refuses --jitter without --gbuffer instead of ignoring it. Blender's vectors hold no jitter,
// so the scores are the same with --jitter, with the sidecar and with neither.
TEST(Blender, EvalTakesJitterForTheGbufferLikeResolve) {
  const auto out = test::fresh_temp_dir("blender_eval_jitter");
  const std::string dir = kDir + "/jitter";
  auto eval = [&](const std::string& jitter) {
    static int n = 0;
    const std::string json = (out / ("e" + std::to_string(n++) + ".json")).string();
    const test::CliRun r =
        test::run("eval --out " + dir + " --ref " + dir + "/reference --gbuffer " + dir +
                  " --layout blender --warmup 2 " + jitter + " --json " + json);
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("(layout blender:ViewLayer)"), std::string::npos) << r.out;
    return nlohmann::json::parse(std::ifstream(json))["methods"][0]["summary"];
  };
  const auto a = eval("--jitter halton16"), b = eval("--jitter-file " + dir + "/jitter.json"),
             c = eval("");
  EXPECT_EQ(a.dump(), b.dump());
  EXPECT_EQ(a.dump(), c.dump());
  EXPECT_GT(a["ghosting"]["samples_by_age"][0].get<int>(), 0) << a.dump();
  const test::CliRun r =
      test::run("eval --out " + dir + " --ref " + dir + "/reference --jitter halton16");
  test::expect_one_line_error(r, "give --gbuffer");
}

// Blender's files carry no lens, and ThinLens's defaults are nobody's camera: `run --pipeline
// dof` refuses them before writing anything, naming the file and the settings that would give
// one (it had left the frames unchanged, as a pinhole, with no word). Artist ranges (no lens
// needed), the lens given by settings or a "lens" in the camera sidecar blur them; the sidecar's
// lens and the same lens by settings give the same bits.
TEST(Blender, DofTakesRangesOrALensGivenBySettingsOrTheSidecar) {
  const auto out = test::fresh_temp_dir("blender_dof");
  const auto run = [&](const std::string& in, const std::string& name, const std::string& sets) {
    const test::CliRun r =
        test::run("run --in " + in + " --out " + (out / name).string() + " --pipeline dof" + sets);
    EXPECT_EQ(r.code, 0) << r.err;
    return io::read_frame((out / name / "camera_0003.exr").string()).color;
  };
  const std::string camera = kDir + "/camera";
  // (--layout and --jitter-file given: no note names them, so the error is the only line.)
  const std::string none = "run --in " + camera + " --out " + (out / "none").string() +
                           " --layout blender --jitter-file " + camera + "/jitter.json";
  const test::CliRun r = test::run(none + " --pipeline dof");
  test::expect_one_line_error(
      r, camera +
             "/camera_0001.exr: dof: frame 1 carries no lens (not in the file, no \"lens\" "
             "in a camera sidecar): set dof.f_number, dof.focal_length, dof.focus_distance");
  EXPECT_FALSE(std::filesystem::exists(out / "none"));
  // Only the keys still missing are named.
  test::expect_one_line_error(
      test::run(none + " --pipeline dof --set dof.f_number=2 --set dof.focal_length=35"),
      "frame 1 carries no lens (not in the file, no \"lens\" in a camera sidecar): set "
      "dof.focus_distance (dof.sensor_width");
  const ImageF input =
      io::read_frame(camera + "/camera_0003.exr", {"color"}, nullptr, blender_layout()).color;
  const ImageF ranges = run(camera, "ranges",
                            " --set dof.coc=ranges --set dof.near_end=1 --set dof.far_start=5 "
                            "--set dof.far_end=8 --set dof.far_radius=4");
  const std::string lens_sets =
      " --set dof.f_number=2 --set dof.focal_length=35 --set dof.focus_distance=0.5";
  const ImageF lens = run(camera, "lens", lens_sets);
  EXPECT_NE(ranges, input);
  EXPECT_NE(lens, input);
  EXPECT_NE(lens, ranges);

  // The same lens from the sidecar beside the frames (sensor width and blades left to their
  // defaults, 36 mm and a disc, as the settings leave them; values a float holds exactly, as
  // the settings are floats).
  const auto dir = out / "with_lens";
  std::filesystem::create_directories(dir);
  for (const auto& e : std::filesystem::directory_iterator(camera))
    if (e.path().extension() == ".exr") std::filesystem::copy(e.path(), dir / e.path().filename());
  nlohmann::json sidecar;
  {
    std::ifstream f(camera + "/jitter.json");
    f >> sidecar;
  }
  for (auto& f : sidecar["frames"])
    f["lens"] = {{"f_number", 2}, {"focal_length_mm", 35}, {"focus_distance", 0.5}};
  std::ofstream(dir / "jitter.json") << sidecar.dump();
  EXPECT_EQ(run(dir.string(), "sidecar_lens", ""), lens);
  // A lens the sidecar gets wrong is named with its file and entry, before anything is written.
  sidecar["frames"][1]["lens"]["focus_distance"] = 0.01;
  std::ofstream(dir / "jitter.json") << sidecar.dump();
  test::expect_one_line_error(
      test::run("run --in " + dir.string() + " --out " + (out / "bad").string() +
                " --pipeline dof --layout blender --jitter-file " + (dir / "jitter.json").string()),
      (dir / "jitter.json").string() + ": frame entry 2: lens focus distance 0.01: must exceed");
  EXPECT_FALSE(std::filesystem::exists(out / "bad"));
}

// Motion blur's camera / object split needs the camera: on files that carry none (quad/, no
// sidecar) it had found no camera motion and blurred all of it as the objects', the settings
// silently doing nothing; it is now refused before anything is written. With the camera from
// the sidecar (camera/: it translates and yaws) leaving out the rotation changes the blur.
TEST(Blender, MotionBlurSplitNeedsTheCamera) {
  EXPECT_FALSE(io::SequenceReader(input("quad")).check(0, kAll, "test").camera_known);
  EXPECT_TRUE(io::SequenceReader(input("camera")).check(0, kAll, "test").camera_known);
  EXPECT_TRUE(io::SequenceReader(input("camera")).read(0, kAll, "test").camera_known);
  const auto out = test::fresh_temp_dir("blender_mb");
  const std::string quad = "run --in " + kDir + "/quad --layout blender --pipeline motion_blur";
  for (const std::string set :
       {"camera_rotation=false", "camera_max_radius=2", "object_max_radius=2"}) {
    test::expect_one_line_error(
        test::run(quad + " --out " + (out / "quad").string() + " --set motion_blur." + set),
        "quad_0001.exr: motion_blur: frame 1 carries no camera (not in the file, no view and "
        "projection in a camera sidecar)");
    EXPECT_FALSE(std::filesystem::exists(out / "quad")) << set;
  }
  EXPECT_EQ(test::run(quad + " --out " + (out / "quad").string()).code, 0);  // no split: fine
  const auto run = [&](const std::string& name, const std::string& sets) {
    const test::CliRun r = test::run("run --in " + kDir + "/camera --out " + (out / name).string() +
                                     " --pipeline motion_blur --set motion_blur.shutter=1" + sets);
    EXPECT_EQ(r.code, 0) << r.err;
    return io::read_frame((out / name / "camera_0004.exr").string()).color;
  };
  EXPECT_NE(run("all", ""), run("no_rotation", " --set motion_blur.camera_rotation=false"));
}

// A jitter.json beside foreign frames gives their camera and jitter without --jitter-file
// (Blender writes neither, and its Vector pass is zero on the background of a moving camera),
// said once; --jitter none ignores it; a bad one is an error naming it and the way out.
TEST(Blender, SidecarBesideTheFramesIsTakenByDefault) {
  std::vector<std::string> notes;
  const io::SequenceReader beside(input("camera"),
                                  [&](const std::string& n) { notes.push_back(n); });
  ASSERT_TRUE(beside.camera_known());
  EXPECT_EQ(std::count_if(notes.begin(), notes.end(),
                          [](const std::string& n) {
                            return n.find("camera and jitter from jitter.json") !=
                                   std::string::npos;
                          }),
            1);
  io::SequenceInput given = input("camera"), none = input("camera");
  given.jitter_file = given.dir + "/jitter.json";
  none.jitter = "none";
  const io::SequenceReader explicit_file(given), ignored(none);
  EXPECT_FALSE(ignored.camera_known());
  const Frame a = beside.read(2, kAll, "test"), b = explicit_file.read(2, kAll, "test"),
              c = ignored.read(2, kAll, "test");
  EXPECT_EQ(a.motion, b.motion);
  EXPECT_EQ(a.view, b.view);
  EXPECT_NE(a.motion, c.motion);  // the sky's motion comes from the sidecar's camera

  const auto dir = test::fresh_temp_dir("blender_sidecar_bad");
  for (const auto& e : std::filesystem::directory_iterator(kDir + "/camera"))
    if (e.path().extension() == ".exr") std::filesystem::copy(e.path(), dir / e.path().filename());
  std::ofstream(dir / "jitter.json") << "{\"frames\": [{\"frame\": 1}]}";
  const test::CliRun r =
      test::run("resolve --in " + dir.string() + " --out " + (dir / "out").string());
  // (after the note naming the layout it recognised)
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("error: " + (dir / "jitter.json").string() + ": bad camera sidecar"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("--jitter none ignores it)\n"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("camera and jitter from"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "out" / "camera_0001.exr"));
  const test::CliRun ok = test::run("resolve --in " + dir.string() + " --out " +
                                    (dir / "out").string() + " --jitter none");
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_NE(ok.err.find("camera unknown"), std::string::npos) << ok.err;
}

// Blender's Combined.A below 1 (Film > Transparent): the alpha is read beside the color and
// carried through the run (run/alpha.h) into the outputs' A, where it had been dropped
// (the outputs were the premultiplied color over black); an opaque render's A (quad/: 1
// everywhere) comes out exactly 1; 8-bit outputs, which have no alpha, say so once; a plain
// RGBA file's A is found beside its R the same way.
TEST(Blender, TransparentAlphaIsCarriedIntoTheOutputs) {
  namespace fs = std::filesystem;
  const auto dir = test::fresh_temp_dir("blender_alpha");
  fs::create_directories(dir / "in");
  for (const auto& e : fs::directory_iterator(kDir + "/quad"))
    if (e.path().extension() == ".exr") fs::copy(e.path(), dir / "in" / e.path().filename());
  // Frames 3 and 4: alpha 0.25 on a 5x2 block (frame 3) and one pixel (frame 4).
  for (const auto& [name, w] : {std::pair{"quad_0003.exr", 5}, std::pair{"quad_0004.exr", 1}}) {
    const std::string path = (dir / "in" / name).string();
    OIIO::ImageBuf b(path);
    ASSERT_TRUE(b.read(0, 0, true, OIIO::TypeDesc::FLOAT)) << b.geterror();
    const int a = b.spec().channelindex("ViewLayer.Combined.A");
    ASSERT_GE(a, 0);
    std::vector<float> px(size_t(b.nchannels()));
    for (int y = 10; y < 10 + (w > 1 ? 2 : 1); ++y)
      for (int x = 20; x < 20 + w; ++x) {
        b.getpixel(x, y, px.data());
        EXPECT_EQ(px[size_t(a)], 1.0f);
        px[size_t(a)] = 0.25f;
        b.setpixel(x, y, px.data());
      }
    ASSERT_TRUE(b.write(path + ".tmp.exr")) << b.geterror();
    fs::rename(path + ".tmp.exr", path);
  }
  const auto out_alpha = [&](const std::string& sub, int n) {
    const Frame f = io::read_frame((dir / sub / fmt::format("quad_{:04d}.exr", n)).string());
    EXPECT_TRUE(f.has(Channel::alpha)) << sub << " " << n;
    return f.alpha;
  };
  const auto in_alpha = [&](int n) {
    return io::read_frame((dir / "in" / fmt::format("quad_{:04d}.exr", n)).string(),
                          ChannelSet{Channel::color, Channel::alpha}, "test", nullptr,
                          blender_layout())
        .alpha;
  };
  // Per-pixel stages: the input's alpha, bit for bit.
  const test::CliRun tm = test::run("run --in " + (dir / "in").string() + " --out " +
                                    (dir / "tonemap").string() + " --pipeline tonemap");
  ASSERT_EQ(tm.code, 0) << tm.err;
  EXPECT_EQ(tm.err.find("no alpha"), std::string::npos) << tm.err;
  for (int n = 1; n <= 6; ++n) EXPECT_EQ(out_alpha("tonemap", n), in_alpha(n)) << n;
  // A temporal stage: opaque frames exactly 1, the block's frame below 1 around the block.
  const test::CliRun taa = test::run("run --in " + (dir / "in").string() + " --out " +
                                     (dir / "taa").string() + " --pipeline taa,motion_blur");
  ASSERT_EQ(taa.code, 0) << taa.err;
  for (int n : {1, 2}) EXPECT_TRUE(fully_opaque(out_alpha("taa", n))) << n;
  const ImageF a3 = out_alpha("taa", 3);
  float lo = 1, hi = 0;
  for (float v : a3.data()) lo = std::min(lo, v), hi = std::max(hi, v);
  EXPECT_LT(a3.at(22, 10, 0), 0.5f);
  EXPECT_GE(lo, 0.0f);
  EXPECT_LE(hi, 1.0f + 1e-6f);
  // 8-bit outputs: said once, naming the first transparent frame.
  const test::CliRun png =
      test::run("run --in " + (dir / "in").string() + " --out " + (dir / "png").string() +
                " --pipeline tonemap --out-format png");
  ASSERT_EQ(png.code, 0) << png.err;
  const std::string note =
      "quad_0003.exr: alpha below 1 (a transparent background): png images "
      "carry no alpha";
  EXPECT_NE(png.err.find(note), std::string::npos) << png.err;
  EXPECT_EQ(png.err.find("no alpha", png.err.find(note) + note.size()), std::string::npos)
      << png.err;
  // A frame without A after frames with it: its output has none, said once.
  fs::create_directories(dir / "partial");
  for (int n = 1; n <= 4; ++n)
    fs::copy(dir / "in" / fmt::format("quad_{:04d}.exr", n),
             dir / "partial" / fmt::format("quad_{:04d}.exr", n));
  {
    const std::string path = (dir / "partial" / "quad_0003.exr").string();
    OIIO::ImageBuf b(path);
    ASSERT_TRUE(b.read(0, 0, true, OIIO::TypeDesc::FLOAT)) << b.geterror();
    std::vector<int> keep;
    for (int c = 0; c < b.nchannels(); ++c)
      if (b.spec().channel_name(c) != "ViewLayer.Combined.A") keep.push_back(c);
    const OIIO::ImageBuf cut = OIIO::ImageBufAlgo::channels(b, int(keep.size()), keep);
    ASSERT_TRUE(cut.write(path + ".tmp.exr")) << cut.geterror();
    fs::rename(path + ".tmp.exr", path);
  }
  const test::CliRun partial = test::run("run --in " + (dir / "partial").string() + " --out " +
                                         (dir / "partial_out").string() + " --pipeline taa");
  ASSERT_EQ(partial.code, 0) << partial.err;
  const std::string gap_note = "quad_0003.exr: no alpha where earlier frames have one";
  EXPECT_NE(partial.err.find(gap_note), std::string::npos) << partial.err;
  EXPECT_EQ(partial.err.find("no alpha where", partial.err.find(gap_note) + gap_note.size()),
            std::string::npos)
      << partial.err;
  for (int n : {1, 2, 4}) out_alpha("partial_out", n);  // (expects A)
  EXPECT_FALSE(
      io::read_frame((dir / "partial_out" / "quad_0003.exr").string()).has(Channel::alpha));
  // An opaque render: A = 1 in every output, nothing said.
  const test::CliRun opaque = test::run("run --in " + kDir + "/quad --out " +
                                        (dir / "opaque").string() + " --pipeline taa,tonemap");
  ASSERT_EQ(opaque.code, 0) << opaque.err;
  EXPECT_EQ(opaque.err.find("no alpha"), std::string::npos) << opaque.err;
  for (int n = 1; n <= 6; ++n) EXPECT_TRUE(fully_opaque(out_alpha("opaque", n))) << n;

  // A plain single-layer file: R G B A.
  fs::create_directories(dir / "plain");
  for (int n = 1; n <= 2; ++n) {
    OIIO::ImageSpec spec(4, 3, 4, OIIO::TypeDesc::FLOAT);
    spec.channelnames = {"R", "G", "B", "A"};
    OIIO::ImageBuf b(spec);
    const float px[4] = {0.5f, 0.5f, 0.5f, n == 2 ? 0.5f : 1.0f};
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 4; ++x) b.setpixel(x, y, px);
    ASSERT_TRUE(b.write((dir / "plain" / fmt::format("p_{:04d}.exr", n)).string()));
  }
  io::SequenceInput plain;
  plain.dir = (dir / "plain").string();
  const io::SequenceReader reader(plain);
  for (size_t i = 0; i < 2; ++i) {
    const Frame f = reader.read(i, ChannelSet{Channel::color}, "test");
    ASSERT_TRUE(f.has(Channel::alpha));
    EXPECT_EQ(f.alpha.at(3, 2, 0), i == 0 ? 1.0f : 0.5f);
  }
  EXPECT_EQ(alpha_channel_beside("R"), "A");
  EXPECT_EQ(alpha_channel_beside("V.Combined.R"), "V.Combined.A");
  EXPECT_EQ(alpha_channel_beside("A"), "");
}
