#include "apps/bench/bench_passes.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <tuple>

#include <fmt/format.h>

#include "camera/camera.h"
#include "frame/frame.h"
#include "io/io.h"
#include "metrics/flip.h"
#include "metrics/ssim.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"
#include "run/methods.h"
#include "run/post_pipeline.h"
#include "run/sequence.h"
#include "svgf/denoiser.h"
#include "svgf/filter.h"
#include "svgf/gradient.h"
#include "svgf/settings.h"

namespace afterimage {

Frame synthetic_frame(int w, int h, int index) {
  Frame f = Frame::allocate(w, h);
  const JitterSequence jit;
  f.jitter = jit.at(index);
  f.index = index;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float u = (x + 0.5f) / w, v = (y + 0.5f) / h;
      const float stripes = 0.5f + 0.5f * std::sin(0.9f * (x + index * 0.7f) + 0.3f * y);
      f.color.at(x, y, 0) = 0.2f + 2.0f * u * stripes;
      f.color.at(x, y, 1) = 0.1f + v * stripes;
      f.color.at(x, y, 2) = 0.5f * (1.0f - u) + 0.2f * stripes;
      f.depth.at(x, y, 0) = 2.0f + 10.0f * v + ((x / 64 + y / 64) % 2);
      f.id.at(x, y, 0) = uint32_t(1 + (x / 64 + y / 64) % 5);
      // Pan of 0.7 px/frame plus a slow rotation about the center.
      f.motion.at(x, y, 0) = -0.7f + 0.002f * (y - 0.5f * h);
      f.motion.at(x, y, 1) = -0.002f * (x - 0.5f * w);
      f.normal.at(x, y, 2) = 1.0f;
      f.albedo.at(x, y, 0) = f.albedo.at(x, y, 1) = f.albedo.at(x, y, 2) = 0.5f;
    }
  return f;
}

// The post stages' frame: synthetic_frame with every effect active, as in a shot that uses
// them (a pinhole frame would time dof as a copy, sub-pixel motion motion_blur's early exit):
// a 50 mm f/2 lens focused at 6 m (depths 2..13 m: CoC diameters up to ~20 px at 1080p),
// a 4 px/frame camera pan plus a disc in the middle moving 24 px/frame (blur radius up to the
// clamp), and a few small very bright lights (bloom, flare).
Frame synthetic_post_frame(int w, int h, int index) {
  Frame f = synthetic_frame(w, h, index);
  f.lens.f_number = 2.0;
  f.lens.focus_distance = 6.0;
  const double cx = 0.5 * w, cy = 0.5 * h, r = 0.2 * h;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool disc = (x + 0.5 - cx) * (x + 0.5 - cx) + (y + 0.5 - cy) * (y + 0.5 - cy) < r * r;
      f.motion.at(x, y, 0) = disc ? -24.0f : -4.0f;
      f.motion.at(x, y, 1) = disc ? 6.0f : 0.0f;
      if (disc) f.depth.at(x, y, 0) = 3.0f;
    }
  for (int k = 0; k < 4; ++k) {
    const int lx = (k + 1) * w / 5, ly = h / 4 + (k % 2) * h / 2;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        for (int c = 0; c < 3; ++c) f.color.at(lx + dx, ly + dy, c) = 500.0f;
  }
  return f;
}

namespace {

// A kernel pass: timed against the bandwidth floor at every size and thread count.
BenchPass kernel_pass(std::string name, int read_planes, int write_planes,
                      std::function<void(int, int)> prepare, std::function<void(const Exec&)> run) {
  BenchPass p;
  p.name = std::move(name);
  p.read_planes = read_planes;
  p.write_planes = write_planes;
  p.prepare = std::move(prepare);
  p.run = std::move(run);
  return p;
}

// The I/O floor's method: reads what `like` reads and returns the color unchanged, so a
// files-to-files run with it reads and writes exactly what the real one does.
class PassThrough final : public SequenceMethod {
 public:
  explicit PassThrough(const SequenceMethod& like)
      : required_(like.required_channels()), used_(like.used_channels()) {}
  std::string name() const override { return "io-floor"; }
  ChannelSet required_channels() const override { return required_; }
  ChannelSet used_channels() const override { return used_; }
  Frame process(const Frame& f) override {
    Frame out = f.header_only();
    out.color = f.color;
    return out;
  }
  void reset() override {}
  void save_state(const std::string&) const override {}
  void load_state(const std::string&) override {}
  std::string settings_json() const override { return "{}"; }
  std::string describe_settings() const override { return ""; }
  void set_exec(const Exec&) override {}

