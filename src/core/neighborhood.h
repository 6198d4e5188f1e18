// Neighbourhood loads for per-pixel kernels: the 3x3 order every pass uses and a strided
// loader (step 1: the 3x3 neighbours; step 2^i: the taps of an à-trous wavelet level,
// Dammertz et al. 2010, used by SVGF's filter). All clamp to the edge.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>

#include "core/simd.h"

namespace afterimage {

// Order of the 3x3 neighbourhood everywhere: center, the cross (left, right, up, down), then
// the corners. The first 5 are the cross.
constexpr int kNeighborDx[9] = {0, -1, 1, 0, 0, -1, 1, -1, 1};
constexpr int kNeighborDy[9] = {0, 0, 0, -1, 1, -1, -1, 1, 1};

// Offsets (in elements) of rows y - step, y, y + step, clamped to the image: index
// kNeighborDy[i] + 1 gives neighbour i's row.
inline std::array<size_t, 3> neighborhood_rows(int y, int width, int height, int step = 1) {
  return {size_t(std::max(y - step, 0)) * size_t(width), size_t(y) * size_t(width),
          size_t(std::min(y + step, height - 1)) * size_t(width)};
}

// Lanes x + dx * step .. of `row` (width `width`), clamped to the edge: a contiguous load
// inside, a gather of clamped indices at the borders.
template <class D, class T>
HWY_INLINE hn::Vec<D> load_row_strided(D d, const T* row, int x, int dx, int step, int width) {
  const int n = int(hn::Lanes(d));
  const int xs = x + dx * step;
  if (xs >= 0 && xs + n <= width) return hn::LoadU(d, row + xs);
  const hn::RebindToSigned<D> di;
  auto idx = hn::Min(hn::Max(iota_from(di, xs), hn::Zero(di)), hn::Set(di, width - 1));
  return hn::GatherIndex(d, row, idx);
}

// The step-1 form (3x3 neighbourhoods).
template <class D, class T>
HWY_INLINE hn::Vec<D> load_row_shifted(D d, const T* row, int x, int dx, int width) {
  return load_row_strided(d, row, x, dx, 1, width);
}

// Neighbour i (kNeighborDx/Dy order) of the lanes at (x, y) of `plane`, at distance `step`;
// `rows` from neighborhood_rows(y, width, height, step).
template <class D, class T>
HWY_INLINE hn::Vec<D> load_neighbor(D d, const T* plane, const std::array<size_t, 3>& rows, int x,
                                    int i, int step, int width) {
  return load_row_strided(d, plane + rows[size_t(kNeighborDy[i] + 1)], x, kNeighborDx[i], step,
                          width);
}

}  // namespace afterimage
