// `afterimage run --pipeline` (issue 12): stages in the DESIGN.md order whatever the order
// given, settings per stage through the tables, the same output as resolve + tonemap applied by
// hand, and one-line errors for unknown stages and settings.
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>

#include "cli_util.h"
#include "core/sanitize.h"
#include "io/io.h"
#include "post/sharpen.h"
#include "post/tonemap.h"
#include "run/post_pipeline.h"
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
  EXPECT_EQ(parse_pipeline("sharpen,flare,tonemap", {}).post,
            (std::vector<std::string>{"flare", "tonemap", "sharpen"}));
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

// sharpen is the chain's last stage, after the tonemap; listed, it is seed 000 Eq.5's filter
// (strength 1), `sharpen.sharpen` sets it, 0 turns it off, out of range is refused.
TEST(PostPipeline, SharpenRunsLastOnTheTonemappedImage) {
  Frame f = Frame::allocate(23, 9);
  f.color = test::random_image(23, 9, 3, 11, 0.0f, 8.0f);
  const ImageF tonemapped = post::tonemap(f.color, {});
  const auto run = [&](std::vector<std::string> sets) {
    return make_pipeline_method(parse_pipeline("sharpen,tonemap", sets), {})->process(f).color;
  };
  const ImageF sharpened = run({});
  EXPECT_EQ(sharpened, post::sharpen(tonemapped, {1.0f}));
  EXPECT_NE(sharpened, tonemapped);
  EXPECT_NE(sharpened, post::tonemap(post::sharpen(f.color, {1.0f}), {}));  // not before it
  EXPECT_EQ(run({"sharpen.sharpen=0.5"}), post::sharpen(tonemapped, {0.5f}));
  EXPECT_EQ(run({"sharpen.sharpen=0"}), tonemapped);
  EXPECT_THROW(run({"sharpen.sharpen=9"}), SettingsError);
  EXPECT_THROW(run({"sharpen.radius=1"}), SettingsError);
}

// Without a temporal method the chain repairs non-finite color itself, as the reader's warning
// says ("replaced by the neighbourhood mean before use"): before, a post-only run wrote the
// NaN and Inf pixels through (a dof or bloom copies or keeps them).
TEST(PostPipeline, PostOnlyChainRepairsNonFiniteColorFirst) {
  Frame f = Frame::allocate(40, 24);
  f.color = test::random_image(40, 24, 3, 5, 0.0f, 4.0f);
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 40; ++x) f.depth.at(x, y, 0) = 2.0f + 0.1f * float(x % 7);
  f.lens.f_number = 2.0;
  f.lens.focus_distance = 2.3;
  f.color.at(3, 4, 0) = std::numeric_limits<float>::quiet_NaN();
  f.color.at(20, 10, 1) = std::numeric_limits<float>::infinity();
  f.color.at(33, 20, 2) = -std::numeric_limits<float>::infinity();
  f.color.at(8, 8, 0) = -0.5f;
  Frame clean = f;
  ImageF invalid;
  ASSERT_TRUE(sanitize_color(f.color, clean.color, invalid, {}));
  for (const char* p : {"dof", "bloom", "dof,bloom,flare"}) {
    const ImageF out = make_pipeline_method(parse_pipeline(p, {}), {})->process(f).color;
    for (float v : out.data()) ASSERT_TRUE(std::isfinite(v)) << p;
    EXPECT_EQ(out, make_pipeline_method(parse_pipeline(p, {}), {})->process(clean).color) << p;
  }
}