 private:
  ChannelSet required_, used_;
};

// End to end (DESIGN.md §5), files to files beside the I/O floor (the same run with
// PassThrough): `name` runs the method make_method() returns over 8 frames of `scene` that the
// renderer wrote (the default formats). e2e.resolve.files: `resolve` (the default TAA) on
// `motion`; e2e.run.post.files: `run --pipeline dof,motion_blur,bloom,flare,tonemap` on
// `focus` (a lens, so the DoF blurs).
BenchPass end_to_end_pass(std::string name, std::string scene_name,
                          std::function<std::unique_ptr<SequenceMethod>(const Exec&)> make_method) {
  struct State {
    std::filesystem::path dir;
    int frames = 8;
    ~State() {
      std::error_code ec;
      if (!dir.empty()) std::filesystem::remove_all(dir, ec);
    }
  };
  auto st = std::make_shared<State>();
  auto files = [st](const char* out) {
    SequenceFiles f;
    f.in.dir = (st->dir / "in").string();
    f.out_dir = (st->dir / out).string();
    return f;
  };
  BenchPass p;
  p.name = std::move(name);
  p.sizes = {{1920, 1080}};
  p.all_threads_only = true;
  p.frames_per_run = st->frames;
  p.prepare = [st, scene_name](int w, int h) {
    std::random_device rd;
    st->dir = std::filesystem::temp_directory_path() /
              fmt::format("afterimage-bench-{}-{:08x}", getpid(), rd());
    const render::Scene scene = render::make_builtin_scene(scene_name);
    render::RenderSettings rs;
    rs.width = w;
    rs.height = h;
    render::render_sequence(scene, st->frames, {{"gbuffer", 0}}, rs, Exec{},
                            [&](int k, size_t, Frame&& f) {
                              io::write_frame(io::frame_path((st->dir / "in").string(), k), f);
                            });
  };
  p.run = [files, make_method](const Exec& ex) {
    const std::unique_ptr<SequenceMethod> method = make_method(ex);
    run_sequence(*method, files("out"));
  };
  p.floor_run = [files, make_method](const Exec& ex) {
    PassThrough method(*make_method(ex));
    run_sequence(method, files("floor"));
  };
  return p;
}

// A path-traced-like frame for the SVGF stages: synthetic_frame's surfaces with 1-spp-like
// noise on the color (an exponential-ish multiplicative sample from a per-pixel hash, pure in
// (pixel, index), with rare fireflies), tilted normals, and a background region (normal 0, the
// background depth) in the top-left corner, so every edge-stopping case is exercised.
Frame noisy_svgf_frame(int w, int h, int index) {
  Frame f = synthetic_frame(w, h, index);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      uint32_t v =
          uint32_t(x) * 0x9E3779B1u ^ uint32_t(y) * 0x85EBCA77u ^ uint32_t(index) * 0xC2B2AE3Du;
      v ^= v >> 15;
      v *= 0x2C1B3C6Du;
      v ^= v >> 12;
      const float u = (float(v >> 8) + 0.5f) * (1.0f / 16777216.0f);
      const float sample = (v & 1023u) == 0 ? 40.0f : -std::log(u);  // mean ~1
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) *= sample;
      const float tilt = 0.3f * std::sin(0.05f * float(x / 64 * 64 + y / 64 * 64));
      f.normal.at(x, y, 0) = tilt;
      f.normal.at(x, y, 2) = std::sqrt(1.0f - tilt * tilt);
      if (x < w / 4 && y < h / 4) {
        f.depth.at(x, y, 0) = kBackgroundDepth;
        for (int c = 0; c < 3; ++c) f.normal.at(x, y, c) = 0.0f;
      }
    }
  return f;
}

