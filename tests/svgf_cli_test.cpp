// SVGF through the registry, the pipeline (`run --pipeline svgf,taa`: two temporal stages,
// denoiser first) and the `afterimage denoise` command on a small noisy sequence written here.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "cli_util.h"
#include "io/io.h"
#include "run/methods.h"
#include "run/post_pipeline.h"
#include "run/sequence.h"
#include "svgf/denoiser.h"
#include "svgf/settings.h"
#include "taa/presets.h"
#include "taa/taa_method.h"
#include "test_util.h"

namespace afterimage {
namespace {

namespace fs = std::filesystem;

// Two fronto-parallel planes (depth 3 left, 9 right) with albedo texture, a slow pan of one
// pixel per frame, the noise-free color and its noisy 1-spp-like version.
Frame noisy_frame(int w, int h, int t, bool noisy) {
  Frame f = Frame::allocate(w, h);
  f.index = t;
  std::mt19937 rng(500 + unsigned(t));
  std::exponential_distribution<float> e(1.0f);  // mean 1, heavy right tail like 1 spp
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int u = x + t;  // scene coordinate: the camera pans right by 1 px per frame
      const bool left = u < w / 2 + 4;
      const float light = left ? 1.0f : 3.0f;
      for (int c = 0; c < 3; ++c) {
        const float a = 0.3f + 0.5f * float((u / 4 + y / 4 + c) % 2);
        f.albedo.at(x, y, c) = a;
        f.color.at(x, y, c) = a * light * (noisy ? e(rng) : 1.0f);
      }
      f.depth.at(x, y, 0) = left ? 3.0f : 9.0f;
      f.normal.at(x, y, 2) = 1.0f;
      f.id.at(x, y, 0) = left ? 1 : 2;
      f.motion.at(x, y, 0) = t > 0 ? 1.0f : 0.0f;  // p_prev = p_curr + 1
    }
  return f;
}

double rmse(const ImageF& a, const ImageF& b) {
  double e = 0;
  for (size_t i = 0; i < a.data().size(); ++i)
    e += (double(a.data()[i]) - b.data()[i]) * (double(a.data()[i]) - b.data()[i]);
  return std::sqrt(e / double(a.data().size()));
}

TEST(SvgfPipeline, RegistryAndTwoTemporalStages) {
  EXPECT_EQ(method_variants("svgf"), svgf::preset_names());
  EXPECT_EQ(default_variant("svgf"), "afterimage");
  EXPECT_EQ(make_method("svgf:svgf-paper")->name(), "svgf:svgf-paper");
  EXPECT_THROW(make_method("svgf:nope"), SettingsError);
  EXPECT_THROW(make_method("svgf:afterimage+sigma_l=-1"), SettingsError);
  EXPECT_EQ(method_command("svgf:svgf-paper+sigma_l=8"),
            "afterimage denoise --preset svgf-paper --set sigma_l=8");
  EXPECT_EQ(svgf::make_preset("svgf-paper"), svgf::SvgfSettings{});
  EXPECT_TRUE(settings::all_members_registered<svgf::SvgfSettings>());

  const PipelineSpec p = parse_pipeline("tonemap,taa:hdrp,svgf", {"svgf.sigma_l=8"});
  EXPECT_EQ(p.denoise, "svgf:afterimage");
  EXPECT_EQ(p.temporal, "taa:hdrp");
  EXPECT_EQ(parse_pipeline("svgf", {}).temporal, "");
  EXPECT_THROW(parse_pipeline("svgf,svgf:svgf-paper", {}), SettingsError);
  EXPECT_THROW(parse_pipeline("taa,taau", {}), SettingsError);
  EXPECT_THROW(make_pipeline_method(parse_pipeline("svgf,taa", {"svgf.sigma_n=0"}), {}),
               SettingsError);

  // svgf,taa is SVGF's output resolved by TAA with the input's G-buffer, bit for bit.
  auto chain = make_pipeline_method(parse_pipeline("taa:hdrp,svgf:svgf-paper", {}), {});
  svgf::SvgfDenoiser den(svgf::make_preset("svgf-paper"));
  taa::TaaMethod taa("taa:hdrp", taa::make_preset("hdrp"));
  for (int t = 0; t < 4; ++t) {
    const Frame f = noisy_frame(40, 24, t, true);
    Frame mid = f;
    mid.color = den.process(f).color;
    EXPECT_EQ(chain->process(f).color, taa.process(mid).color) << t;
  }
}

TEST(SvgfCli, DenoiseAndRunOnASequenceWrittenHere) {
  const fs::path dir = test::fresh_temp_dir("svgf_cli");
  const test::RemoveIfPassed cleanup{dir};
  const int w = 48, h = 28, frames = 8;
  for (int t = 0; t < frames; ++t) {
    io::write_frame(io::frame_path((dir / "in").string(), t), noisy_frame(w, h, t, true));
  }
  auto r = test::run("denoise --in " + (dir / "in").string() + " --out " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("denoised 8 frames"), std::string::npos) << r.out;
  // The last frame: much closer to the noise-free image than the input (exponential noise
  // has a standard deviation equal to the signal).
  const Frame out = io::read_frame(io::frame_path((dir / "out").string(), frames - 1));
  const Frame in = io::read_frame(io::frame_path((dir / "in").string(), frames - 1));
  const ImageF clean = noisy_frame(w, h, frames - 1, false).color;
  EXPECT_LT(rmse(out.color, clean), 0.5 * rmse(in.color, clean));

  r = test::run("denoise --in " + (dir / "in").string() + " --out " + (dir / "paper").string() +
                " --preset svgf-paper --set sigma_l=8 --save-state " + (dir / "s.state").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "s.state"));
  r = test::run("run --in " + (dir / "in").string() + " --out " + (dir / "run").string() +
                " --pipeline svgf,taa,tonemap");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(io::frame_path((dir / "run").string(), frames - 1)));

  // The default is SVGF then the taa default, frame for frame what `run --pipeline svgf,taa`
  // writes; --taa off is SVGF alone.
  r = test::run("run --in " + (dir / "in").string() + " --out " + (dir / "chain").string() +
                " --pipeline svgf,taa");
  ASSERT_EQ(r.code, 0) << r.err;
  r = test::run("denoise --in " + (dir / "in").string() + " --out " + (dir / "alone").string() +
                " --taa off");
  ASSERT_EQ(r.code, 0) << r.err;
  auto alone_ref = make_method("svgf:" + default_variant("svgf"), {});
  for (int t = 0; t < frames; ++t) {
    const Frame f = io::read_frame(io::frame_path((dir / "in").string(), t));
    const ImageF expect_alone = alone_ref->process(f).color;
    EXPECT_EQ(io::read_frame(io::frame_path((dir / "alone").string(), t)).color, expect_alone) << t;
    EXPECT_EQ(io::read_frame(io::frame_path((dir / "out").string(), t)).color,
              io::read_frame(io::frame_path((dir / "chain").string(), t)).color)
        << t;
  }
  EXPECT_NE(io::read_frame(io::frame_path((dir / "out").string(), frames - 1)).color,
            io::read_frame(io::frame_path((dir / "alone").string(), frames - 1)).color);

  const std::string base =
      "denoise --in " + (dir / "in").string() + " --out " + (dir / "bad").string();
  test::expect_one_line_error(test::run(base + " --taa nope"), "nope");
  test::expect_one_line_error(test::run(base + " --preset nope"), "nope");
  test::expect_one_line_error(test::run(base + " --set sigma_q=1"), "sigma_q");
  test::expect_one_line_error(test::run(base + " --set split=diffuse_specular"), "diffuse");
  EXPECT_FALSE(fs::exists(dir / "bad" / "frame.0001.exr"));
}

}  // namespace
}  // namespace afterimage