// After a temporal upscaler the stages that read depth or motion take them at the color's
// size: nearest input pixel, motion in output pixels (before: 'taau,dof' was refused, "frame
// 0 is 80x45, its color 160x90x3").
TEST(PostPipeline, UpscaledChainReadsTheGBufferAtItsSize) {
  Frame f = Frame::allocate(3, 2);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) {
      f.depth.at(x, y, 0) = float(10 * y + x + 1);
      f.motion.at(x, y, 0) = float(x);
      f.motion.at(x, y, 1) = float(-y);
    }
  f.jitter = {0.25, -0.5};
  const Frame g = gbuffer_at_size(f, 6, 4);
  EXPECT_EQ(g.width, 6);
  EXPECT_EQ(g.height, 4);
  EXPECT_EQ(g.jitter.x, 0.5);
  EXPECT_EQ(g.jitter.y, -1.0);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 6; ++x) {
      EXPECT_EQ(g.depth.at(x, y, 0), f.depth.at(x / 2, y / 2, 0)) << x << " " << y;
      EXPECT_EQ(g.motion.at(x, y, 0), 2.0f * f.motion.at(x / 2, y / 2, 0));
      EXPECT_EQ(g.motion.at(x, y, 1), 2.0f * f.motion.at(x / 2, y / 2, 1));
    }
  // A non-integer ratio: the input pixel under each output pixel's centre.
  const Frame h = gbuffer_at_size(f, 4, 2);
  EXPECT_EQ(h.depth.at(1, 0, 0), f.depth.at(1, 0, 0));  // centre 1.5 * 3 / 4 = 1.125
  EXPECT_EQ(h.depth.at(3, 1, 0), f.depth.at(2, 1, 0));

  const fs::path dir = test::fresh_temp_dir("run_cli_taau_post");
  const std::string in = (dir / "in").string();
  ASSERT_EQ(
      test::run("render --scene focus --frames 2 --size 64x36 --render-scale 2 --out " + in).code,
      0);
  for (const auto& [out, p] :
       {std::pair("taau", "taau"), std::pair("post", "taau,dof,motion_blur")}) {
    const auto r =
        test::run("run --in " + in + " --out " + (dir / out).string() + " --pipeline " + p);
    ASSERT_EQ(r.code, 0) << r.err;
  }
  const Frame a = io::read_frame(io::frame_path((dir / "taau").string(), 1));
  const Frame b = io::read_frame(io::frame_path((dir / "post").string(), 1));
  EXPECT_EQ(b.width, 64);
  EXPECT_NE(a.color, b.color);
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
  // With a sharpen stage the 8-bit file holds what an EXR run holds, quantised: the sharpen
  // works on the sRGB-encoded values either way (run/post_pipeline.h display_transform).
  const std::string sharp = " --pipeline taa,tonemap,sharpen --set sharpen.sharpen=2";
  r = test::run("run --in " + in + " --out " + (dir / "sharp-exr").string() + sharp);
  ASSERT_EQ(r.code, 0) << r.err;
  r = test::run("run --in " + in + " --out " + (dir / "sharp-png").string() + sharp +
                " --out-format png");
  ASSERT_EQ(r.code, 0) << r.err;
  for (int k = 0; k < 3; ++k) {
    const ImageF exr = io::read_frame(io::frame_path((dir / "sharp-exr").string(), k)).color;
    const std::string png = (dir / "sharp-png" / fmt::format("frame.{:04d}.png", k)).string();
    const ImageF encoded = io::read_rgb(png, false);
    const ImageF plain =
        io::read_rgb((dir / "png" / fmt::format("frame.{:04d}.png", k)).string(), false);
    ASSERT_TRUE(encoded.same_shape(exr));
    EXPECT_NE(encoded, plain) << k;  // the sharpen shows in the file
    for (size_t i = 0; i < exr.data().size(); ++i)
      ASSERT_NEAR(encoded.data()[i], std::clamp(exr.data()[i], 0.0f, 1.0f), 0.5f / 255 + 1e-6f)
          << k << " " << i;
  }
  // An explicit tonemap.srgb=false stands in an 8-bit file (it was overridden before 4ef3035):
  // the file holds the EXR run's linear display values, quantised, with or without a sharpen.
  for (const std::string stages : {"taa,tonemap", "taa,tonemap,sharpen"}) {
    const std::string lin = " --pipeline " + stages + " --set tonemap.srgb=false";
    r = test::run("run --in " + in + " --out " + (dir / "lin-exr").string() + lin);
    ASSERT_EQ(r.code, 0) << r.err;
    r = test::run("run --in " + in + " --out " + (dir / "lin-png").string() + lin +
                  " --out-format png");
    ASSERT_EQ(r.code, 0) << r.err;
    double mean = 0.0, encoded_mean = 0.0;
    for (int k = 0; k < 3; ++k) {
      const ImageF exr = io::read_frame(io::frame_path((dir / "lin-exr").string(), k)).color;
      const std::string name = fmt::format("frame.{:04d}.png", k);
      const ImageF png = io::read_rgb((dir / "lin-png" / name).string(), false);
      const ImageF encoded = io::read_rgb((dir / "png" / name).string(), false);
      ASSERT_TRUE(png.same_shape(exr));
      ASSERT_TRUE(encoded.same_shape(exr));
      for (size_t i = 0; i < exr.data().size(); ++i) {
        ASSERT_NEAR(png.data()[i], std::clamp(exr.data()[i], 0.0f, 1.0f), 0.5f / 255 + 1e-6f)
            << stages << " " << k << " " << i;
        mean += png.data()[i];
        encoded_mean += encoded.data()[i];
      }
    }
    // The default run's file (sRGB-encoded, `png` above) is brighter: the encoding was left out.
    EXPECT_LT(mean, 0.9 * encoded_mean) << stages;
    fs::remove_all(dir / "lin-exr");
    fs::remove_all(dir / "lin-png");
  }

  const std::string base = "run --in " + in + " --out " + (dir / "bad").string();
  test::expect_one_line_error(test::run(base + " --pipeline taa,glow"), "glow");
  test::expect_one_line_error(test::run(base + " --pipeline taa --set tonemap.exposure=2"),
                              "tonemap");
  // The message names the stage the user set (the sharpen table was called "post" before).
  test::expect_one_line_error(
      test::run(base + " --pipeline tonemap,sharpen --set sharpen.sharpen=100"),
      "sharpen setting sharpen: 100 is out of range");
  test::expect_one_line_error(test::run(base + " --pipeline tonemap --set tonemap.exposure=-1"),
                              "exposure");
  EXPECT_FALSE(fs::exists(dir / "bad"));
}

