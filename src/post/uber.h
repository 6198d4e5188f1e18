// The "uber" final pass (issue 12 speed; as UE's and Unity's post stacks end in one "uber"
// shader): bloom, lens flare and tonemap in a row as one pass over the full-resolution image.
// Bloom and flare compute their low-resolution parts alone (the mip chain; the bright pass,
// ghosts, streaks, sprites and glare), and one final pass per row adds the upsampled bloom
// light, the flare's light and tonemaps, writing the output once instead of three images.
// The flare's bright pass needs bloom's full-resolution output: bloom's last upsample and
// composite write it into the output image and feed each row to the bright pass while it is
// in cache; the final pass then adds the flare's light and tonemaps in place. Each term keeps
// its arithmetic order: the output has the bits of tonemap(lens_flare(bloom(hdr))) for any
// thread count and --simd off. Measured (1080p chain, task-clock samples in post::): running
// bloom's last upsample and composite a second time instead of storing its rows was 4% slower.
#pragma once

#include "core/image.h"
#include "core/parallel.h"
#include "post/bloom.h"
#include "post/flare.h"
#include "post/tonemap.h"

namespace afterimage::post {

// tonemap(lens_flare(bloom(hdr, b), f), t), fused when bloom_rows_supported(b) and the flare
// adds light, else the three passes in turn. Writes into `out` (resized to hdr's shape; its
// storage reused when it already has it; not hdr).
void bloom_flare_tonemap_into(const ImageF& hdr, const BloomSettings& b, const FlareSettings& f,
                              const TonemapSettings& t, ImageF& out, const Exec& exec = {});
ImageF bloom_flare_tonemap(const ImageF& hdr, const BloomSettings& b, const FlareSettings& f,
                           const TonemapSettings& t, const Exec& exec = {});

}  // namespace afterimage::post