// SVGF's stages (issue 11, speed), the paper preset (5 à-trous iterations), on noisy_svgf_frame
// in steady state. accumulate is timed by the denoiser's own stage clock; variance and à-trous
// call filter.h directly on the denoiser's moments, color history and variance.
void add_svgf_stage_passes(std::vector<BenchPass>& passes) {
  struct State {
    Frame frames[2];
    std::unique_ptr<svgf::SvgfDenoiser> den;
    int next = 0;
    svgf::SvgfSettings s = svgf::preset_svgf_paper();
    ImageF gradient, temporal_length, spatial_length, variance, color_out[2], var_out[2];
  };
  auto st = std::make_shared<State>();
  const auto prepare = [st](int w, int h) {
    st->frames[0] = noisy_svgf_frame(w, h, 0);
    st->frames[1] = noisy_svgf_frame(w, h, 1);
    st->den = std::make_unique<svgf::SvgfDenoiser>(st->s);
    for (int i = 0; i < 6; ++i) st->den->process(st->frames[i % 2]);  // history length >= 4
    svgf::depth_gradient(st->frames[0].depth, st->gradient);
    st->temporal_length = ImageF(w, h, 1, float(st->s.temporal_variance_frames));
    st->spatial_length = ImageF(w, h, 1, 0.0f);
  };
  const auto guide = [st] {
    const Frame& f = st->frames[0];
    return svgf::Guide{&f.depth, &f.normal, &st->gradient};
  };
  BenchPass acc;
  acc.name = "svgf.stage.accumulate";
  // Reads color 3 + albedo 3 + depth 1 + normal 3 + id 1 + motion 2 + depth gradient 2, the
  // previous depth 1 + normal 3 + id 1 and the history color 3 + moments 2 + length 1; writes
  // color 3 + moments 2 + length 1 (each plane once: the 2x2 taps hit the same rows).
  acc.read_planes = 26;
  acc.write_planes = 6;
  acc.prepare = prepare;
  acc.run = [st](const Exec& ex) {
    st->den->set_exec(ex);
    st->den->process(st->frames[st->next++ % 2]);
  };
  acc.self_timed_run = [st](const Exec& ex) {
    st->den->set_exec(ex);
    st->den->process(st->frames[st->next++ % 2]);
    return st->den->last_timings().accumulate_ms;
  };
  passes.push_back(acc);
  for (const bool spatial : {false, true}) {
    BenchPass p;
    p.name = spatial ? "svgf.stage.variance.spatial" : "svgf.stage.variance";
    // Temporal: reads length 1 + the moments' variance 1; spatial: also the mean 1, depth 1,
    // normal 3, depth gradient 2. Writes the variance.
    p.read_planes = spatial ? 9 : 2;
    p.write_planes = 1;
    p.prepare = prepare;
    p.run = [st, spatial, guide](const Exec& ex) {
      svgf::estimate_variance(guide(), st->den->moments(),
                              spatial ? st->spatial_length : st->temporal_length, st->s,
                              st->variance, ex);
    };
    passes.push_back(p);
  }
  BenchPass at;
  at.name = "svgf.stage.atrous";
  // Per iteration: reads color 3 + variance 1 + depth 1 + normal 3 + depth gradient 2, writes
  // color 3 + variance 1; the floor is one such sweep per iteration.
  at.read_planes = 10;
  at.write_planes = 4;
  at.floor_sweeps = st->s.iterations;
  at.prepare = prepare;
  at.run = [st, guide](const Exec& ex) {
    const ImageF* c = &st->den->color_history();
    const ImageF* v = &st->den->variance();
    for (int i = 0; i < st->s.iterations; ++i) {
      svgf::atrous_iteration(guide(), *c, *v, 1 << i, st->s, st->color_out[i % 2],
                             st->var_out[i % 2], ex);
      c = &st->color_out[i % 2];
      v = &st->var_out[i % 2];
    }
  };
  passes.push_back(at);
  // The afterimage preset's à-trous (3 iterations of the 3x3 kernel, normal_exp) on the same
  // inputs.
  BenchPass at_ai = at;
  at_ai.name = "svgf.stage.atrous.afterimage";
  at_ai.floor_sweeps = svgf::preset_afterimage().iterations;
  at_ai.run = [st, guide](const Exec& ex) {
    const svgf::SvgfSettings s = svgf::preset_afterimage();
    const ImageF* c = &st->den->color_history();
    const ImageF* v = &st->den->variance();
    for (int i = 0; i < s.iterations; ++i) {
      svgf::atrous_iteration(guide(), *c, *v, 1 << i, s, st->color_out[i % 2], st->var_out[i % 2],
                             ex);
      c = &st->color_out[i % 2];
      v = &st->var_out[i % 2];
    }
  };
  passes.push_back(at_ai);

  // A-SVGF's gradient reconstruction (svgf/gradient.h) with the afterimage preset's settings,
  // on one gradient sample per 3x3 stratum: delta a noisy change, max its magnitude bound.
  struct GradientState {
    ImageF gradient, luminance, strata, lambda, relight;
    svgf::SvgfSettings s = svgf::preset_afterimage();
  };
  auto gs = std::make_shared<GradientState>();
  BenchPass gr;
  gr.name = "svgf.stage.gradient";
  // The floor: reading the sparse samples (delta, max, valid) and writing lambda at full
  // resolution; the guides are read at one pixel per stratum.
  gr.read_planes = 3;
  gr.write_planes = 1;
  gr.prepare = [st, gs, prepare](int w, int h) {
    prepare(w, h);
    gs->gradient = ImageF(w, h, 3, 0.0f);
    gs->luminance = ImageF(w, h, 1);
    const Frame& f = st->frames[0];
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        gs->luminance.at(x, y, 0) =
            (f.color.at(x, y, 0) + f.color.at(x, y, 1) + f.color.at(x, y, 2)) / 3.0f;
        if (x % 3 != 1 || y % 3 != 1) continue;
        const float l = gs->luminance.at(x, y, 0);
        gs->gradient.at(x, y, 0) = (x / 3 + y / 3) % 7 == 0 ? l : 0.1f * l;  // delta
        gs->gradient.at(x, y, 1) = l;                                        // max
        gs->gradient.at(x, y, 2) = 1.0f;                                     // valid
      }
  };
  gr.run = [gs, guide](const Exec& ex) {
    svgf::reconstruct_gradient(gs->gradient, guide(), gs->luminance, gs->s, gs->strata, gs->lambda,
                               gs->s.gradient_relight ? &gs->relight : nullptr, ex);
  };
  passes.push_back(gr);
}

}  // namespace