// --list-settings needs no --pipeline (it had refused to run without one): it lists every
// stage, each under a header naming it, with the run's values and defaults; a --set shows.
TEST(RunCli, ListSettingsShowsEveryStageWithValuesAndDefaults) {
  auto r = test::run("run --list-settings");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out.find("each stage's settings (change one with --set STAGE.KEY=VALUE):\n"), 0u)
      << r.out;
  for (const std::string head : {"svgf:afterimage:", "taa:afterimage:"})
    EXPECT_NE(r.out.find("\n" + head + "\n"), std::string::npos) << head << " in:\n" << r.out;
  for (const auto& stage : post_stages())
    EXPECT_NE(r.out.find(fmt::format("\n{}:\n", stage.name)), std::string::npos)
        << stage.name << " in:\n"
        << r.out;
  // The sharpen stage's own default (1, seed 000 Eq.5 as written), not its struct's 0.
  EXPECT_NE(r.out.find("\nsharpen:\n  sharpen                    = 1  "
                       "            default 1,"),
            std::string::npos)
      << r.out;
  r = test::run("run --pipeline tonemap,taa --set tonemap.exposure=2 --list-settings");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out.find("\ndof:\n"), std::string::npos) << r.out;  // only the pipeline's stages
  EXPECT_LT(r.out.find("\ntaa:afterimage:\n"), r.out.find("\ntonemap:\n"));  // chain order
  EXPECT_NE(r.out.find("  exposure                   = 2              default 1,"),
            std::string::npos)
      << r.out;
  // Without --list-settings the pipeline is still required.
  test::expect_one_line_error(test::run("run --in a --out b"), "--pipeline: no stage given");
}

