// Coverage alpha through the temporal methods and the post chain (DESIGN.md §3 "Alpha").
//
// A render with a transparent background (Blender's Film > Transparent) writes a color
// premultiplied by its coverage alpha. A filter that averages color with weights w gives the
// right premultiplied result for any weights, and the matching alpha is the same average of the
// alpha: out = sum w c / sum w, out_a = sum w a / sum w. So the alpha goes through a second
// instance of each stage that moves pixels, fed the alpha in all three color planes:
//   - a temporal method (taa, taau, svgf): its own history of the alpha, reprojected with the
//     same motion and rectified against the alpha's own neighbourhood. Its blend weights come
//     from the alpha where the color's come from the color (TAA's luma weights), so the two
//     agree exactly where the color's luma follows the coverage and closely elsewhere;
//   - dof and motion_blur: their weights come from the G-buffer alone (CoC, velocity, depth),
//     so the alpha takes exactly the color's weights;
//   - bloom, flare, tonemap and sharpen leave the alpha as it is: bloom and flare add light
//     (premultiplied color may exceed alpha: light over an empty pixel), tonemap and sharpen
//     are per-pixel display steps of the color.
// An alpha that is 1 everywhere (an opaque render that still writes Combined.A) costs a scan:
// the output alpha is 1 and the second instance is not run; it starts afresh, as at a camera
// cut, on the next frame whose alpha is below 1 somewhere.
#pragma once

#include <cmath>
#include <functional>
#include <memory>

#include "core/image.h"
#include "core/parallel.h"
#include "frame/sequence_method.h"

namespace afterimage {

// An alpha value as the twins read it: a non-finite one (a library caller's frame; the file
// reader already sets them to 0) is empty, so that it never reaches history.
inline float finite_alpha(float a) {
  return std::isfinite(a) ? a : 0.0f;
}
// `alpha` with finite_alpha of every value.
ImageF finite_alpha(ImageF alpha, const Exec& ex = {});
// True when every value of `alpha` is exactly 1 (what an opaque render writes).
bool fully_opaque(const ImageF& alpha, const Exec& ex = {});
// The one-plane alpha as a three-plane color (each plane a copy), for a stage's second instance.
ImageF alpha_as_color(const ImageF& alpha, const Exec& ex = {});
// The first plane of a color made by alpha_as_color and processed: the alpha again.
ImageF alpha_of_color(const ImageF& color, const Exec& ex = {});
// A twin's input: `f`'s header, its alpha as the color (alpha_as_color; 1 where `f` has no
// alpha), and copies of the channels of `uses` that `f` has, besides color and alpha.
Frame alpha_frame(const Frame& f, ChannelSet uses, const Exec& ex = {});

// `method` with the frames' alpha carried through a second instance made by `make_twin` (same
// technique, same settings), as above. Frames without alpha pass through `method` alone. State
// files: the method's at the path, the alpha's at path + ".alpha" while it is in use.
std::unique_ptr<SequenceMethod> carry_alpha(
    std::unique_ptr<SequenceMethod> method,
    std::function<std::unique_ptr<SequenceMethod>()> make_twin, const Exec& exec);

}  // namespace afterimage