std::vector<BenchPass> all_bench_passes() {
  std::vector<BenchPass> passes;
  // Every registered sequence method, one frame in steady state (history in place), with the
  // family's minimum memory traffic as the floor.
  for (const MethodFamily& family : method_families()) {
    std::vector<std::string> variants = family.variants;
    variants.insert(variants.end(), family.bench_extra_variants.begin(),
                    family.bench_extra_variants.end());
    for (const auto& variant : variants) {
      struct State {
        Frame frame;
        std::unique_ptr<SequenceMethod> method;
      };
      auto st = std::make_shared<State>();
      const std::string spec = family.technique + ":" + variant;
      passes.push_back(kernel_pass(
          family.bench_pass + "." + variant, family.bench_read_planes, family.bench_write_planes,
          [st, spec, size = family.bench_input_size, variant](int w, int h) {
            // The row is named by its output size; upsampling methods read smaller frames.
            if (size) std::tie(w, h) = size(variant, w, h);
            st->frame = synthetic_frame(w, h, 1);
            st->method = make_method(spec);
            st->method->process(synthetic_frame(w, h, 0));
            st->method->process(st->frame);  // with history: the planes of the timed frames
          },
          [st](const Exec& ex) {
            st->method->set_exec(ex);
            st->method->process(st->frame);
          }));
      // The floor over the planes this variant streams (the family's minimum when the method
      // does not report them): a preset that keeps more state moves more bytes.
      passes.back().streamed_planes = [st] {
        const PlaneTraffic t = st->method->last_traffic();
        return std::pair(t.read, t.write);
      };
    }
  }
  add_svgf_stage_passes(passes);
  {
    // Every post stage alone (reads and writes RGB), then the whole post chain in order.
    struct State {
      Frame frame;
      std::vector<std::unique_ptr<PostStage>> stages;
    };
    // scene: a built-in scene's frame 1 (its motion refers to frame 0) rendered at the row's size
    // instead of the bench frame (the G-buffer render, as `render` writes it: the scene's lens and
    // motion).
    auto add = [&](const std::string& name, std::vector<const PostStageInfo*> infos,
                   std::string set = "", std::string scene = "") {
      auto st = std::make_shared<State>();
      passes.push_back(kernel_pass(
          name, 3, 3,
          [st, infos, set, scene](int w, int h) {
            if (scene.empty()) {
              st->frame = synthetic_post_frame(w, h, 0);
            } else {
              render::RenderSettings rs;
              rs.width = w;
              rs.height = h;
              st->frame = render::render_gbuffer(render::make_builtin_scene(scene), 1, rs, Exec{});
            }
            st->stages.clear();
            for (const PostStageInfo* i : infos) st->stages.push_back(i->make());
            // `set`: the first stage's assignments, comma-separated.
            for (size_t at = 0; at < set.size();) {
              const size_t end = std::min(set.find(',', at), set.size());
              st->stages.front()->set(set.substr(at, end - at));
              at = end + 1;
            }
          },
          [st](const Exec& ex) {
            // As `run` chains them (run_post_stages: tonemap fused into flare's rows), the
            // first stage reading the frame's color without a copy.
            std::vector<PostStage*> stages;
            for (const auto& s : st->stages) stages.push_back(s.get());
            run_post_stages(stages, st->frame, st->frame.color, ex);
          }));
    };
    std::vector<const PostStageInfo*> chain;
    for (const PostStageInfo& info : post_stages()) {
      add("post." + info.name, {&info});
      if (info.name == "dof") {
        add("post.dof.half", {&info}, "resolution=half");
        add("post.dof.all-half", {&info}, "resolution=half,half_from=0");
        add("post.dof.diffusion", {&info}, "mode=diffusion");
      }
      if (info.name == "motion_blur")
        add("post.motion_blur.all-samples", {&info}, "fast_tap_spacing=0");
      // The chain issue 12 times: DoF, motion blur, bloom, flare, tonemap (sharpen, an option
      // on the display image after them, has its own row).
      if (info.name != "sharpen") chain.push_back(&info);
    }
    add("post.chain", chain);
    // The DoF and the chain on a real shallow-focus render, at 1080p: `focus`'s blurred tiles
    // mostly reach the DoF's radius clamp (96 distinct taps a pixel), the bench frame's stay
    // under ~10 px, so the rows above understate what a shallow-focus shot costs.
    add("post.dof.focus", {chain.front()}, "", "focus");
    passes.back().sizes = {{1920, 1080}};
    add("post.chain.focus", chain, "", "focus");
    passes.back().sizes = {{1920, 1080}};
  }
  {
    // SSIM of one plane pair: reads 2 planes.
    auto imgs = std::make_shared<std::pair<ImageF, ImageF>>();
    passes.push_back(kernel_pass(
        "metrics.ssim", 2, 0,
        [imgs](int w, int h) {
          Frame a = synthetic_frame(w, h, 0), b = synthetic_frame(w, h, 1);
          imgs->first = ImageF(w, h, 1);
          imgs->second = ImageF(w, h, 1);
          for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
              imgs->first.at(x, y, 0) = std::min(1.0f, a.color.at(x, y, 1));
              imgs->second.at(x, y, 0) = std::min(1.0f, b.color.at(x, y, 1));
            }
        },
        [imgs](const Exec& ex) {
          metrics::ssim(view(imgs->first, 0), view(imgs->second, 0), {}, ex);
        }));
  }
  {
    // LDR-FLIP: reads 2 RGB images, writes the 1-plane error map.
    auto imgs = std::make_shared<std::pair<ImageF, ImageF>>();
    passes.push_back(kernel_pass(
        "metrics.flip", 6, 1,
        [imgs](int w, int h) {
          imgs->first = synthetic_frame(w, h, 0).color;
          imgs->second = synthetic_frame(w, h, 1).color;
          for (ImageF* i : {&imgs->first, &imgs->second})
            for (float& v : i->data()) v = std::min(1.0f, v);
        },
        [imgs](const Exec& ex) {
          metrics::ldr_flip(imgs->first, imgs->second, metrics::flip_default_ppd(), ex);
        }));
  }
  {
    // G-buffer render of the thin scene: writes color 3 + depth 1 + normal 3 + albedo 3 +
    // motion 2 + id 1 planes (compute-bound: the ratio shows how far from memory-bound).
    auto scene = std::make_shared<render::Scene>(render::make_builtin_scene("thin"));
    auto rs = std::make_shared<render::RenderSettings>();
    passes.push_back(kernel_pass(
        "render.gbuffer.thin", 0, 13,
        [rs](int w, int h) {
          rs->width = w;
          rs->height = h;
        },
        [scene, rs](const Exec& ex) { render::render_gbuffer(*scene, 3, *rs, ex); }));
  }
  passes.push_back(end_to_end_pass("e2e.resolve.files", "motion", [](const Exec& ex) {
    return make_method("taa:" + default_variant("taa"), ex);
  }));
  passes.push_back(end_to_end_pass("e2e.run.post.files", "focus", [](const Exec& ex) {
    return make_pipeline_method(parse_pipeline("dof,motion_blur,bloom,flare,tonemap", {}), ex);
  }));
  return passes;
}

}  // namespace afterimage