// Our pinhole renders keep an f-number of 0 in their files: dof leaves them unchanged, as the
// physics says, and the run says so once (it had said nothing). A frame whose lens is unknown
// keeps it unknown through a write and a read, so a run's output is refused as its input was;
// so does a frame whose camera is unknown.
TEST(RunCli, DofOnAPinholeSaysItChangesNothing) {
  const fs::path dir = test::fresh_temp_dir("run_cli_pinhole");
  const std::string in = (dir / "in").string();
  ASSERT_EQ(test::run("render --scene motion --frames 3 --size 32x18 --out " + in).code, 0);
  const test::CliRun r =
      test::run("run --in " + in + " --out " + (dir / "dof").string() + " --pipeline dof");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string note = "dof: frame 0's lens is a pinhole (f-number 0, in focus at every depth)";
  const size_t at = r.err.find(note);
  ASSERT_NE(at, std::string::npos) << r.err;
  EXPECT_EQ(r.err.find(note, at + 1), std::string::npos) << r.err;  // once a run
  EXPECT_NE(r.err.find(io::frame_path(in, 0) + ": " + note), std::string::npos) << r.err;
  for (int k = 0; k < 3; ++k) {
    const Frame a = io::read_frame(io::frame_path(in, k));
    EXPECT_TRUE(a.lens_known);
    EXPECT_EQ(io::read_frame(io::frame_path((dir / "dof").string(), k)).color, a.color) << k;
  }
  // An unknown lens stays unknown: the writer leaves the lens out, the reader finds none.
  Frame f = io::read_frame(io::frame_path(in, 1));
  f.lens_known = false;
  const std::string unknown = (dir / "unknown").string();
  fs::create_directories(unknown);
  io::write_frame(io::frame_path(unknown, 1), f);
  EXPECT_FALSE(io::read_frame(io::frame_path(unknown, 1)).lens_known);
  EXPECT_TRUE(io::read_frame(io::frame_path(unknown, 1)).camera_known);
  f.camera_known = false;  // the same for the camera
  io::write_frame(io::frame_path(unknown, 1), f);
  EXPECT_FALSE(io::read_frame(io::frame_path(unknown, 1)).camera_known);
  test::expect_one_line_error(
      test::run("run --in " + unknown + " --out " + (dir / "out").string() + " --pipeline dof"),
      "dof: frame 1 carries no lens");
  EXPECT_FALSE(fs::exists(dir / "out"));
}

