#include "pipeline/bench_passes.h"

#include <cmath>
#include <memory>

#include "camera/camera.h"
#include "frame/frame.h"
#include "metrics/flip.h"
#include "metrics/ssim.h"
#include "pipeline/methods.h"
#include "render/builtin_scenes.h"
#include "render/renderer.h"

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

std::vector<BenchPass> all_bench_passes() {
  std::vector<BenchPass> passes;
  // Every registered sequence method, one frame in steady state (history in place), with the
  // family's minimum memory traffic as the floor.
  for (const MethodFamily& family : method_families())
    for (const auto& variant : family.variants) {
      struct State {
        Frame frame;
        std::unique_ptr<SequenceMethod> method;
      };
      auto st = std::make_shared<State>();
      const std::string spec = family.technique + ":" + variant;
      passes.push_back({family.bench_pass + "." + variant, family.bench_read_planes,
                        family.bench_write_planes,
                        [st, spec](int w, int h) {
                          st->frame = synthetic_frame(w, h, 1);
                          st->method = make_method(spec);
                          st->method->process(synthetic_frame(w, h, 0));
                        },
                        [st](const Exec& ex) {
                          st->method->set_exec(ex);
                          st->method->process(st->frame);
                        }});
    }
  {
    // SSIM of one plane pair: reads 2 planes.
    auto imgs = std::make_shared<std::pair<ImageF, ImageF>>();
    passes.push_back({"metrics.ssim", 2, 0,
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
                      }});
  }
  {
    // LDR-FLIP: reads 2 RGB images, writes the 1-plane error map.
    auto imgs = std::make_shared<std::pair<ImageF, ImageF>>();
    passes.push_back({"metrics.flip", 6, 1,
                      [imgs](int w, int h) {
                        imgs->first = synthetic_frame(w, h, 0).color;
                        imgs->second = synthetic_frame(w, h, 1).color;
                        for (ImageF* i : {&imgs->first, &imgs->second})
                          for (float& v : i->data()) v = std::min(1.0f, v);
                      },
                      [imgs](const Exec& ex) {
                        metrics::ldr_flip(imgs->first, imgs->second, metrics::flip_default_ppd(),
                                          ex);
                      }});
  }
  {
    // G-buffer render of the thin scene: writes color 3 + depth 1 + normal 3 + albedo 3 +
    // motion 2 + id 1 planes (compute-bound: the ratio shows how far from memory-bound).
    auto scene = std::make_shared<render::Scene>(render::make_builtin_scene("thin"));
    auto rs = std::make_shared<render::RenderSettings>();
    passes.push_back({"render.gbuffer.thin", 0, 13,
                      [rs](int w, int h) {
                        rs->width = w;
                        rs->height = h;
                      },
                      [scene, rs](const Exec& ex) { render::render_gbuffer(*scene, 3, *rs, ex); }});
  }
  return passes;
}

}  // namespace afterimage
