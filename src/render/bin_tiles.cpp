// Stage 2: tile binning with a radix sort by depth and a counting sort by tile.
#include "retimegs/render/bin_tiles.hpp"

#include <omp.h>

#include <algorithm>
#include <bit>
#include <climits>
#include <cmath>
#include <utility>

#include "retimegs/core/error.hpp"
#include "simd.hpp"

namespace retimegs::render {
namespace {

constexpr int kRadixBits = 8;
constexpr int kRadixBuckets = 1 << kRadixBits;
constexpr int kKeyBits = 32;

// Stable LSD radix sort of 64-bit items by their upper 32 bits (the key; the lower half is the
// value), one byte per pass, skipping bytes in which all keys agree (depths in [3, 6] share
// their top byte). Each pass splits the items into one contiguous run per thread: the threads
// count their run's digits, the offsets of (digit, thread) are summed in that order, and each
// thread scatters its run; a stable sort has one result, whatever the thread count.
void radix_sort_by_key(UninitVector<std::uint64_t>& items) {
  constexpr int kValueBits = 32;
  const std::size_t n = items.size();
  std::uint64_t varying = 0;  // bits in which some key differs from the first
  for (std::size_t i = 1; i < n; ++i) varying |= items[i] ^ items[0];
  varying >>= kValueBits;
  constexpr std::size_t kItemsPerThread = 16384;  // below: one thread (fork/join would dominate)
  const int threads = int(std::min<std::size_t>(omp_get_max_threads(), n / kItemsPerThread + 1));
  UninitVector<std::uint64_t> sorted(n);
  std::vector<std::size_t> offsets(std::size_t(threads) * kRadixBuckets);  // [threads, buckets]
  for (int shift = 0; shift < kKeyBits; shift += kRadixBits) {
    if (((varying >> shift) & (kRadixBuckets - 1)) == 0) continue;  // one bucket: order kept
    const auto digit = [&](std::uint64_t item) {
      return std::size_t(item >> (kValueBits + shift)) & (kRadixBuckets - 1);
    };
#pragma omp parallel num_threads(threads)
    {
      const int t = omp_get_thread_num();
      const std::size_t begin = n * t / threads, end = n * (t + 1) / threads;
      std::size_t* own = &offsets[std::size_t(t) * kRadixBuckets];
      std::fill(own, own + kRadixBuckets, 0);
      for (std::size_t i = begin; i < end; ++i) ++own[digit(items[i])];
#pragma omp barrier
#pragma omp single
      {
        std::size_t offset = 0;
        for (int d = 0; d < kRadixBuckets; ++d)
          for (int u = 0; u < threads; ++u)
            offset += std::exchange(offsets[std::size_t(u) * kRadixBuckets + d], offset);
      }
      for (std::size_t i = begin; i < end; ++i) sorted[own[digit(items[i])]++] = items[i];
    }
    items.swap(sorted);
  }
}

// blend_tile_rect (project.cpp) of 16 Gaussians at a time, operation for operation in float, the
// logarithm per lane. Lanes of culled Gaussians (radius 0) get an empty rect.
void blend_tile_rects(const Projected& p, const float* opacities, int tiles_x, int tiles_y,
                      const RenderOptions& options, std::vector<TileRect>& rects) {
  using simd::vf;
  using simd::vi;
  constexpr int kLanes = simd::kLanes;
  const std::size_t n = p.size();
  const vf lim = simd::splat(1e8f);                   // kMaxPixelCoordinate
  const vf inv_tile = simd::splat(1.0f / kTileSize);  // exact: a power of two
  const auto clamp_int = [](vi a, int hi) {
    return simd::min(simd::max(a, vi{}), simd::splat_int(hi));
  };
  const auto trunc = [](vf a) { return __builtin_convertvector(a, vi); };
  const auto floor_tile = [&](vf x) {
    return simd::floor_to_int(simd::min(simd::max(x, -lim), lim) * inv_tile);
  };
  const bool tight = options.tight_tile_bounds && options.min_alpha > 0;
  constexpr float kRelMargin = 1.001f, kAbsMargin = 0.01f;  // as alpha_extent
  const std::ptrdiff_t batches = std::ptrdiff_t((n + kLanes - 1) / kLanes);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t b = 0; b < batches; ++b) {
    const std::size_t first = std::size_t(b) * kLanes;
    const int count = int(std::min<std::size_t>(kLanes, n - first));
    vf u{}, v{}, c0{}, c1{}, c2{}, level{};
    vi radius{};
    for (int l = 0; l < count; ++l) {
      const std::size_t i = first + l;
      u[l] = p.means2d[2 * i];
      v[l] = p.means2d[2 * i + 1];
      c0[l] = p.conics[3 * i];
      c1[l] = p.conics[3 * i + 1];
      c2[l] = p.conics[3 * i + 2];
      radius[l] = p.radii[i];
      if (tight && radius[l] > 0) level[l] = std::log(opacities[i] / options.min_alpha);
    }
    // radius_tile_rect: C-style truncation toward zero, as gsplat v0.1.13.
    const vf uc = simd::min(simd::max(u, -lim), lim), vc = simd::min(simd::max(v, -lim), lim);
    const vf r = __builtin_convertvector(radius, vf) * inv_tile;
    vi x0 = clamp_int(trunc(uc * inv_tile - r), tiles_x);
    vi x1 = clamp_int(trunc(uc * inv_tile + r) + 1, tiles_x);
    vi y0 = clamp_int(trunc(vc * inv_tile - r), tiles_y);
    vi y1 = clamp_int(trunc(vc * inv_tile + r) + 1, tiles_y);
    if (tight) {
      // alpha_extent: the half-extents of sigma <= level; none where level <= 0.
      const vf det = c0 * c2 - c1 * c1;
      const vf two_level = 2.0f * simd::max(level, vf{});
      const simd::mask some = simd::less(vf{}, level);
      const vf ext_x = simd::select(
          some, simd::sqrt_nonnegative(two_level * (c2 / det)) * kRelMargin + kAbsMargin, vf{});
      const vf ext_y = simd::select(
          some, simd::sqrt_nonnegative(two_level * (c0 / det)) * kRelMargin + kAbsMargin, vf{});
      x0 = simd::max(x0, floor_tile(u - ext_x));
      x1 = simd::min(x1, floor_tile(u + ext_x) + 1);
      y0 = simd::max(y0, floor_tile(v - ext_y));
      y1 = simd::min(y1, floor_tile(v + ext_y) + 1);
    }
    for (int l = 0; l < count; ++l) {
      const bool empty = radius[l] <= 0 || x1[l] <= x0[l] || y1[l] <= y0[l];
      rects[first + l] = empty ? TileRect{} : TileRect{x0[l], y0[l], x1[l], y1[l]};
    }
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
  blend_tile_rects(projected, opacities, bins.tiles_x, bins.tiles_y, options, rects);
  // [V] (depth << 32 | Gaussian): the float bits of a positive depth sort as uints.
  UninitVector<std::uint64_t> by_depth;
  by_depth.reserve(n);
  for (std::size_t i = 0; i < n; ++i)
    if (rects[i].area() > 0)
      by_depth.push_back(std::uint64_t(std::bit_cast<std::uint32_t>(projected.depths[i])) << 32 |
                         std::uint32_t(i));
  radix_sort_by_key(by_depth);
  UninitVector<std::int32_t> gaussian_by_depth(by_depth.size());  // [V]

  // The rectangles in depth order: the two passes below then read them sequentially.
  const std::size_t v = gaussian_by_depth.size();
  std::vector<TileRect> rects_by_depth(v);  // [V]
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < std::ptrdiff_t(v); ++k) {
    gaussian_by_depth[k] = std::int32_t(by_depth[k] & 0xffffffffu);
    rects_by_depth[k] = rects[gaussian_by_depth[k]];
  }

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