// An OpenEXR data window inside the display window (a compositor's bounding box, another in each
// frame) is read into the display window, the pixels outside it empty (color 0, depth the
// background, motion 0). Before, the data window was taken for the whole frame: a smaller box in
// one frame was refused as a change of size, and equal boxes were written back at the origin,
// moved and without the frame's size. Overscan and a display window off the origin are refused
// before anything is written; `info` shows the data window.
TEST(RunCli, DataWindowsAreReadIntoTheirDisplayWindow) {
  const fs::path dir = test::fresh_temp_dir("run_cli_windows");
  const std::string in = (dir / "in").string(), boxed = (dir / "boxed").string();
  ASSERT_EQ(test::run("render --scene motion --frames 3 --size 32x18 --out " + in).code, 0);
  fs::create_directories(boxed);
  // `from` with its data window cut to `box` and `change` applied to its spec, each channel
  // in its own type (an ImageBuf would hold the uint id as a normalised float).
  const auto rewrite = [](const std::string& from, const std::string& to, OIIO::ROI box,
                          const std::function<void(OIIO::ImageSpec&)>& change) {
    auto in = OIIO::ImageInput::open(from);
    ASSERT_TRUE(in);
    const OIIO::ImageSpec spec = in->spec();
    const size_t pb = spec.pixel_bytes(true);
    std::vector<unsigned char> px(pb * size_t(spec.width) * size_t(spec.height)), cut;
    ASSERT_TRUE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UNKNOWN, px.data()));
    OIIO::ImageSpec out = spec;
    out.x = box.xbegin;
    out.y = box.ybegin;
    out.width = box.width();
    out.height = box.height();
    change(out);
    for (int y = box.ybegin; y < box.yend; ++y)
      cut.insert(cut.end(), px.begin() + ptrdiff_t((size_t(y) * spec.width + box.xbegin) * pb),
                 px.begin() + ptrdiff_t((size_t(y) * spec.width + box.xend) * pb));
    auto o = OIIO::ImageOutput::create(to);
    ASSERT_TRUE(o && o->open(to, out));
    ASSERT_TRUE(o->write_image(OIIO::TypeDesc::UNKNOWN, cut.data()));
    ASSERT_TRUE(o->close());
  };
  const OIIO::ROI boxes[3] = {OIIO::ROI(4, 20, 2, 12), OIIO::ROI(0, 32, 3, 18),
                              OIIO::ROI(0, 32, 0, 18)};
  for (int k = 0; k < 3; ++k)
    rewrite(io::frame_path(in, k), io::frame_path(boxed, k), boxes[k], [](OIIO::ImageSpec&) {});
  const Frame whole = io::read_frame(io::frame_path(in, 0));
  const Frame f = io::read_frame(io::frame_path(boxed, 0));
  ASSERT_EQ(f.width, 32);
  ASSERT_EQ(f.height, 18);
  for (int y = 0; y < 18; ++y)
    for (int x = 0; x < 32; ++x) {
      const bool inside = x >= 4 && x < 20 && y >= 2 && y < 12;
      EXPECT_EQ(f.color.at(x, y, 1), inside ? whole.color.at(x, y, 1) : 0.0f) << x << "," << y;
      EXPECT_EQ(f.depth.at(x, y, 0), inside ? whole.depth.at(x, y, 0) : kBackgroundDepth);
      EXPECT_EQ(f.motion.at(x, y, 0), inside ? whole.motion.at(x, y, 0) : 0.0f);
      EXPECT_EQ(f.id.at(x, y, 0), inside ? whole.id.at(x, y, 0) : 0u);
    }
  EXPECT_NE(test::run("info " + io::frame_path(boxed, 0)).out.find("data window: 16x10 at (4, 2)"),
            std::string::npos);
  const test::CliRun r = test::run("run --in " + boxed + " --out " + (dir / "out").string() +
                                   " --pipeline taa,dof,tonemap --set dof.f_number=2");
  ASSERT_EQ(r.code, 0) << r.err;
  for (int k = 0; k < 3; ++k) {
    const Frame o = io::read_frame(io::frame_path((dir / "out").string(), k));
    EXPECT_EQ(o.width, 32);
    EXPECT_EQ(o.height, 18);
  }

  // Overscan (a data window beyond the display window) and a display window off the origin.
  const std::string over = (dir / "over").string(), moved = (dir / "moved").string();
  fs::create_directories(over);
  fs::create_directories(moved);
  for (int k = 0; k < 2; ++k) {
    const OIIO::ROI all(0, 32, 0, 18);
    rewrite(io::frame_path(in, k), io::frame_path(over, k), all, [&](OIIO::ImageSpec& s) {
      if (k == 1) s.full_width = 30;
    });
    rewrite(io::frame_path(in, k), io::frame_path(moved, k), all, [&](OIIO::ImageSpec& s) {
      if (k == 1) s.full_x = 2;
    });
  }
  test::expect_one_line_error(
      test::run("run --in " + over + " --out " + (dir / "o1").string() + " --pipeline taa"),
      io::frame_path(over, 1) +
          ": data window 32x18 at (0, 0) reaches outside the 30x18 display window (overscan)");
  EXPECT_FALSE(fs::exists(dir / "o1"));
  test::expect_one_line_error(
      test::run("run --in " + moved + " --out " + (dir / "o2").string() + " --pipeline taa"),
      io::frame_path(moved, 1) + ": display window 32x18 at (2, 0), not at (0, 0)");
  EXPECT_FALSE(fs::exists(dir / "o2"));
}

