// Stage 2: tile binning with a radix sort by depth and a counting sort by tile.
#include "retimegs/render/bin_tiles.hpp"

#include <omp.h>

#include <algorithm>
#include <bit>
#include <climits>
#include <utility>

#include "retimegs/core/error.hpp"

namespace retimegs::render {
namespace {

constexpr int kRadixBits = 8;
constexpr int kRadixBuckets = 1 << kRadixBits;
constexpr int kKeyBits = 32;

// Stable LSD radix sort of (key, value) pairs by key, one byte per pass, skipping bytes in which
// all keys agree (depths in [3, 6] share their top byte). Serial: a few milliseconds for 300k
// Gaussians, and no barriers for a busy core to hold up.
void radix_sort_pairs(std::vector<std::uint32_t>& keys, std::vector<std::int32_t>& values) {
  const std::size_t n = keys.size();
  std::uint32_t varying = 0;  // bits in which some key differs from the first
  for (std::size_t i = 1; i < n; ++i) varying |= keys[i] ^ keys[0];
  std::vector<std::uint32_t> keys_tmp(n);
  std::vector<std::int32_t> values_tmp(n);
  for (int shift = 0; shift < kKeyBits; shift += kRadixBits) {
    if (((varying >> shift) & (kRadixBuckets - 1)) == 0) continue;  // one bucket: order kept
    std::size_t offsets[kRadixBuckets] = {};
    for (std::size_t i = 0; i < n; ++i) ++offsets[(keys[i] >> shift) & (kRadixBuckets - 1)];
    std::size_t offset = 0;
    for (std::size_t& o : offsets) offset += std::exchange(o, offset);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t dst = offsets[(keys[i] >> shift) & (kRadixBuckets - 1)]++;
      keys_tmp[dst] = keys[i];
      values_tmp[dst] = values[i];
    }
    keys.swap(keys_tmp);
    values.swap(values_tmp);
  }
}

}  // namespace

TileBins bin_tiles(const Projected& projected, const float* opacities, int width, int height,
                   const RenderOptions& options) {
  TileBins bins;
  bins.tiles_x = (width + kTileSize - 1) / kTileSize;
  bins.tiles_y = (height + kTileSize - 1) / kTileSize;
  const int num_tiles = bins.num_tiles();
  const std::size_t n = projected.size();

  // Tile rectangles; Gaussians that reach no tile are dropped here.
  std::vector<TileRect> rects(n);  // [N]
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < std::ptrdiff_t(n); ++i) {
    if (projected.radii[i] <= 0) continue;
    rects[i] =
        blend_tile_rect(&projected.means2d[2 * i], &projected.conics[3 * i], projected.radii[i],
                        opacities[i], bins.tiles_x, bins.tiles_y, options);
  }
  std::vector<std::uint32_t> depth_keys;        // [V] float bits of a positive depth sort as uints
  std::vector<std::int32_t> gaussian_by_depth;  // [V]
  for (std::size_t i = 0; i < n; ++i) {
    if (rects[i].area() <= 0) continue;
    depth_keys.push_back(std::bit_cast<std::uint32_t>(projected.depths[i]));
    gaussian_by_depth.push_back(std::int32_t(i));
  }
  radix_sort_pairs(depth_keys, gaussian_by_depth);

  // The rectangles in depth order: the two passes below then read them sequentially.
  const std::size_t v = gaussian_by_depth.size();
  std::vector<TileRect> rects_by_depth(v);  // [V]
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < std::ptrdiff_t(v); ++k)
    rects_by_depth[k] = rects[gaussian_by_depth[k]];

  // Counting sort by tile: each thread takes a contiguous run of the depth order, counts its
  // intersections per tile, and scatters them after those of the threads before it.
  const int threads = std::max(1, std::min<int>(omp_get_max_threads(), int(v / 1024) + 1));
  std::vector<std::int64_t> tile_counts(std::size_t(threads) * num_tiles, 0);  // [threads, tiles]
  bins.isect_offsets.assign(num_tiles + 1, 0);
  bool too_many = false;
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
    const std::size_t begin = v * t / threads, end = v * (t + 1) / threads;
    std::int64_t* count = &tile_counts[std::size_t(t) * num_tiles];
    for (std::size_t k = begin; k < end; ++k) {
      const TileRect& r = rects_by_depth[k];
      for (int ty = r.y0; ty < r.y1; ++ty)
        for (int tx = r.x0; tx < r.x1; ++tx) ++count[ty * bins.tiles_x + tx];
    }
#pragma omp barrier
#pragma omp single
    {
      std::int64_t offset = 0;
      for (int tile = 0; tile < num_tiles; ++tile) {
        bins.isect_offsets[tile] = std::int32_t(std::min<std::int64_t>(offset, INT32_MAX));
        for (int u = 0; u < threads; ++u) {
          const std::int64_t c = tile_counts[std::size_t(u) * num_tiles + tile];
          tile_counts[std::size_t(u) * num_tiles + tile] = offset;
          offset += c;
        }
      }
      too_many = offset > INT32_MAX;
      bins.isect_offsets[num_tiles] = std::int32_t(std::min<std::int64_t>(offset, INT32_MAX));
      if (!too_many) bins.gaussian_from_isect.resize(std::size_t(offset));
    }
    if (!too_many)
      for (std::size_t k = begin; k < end; ++k) {
        const std::int32_t g = gaussian_by_depth[k];
        const TileRect& r = rects_by_depth[k];
        for (int ty = r.y0; ty < r.y1; ++ty)
          for (int tx = r.x0; tx < r.x1; ++tx)
            bins.gaussian_from_isect[count[ty * bins.tiles_x + tx]++] = g;
      }
  }
  if (too_many) fail("bin_tiles: more than 2^31 tile intersections");
  return bins;
}

}  // namespace retimegs::render
