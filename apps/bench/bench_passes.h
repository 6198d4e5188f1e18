// The passes `afterimage bench` times, on synthetic inputs (DESIGN.md §5).
#pragma once

#include <vector>

#include "apps/bench/bench.h"

namespace afterimage {

// A synthetic G-buffer frame: smooth HDR color with detail, depth, ids, a motion field of a
// slow pan plus a rotation (sub-pixel, varying), and jitter for frame `index`.
struct Frame;
Frame synthetic_frame(int width, int height, int index);
// synthetic_frame with every post effect active (a shallow-focus lens, fast motion, small
// very bright lights): the frame the post.* rows time.
Frame synthetic_post_frame(int width, int height, int index);

// Every implemented pass: each registered method (taa.resolve.<preset>, ...), metrics.ssim,
// metrics.flip, render.gbuffer (thin scene).
std::vector<BenchPass> all_bench_passes();

}  // namespace afterimage