// A multi-part OpenEXR file (one part a pass, as compositors and engines write them) is read over
// all its parts: the same bits as the single-part file, a channel found by its name or by
// "<part>.<name>"; a name in two parts is refused where it is used, naming both, and parts of
// different windows are refused. Before, only the first part was read (its missing channels an
// error that `info`, which listed only that part, could not explain).
TEST(RunCli, MultiPartFilesAreReadOverAllTheirParts) {
  const fs::path dir = test::fresh_temp_dir("run_cli_parts");
  const std::string in = (dir / "in").string(), parts = (dir / "parts").string();
  ASSERT_EQ(test::run("render --scene motion --frames 3 --size 32x18 --out " + in).code, 0);
  fs::create_directories(parts);
  // Splits a file's channels into parts (names given per part, all of them once), each in its
  // own type; the first part keeps the header's attributes. `change` edits the specs.
  const auto split = [](const std::string& from, const std::string& to,
                        const std::vector<std::pair<std::string, std::vector<std::string>>>& by,
                        const std::function<void(std::vector<OIIO::ImageSpec>&)>& change) {
    auto input = OIIO::ImageInput::open(from);
    ASSERT_TRUE(input);
    const OIIO::ImageSpec spec = input->spec();
    std::vector<OIIO::ImageSpec> specs;
    std::vector<std::vector<unsigned char>> pixels;
    for (const auto& [name, channels] : by) {
      OIIO::ImageSpec ps = spec;
      ps.nchannels = int(channels.size());
      ps.channelnames.clear();
      ps.channelformats.clear();
      std::vector<unsigned char> px;
      for (const std::string& ch : channels) {
        const int c = spec.channelindex(ch);
        ASSERT_GE(c, 0) << ch;
        ps.channelnames.push_back(ch);
        ps.channelformats.push_back(spec.channelformat(c));
        std::vector<unsigned char> one(spec.channelformat(c).size() * size_t(spec.width) *
                                       size_t(spec.height));
        ASSERT_TRUE(input->read_image(0, 0, c, c + 1, OIIO::TypeDesc::UNKNOWN, one.data()));
        px.insert(px.end(), one.begin(), one.end());
      }
      if (!specs.empty()) ps.extra_attribs.clear();  // the header's attributes: the first part
      ps.attribute("name", name);
      specs.push_back(ps);
      pixels.push_back(std::move(px));
    }
    change(specs);
    auto out = OIIO::ImageOutput::create(to);
    ASSERT_TRUE(out && out->open(to, int(specs.size()), specs.data())) << OIIO::geterror();
    for (size_t p = 0; p < specs.size(); ++p) {
      if (p > 0) {
        ASSERT_TRUE(out->open(to, specs[p], OIIO::ImageOutput::AppendSubimage));
      }
      // Planar (one channel after another) to interleaved, as write_image takes them.
      const OIIO::ImageSpec& ps = specs[p];
      const size_t n = size_t(ps.width) * size_t(ps.height), stride = ps.pixel_bytes(true);
      std::vector<unsigned char> inter(stride * n);
      size_t plane = 0, offset = 0;
      for (int c = 0; c < ps.nchannels; ++c) {
        const size_t bytes = ps.channelformat(c).size();
        for (size_t i = 0; i < n; ++i)
          std::memcpy(&inter[i * stride + offset], &pixels[p][plane + i * bytes], bytes);
        plane += bytes * n;
        offset += bytes;
      }
      ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UNKNOWN, inter.data())) << out->geterror();
    }
    ASSERT_TRUE(out->close());
  };
  const std::vector<std::string> gbuffer = {
      "Z", "N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B", "motion.X", "motion.Y", "id"};
  const auto none = [](std::vector<OIIO::ImageSpec>&) {};
  for (int k = 0; k < 3; ++k)
    split(io::frame_path(in, k), io::frame_path(parts, k),
          {{"beauty", {"R", "G", "B"}}, {"gbuffer", gbuffer}}, none);
  const Frame whole = io::read_frame(io::frame_path(in, 1)),
              split_frame = io::read_frame(io::frame_path(parts, 1));
  EXPECT_EQ(split_frame.color, whole.color);
  EXPECT_EQ(split_frame.depth, whole.depth);
  EXPECT_EQ(split_frame.normal, whole.normal);
  EXPECT_EQ(split_frame.albedo, whole.albedo);
  EXPECT_EQ(split_frame.motion, whole.motion);
  EXPECT_EQ(split_frame.id, whole.id);
  EXPECT_EQ(split_frame.view, whole.view);
  const test::CliRun info = test::run("info " + io::frame_path(parts, 1));
  EXPECT_NE(info.out.find("parts: 2"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("part 2 ('gbuffer'), channels (10): Z(float)"), std::string::npos)
      << info.out;
  const std::string pipeline = " --pipeline taa,dof,motion_blur,tonemap --set dof.f_number=2";
  ASSERT_EQ(test::run("run --in " + in + " --out " + (dir / "a").string() + pipeline).code, 0);
  const test::CliRun r =
      test::run("run --in " + parts + " --out " + (dir / "b").string() + pipeline);
  ASSERT_EQ(r.code, 0) << r.err;
  for (int k = 0; k < 3; ++k)
    EXPECT_EQ(io::read_frame(io::frame_path((dir / "b").string(), k)).color,
              io::read_frame(io::frame_path((dir / "a").string(), k)).color)
        << k;

  // One name in two parts: refused where used, reachable by its part's name.
  const std::string twice = (dir / "twice").string();
  fs::create_directories(twice);
  for (int k = 0; k < 2; ++k)
    split(io::frame_path(in, k), io::frame_path(twice, k),
          {{"beauty", {"R", "G", "B"}}, {"depth", {"Z"}}},
          [](std::vector<OIIO::ImageSpec>& s) { s[1].channelnames = {"R"}; });
  test::expect_one_line_error(
      test::run("run --in " + twice + " --out " + (dir / "c").string() +
                " --layout afterimage --pipeline tonemap"),
      "frame.0000.exr: channel R (color) is in the parts 'beauty' and 'depth': name the one "
      "meant, beauty.R or depth.R, in a --map");
  EXPECT_FALSE(fs::exists(dir / "c"));
  const test::CliRun named =
      test::run("run --in " + twice + " --out " + (dir / "d").string() +
                " --layout afterimage --map color=beauty.R,beauty.G,beauty.B --map depth=depth.R "
                "--pipeline dof --set dof.f_number=2");
  ASSERT_EQ(named.code, 0) << named.err;
  // Parts of different data windows (OpenEXR gives every part one display window).
  const std::string windows = (dir / "windows").string();
  fs::create_directories(windows);
  split(io::frame_path(in, 0), io::frame_path(windows, 0),
        {{"beauty", {"R", "G", "B"}}, {"gbuffer", gbuffer}}, none);
  split(io::frame_path(in, 1), io::frame_path(windows, 1),
        {{"beauty", {"R", "G", "B"}}, {"gbuffer", gbuffer}},
        [](std::vector<OIIO::ImageSpec>& s) { s[1].width = 16; });
  test::expect_one_line_error(
      test::run("run --in " + windows + " --out " + (dir / "f").string() + " --pipeline tonemap"),
      io::frame_path(windows, 1) +
          ": part 2 ('gbuffer') has its data window 16x18 at (0, 0) in a 32x18 display window, "
          "the first part 32x18 at (0, 0) in 32x18: a frame's parts must share their windows");
}

