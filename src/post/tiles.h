// The 3x3 tile neighbourhood of the tiled passes (NeighborMax, McGuire et al. 2012): DoF's
// largest radius (dof.h tile_neighbor_max) and motion blur's dominant motion both reduce each
// tile's 3x3 tiles, those inside the grid, in row order.
#pragma once

#include <cstddef>
#include <vector>

namespace afterimage::post {

// Each tile's `combine(acc, neighbour)` over its 3x3 tiles inside the tw x th grid (dy, then
// dx), from `init`.
template <class T, class Combine>
std::vector<T> tile_neighbor_reduce(const std::vector<T>& tile, int tw, int th, T init,
                                    Combine&& combine) {
  std::vector<T> out(tile.size(), init);
  for (int ty = 0; ty < th; ++ty)
    for (int tx = 0; tx < tw; ++tx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int ux = tx + dx, uy = ty + dy;
          if (ux < 0 || uy < 0 || ux >= tw || uy >= th) continue;
          T& m = out[size_t(ty) * size_t(tw) + size_t(tx)];
          m = combine(m, tile[size_t(uy) * size_t(tw) + size_t(ux)]);
        }
  return out;
}

}  // namespace afterimage::post
