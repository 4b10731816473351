#pragma once
// Stage 2: tile binning. Every (tile, Gaussian) intersection, ordered by tile and, within a
// tile, front to back by depth (gsplat's (tile_id << 32 | depth) key order), built with a radix
// sort of the visible Gaussians by depth and a counting sort of the intersections by tile.
#include <cstdint>
#include <vector>

#include "retimegs/core/memory.hpp"
#include "retimegs/render/options.hpp"
#include "retimegs/render/project.hpp"

namespace retimegs::render {

struct TileBins {
  int tiles_x = 0, tiles_y = 0;             // tile t = ty * tiles_x + tx
  std::vector<std::int32_t> isect_offsets;  // [tiles + 1] tile t owns [offsets[t], offsets[t+1])
  UninitVector<std::int32_t> gaussian_from_isect;  // [M] Gaussian index of each intersection

  int num_tiles() const { return tiles_x * tiles_y; }
  std::size_t num_intersections() const { return gaussian_from_isect.size(); }
};

// Intersections of every Gaussian with radius > 0 with the tiles of its blend_tile_rect. Ties in
// depth keep the lower Gaussian index first. Deterministic for any thread count.
TileBins bin_tiles(const Projected& projected, const float* opacities /* [N] */, int width,
                   int height, const RenderOptions& options);
// The same into `bins`, whose arrays keep their capacity.
void bin_tiles(const Projected& projected, const float* opacities /* [N] */, int width, int height,
               const RenderOptions& options, TileBins& bins);

}  // namespace retimegs::render