// A grey render (one channel Y) matches no layout: the error names the file and its channels
// and says how to name the color (it had said "( Y)" and named no file); with --map color=Y,Y,Y
// the automatic layout takes our names for the rest and reads it.
TEST(RunCli, UnknownChannelsAreReadOnceTheColorIsMapped) {
  const auto dir = test::fresh_temp_dir("run_grey");
  fs::create_directories(dir / "in");
  for (int n = 1; n <= 2; ++n) {
    OIIO::ImageSpec spec(6, 4, 1, OIIO::TypeDesc::FLOAT);
    spec.channelnames = {"Y"};
    std::vector<float> px(24);
    for (size_t i = 0; i < px.size(); ++i) px[i] = 0.05f * float(i + size_t(n));
    const std::string path = (dir / "in" / fmt::format("grey.{:04d}.exr", n)).string();
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out && out->open(path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, px.data()));
    out->close();
  }
  const std::string in = (dir / "in").string();
  const test::CliRun bare =
      test::run("run --in " + in + " --out " + (dir / "a").string() + " --pipeline tonemap");
  EXPECT_EQ(bare.code, 1);
  EXPECT_NE(bare.err.find("error: " + (dir / "in" / "grey.0001.exr").string() +
                          ": cannot recognise the layout from the channels (Y); name the "
                          "color's with --map color=R,G,B (a grey Y: color=Y,Y,Y)"),
            std::string::npos)
      << bare.err;
  EXPECT_FALSE(fs::exists(dir / "a"));
  const test::CliRun mapped = test::run("run --in " + in + " --out " + (dir / "b").string() +
                                        " --pipeline tonemap --map color=Y,Y,Y");
  ASSERT_EQ(mapped.code, 0) << mapped.err;
  EXPECT_NE(mapped.err.find("layout afterimage with --map"), std::string::npos) << mapped.err;
  const Frame f = io::read_frame((dir / "b" / "grey.0002.exr").string());
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 6; ++x) {
      EXPECT_EQ(f.color.at(x, y, 0), f.color.at(x, y, 1));
      EXPECT_EQ(f.color.at(x, y, 0), f.color.at(x, y, 2));
    }
  test::remove_if_passed(dir);
}

}  // namespace
}  // namespace afterimage
