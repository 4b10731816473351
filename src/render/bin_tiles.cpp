// Stage 2: tile binning with a radix sort by depth and a counting sort by tile.
#include "retimegs/render/bin_tiles.hpp"

#include <omp.h>

#include <algorithm>
#include <bit>
#include <climits>
#include <cmath>
#include <cstring>
#include <utility>

#include "retimegs/core/error.hpp"
#include "retimegs/render/formulas.hpp"
#include "simd.hpp"

namespace retimegs::render {
namespace {

// The radix sort's digits: at most 12 bits (4096 buckets: the per-thread counts stay in L1/L2),
// so that the 24 bits in which depths in [2, 8) differ take two passes instead of three bytes.
constexpr int kMaxRadixBits = 12;

// A visible Gaussian in the depth sort: (depth bits << 32 | Gaussian index) — the float bits of a
// positive depth sort as uints — and its tile rect, which travels with it so that the passes
// after the sort read the rects in depth order instead of gathering them (a cache miss each).
// A TileRect in 16 bits per side (bin_tiles checks that the tile counts fit).
struct Rect16 {
  std::uint16_t x0, y0, x1, y1;
};

struct DepthItem {
  std::uint64_t key_index;
  Rect16 rect;

  std::int32_t gaussian() const { return std::int32_t(key_index & 0xffffffffu); }
};
static_assert(sizeof(DepthItem) == 16);

// Stable LSD radix sort of the items by the upper 32 bits of key_index (the key), over the bits
// from the lowest to the highest in which some keys differ (`varying`), in as few passes of at
// most kMaxRadixBits as that span needs. Each pass splits the items into one contiguous run per
// thread: the threads count their run's digits, the offsets of (digit, thread) are summed in that
// order, and each thread scatters its run; a stable sort has one result, whatever the thread
// count.
void radix_sort_by_key(UninitVector<DepthItem>& items, std::uint32_t varying) {
  if (varying == 0) return;  // all keys equal: index order is the order
  constexpr int kValueBits = 32;
  const int lowest = std::countr_zero(varying), span = std::bit_width(varying) - lowest;
  const int passes = (span + kMaxRadixBits - 1) / kMaxRadixBits;
  const int digit_bits = (span + passes - 1) / passes;
  const std::size_t buckets = std::size_t(1) << digit_bits;
  const std::size_t n = items.size();
  constexpr std::size_t kItemsPerThread = 16384;  // below: one thread (fork/join would dominate)
  const int threads = int(std::min<std::size_t>(omp_get_max_threads(), n / kItemsPerThread + 1));
  UninitVector<DepthItem> sorted(n);
  std::vector<std::size_t> offsets(std::size_t(threads) * buckets);  // [threads, buckets]
  for (int pass = 0; pass < passes; ++pass) {
    const int shift = kValueBits + lowest + pass * digit_bits;
    const auto digit = [&](const DepthItem& item) {
      return std::size_t(item.key_index >> shift) & (buckets - 1);
    };
#pragma omp parallel num_threads(threads)
    {
      const int t = omp_get_thread_num();
      const std::size_t begin = n * t / threads, end = n * (t + 1) / threads;
      std::size_t* own = &offsets[std::size_t(t) * buckets];
      std::fill(own, own + buckets, 0);
      for (std::size_t i = begin; i < end; ++i) ++own[digit(items[i])];
#pragma omp barrier
#pragma omp single
      {
        std::size_t offset = 0;
        for (std::size_t d = 0; d < buckets; ++d)
          for (int u = 0; u < threads; ++u)
            offset += std::exchange(offsets[std::size_t(u) * buckets + d], offset);
      }
      for (std::size_t i = begin; i < end; ++i) sorted[own[digit(items[i])]++] = items[i];
    }
    items.swap(sorted);
  }
}

// blend_tile_rect (project.cpp) of 16 Gaussians at a time, operation for operation in float, then
// the visible ones (non-empty rect) as depth items in index order. Each thread takes a contiguous
// run of the Gaussians: it computes their rects and counts the visible ones, the counts are summed
// in thread order, and each thread writes its items. `varying`: the key bits in which some items
// differ (for radix_sort_by_key).
UninitVector<DepthItem> depth_items(const Projected& p, const float* opacities, int tiles_x,
                                    int tiles_y, const RenderOptions& options,
                                    std::uint32_t& varying) {
  using simd::vf;
  using simd::vi;
  constexpr int kLanes = simd::kLanes;
  const std::size_t n = p.size();
  const vf lim = simd::splat(float(kMaxPixelCoordinate));
  const vf inv_tile = simd::splat(kInverseTileSize);
  const auto clamp_int = [](vi a, int hi) {
    return simd::min(simd::max(a, vi{}), simd::splat_int(hi));
  };
  const auto trunc = [](vf a) { return __builtin_convertvector(a, vi); };
  const auto floor_tile = [&](vf x) {
    return simd::floor_to_int(simd::min(simd::max(x, -lim), lim) * inv_tile);
  };
  const bool tight = options.tight_tile_bounds && options.min_alpha > 0;
  constexpr float kRelMargin = float(kExtentRelMargin), kAbsMargin = float(kExtentAbsMargin);
  const std::size_t batches = (n + kLanes - 1) / kLanes;
  constexpr std::size_t kBatchesPerThread = 256;  // below: one thread (fork/join would dominate)
  const int threads =
      int(std::min<std::size_t>(omp_get_max_threads(), batches / kBatchesPerThread + 1));
  UninitVector<Rect16> rects(n);                        // [N] empty: x1 == x0
  std::vector<std::size_t> first_item(threads + 1, 0);  // [threads + 1]
  std::vector<std::uint64_t> key_or(threads, 0), key_and(threads, ~std::uint64_t{0});
  UninitVector<DepthItem> items;  // [V]
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
    const std::size_t begin = batches * t / threads * kLanes;
    const std::size_t end = std::min(n, batches * (t + 1) / threads * kLanes);
    std::size_t visible = 0;
    for (std::size_t first = begin; first < end; first += kLanes) {
      const int count = int(std::min<std::size_t>(kLanes, n - first));
      // Lanes past `count` repeat the last Gaussian; their rects are not stored.
      vf mean[2], conic[3];
      simd::load_columns<2>(&p.means2d[2 * first], count, mean);
      simd::load_columns<3>(&p.conics[3 * first], count, conic);
      const vi radius = simd::load_lanes(&p.radii[first], count);
      vf level{};
      if (tight) {
        vf opacity[1];
        simd::load_columns<1>(&opacities[first], count, opacity);
        level = simd::log_nonnegative(opacity[0] / options.min_alpha);
      }
      const vf u = mean[0], v = mean[1], c0 = conic[0], c1 = conic[1], c2 = conic[2];
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
      // The lanes' Rect16s, built in the vectors: (x0 | y0 << 16, x1 | y1 << 16) per lane,
      // interleaved into two vectors of 8 rects (empty ones all zero).
      const simd::mask keep = simd::less(vi{}, radius) & simd::less(x0, x1) & simd::less(y0, y1) &
                              simd::lanes_below(count);
      const vi low = simd::select(keep, x0 | (y0 << 16), vi{});
      const vi high = simd::select(keep, x1 | (y1 << 16), vi{});
      const vi pairs[2] = {__builtin_shufflevector(low, high, 0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5,
                                                   21, 6, 22, 7, 23),
                           __builtin_shufflevector(low, high, 8, 24, 9, 25, 10, 26, 11, 27, 12, 28,
                                                   13, 29, 14, 30, 15, 31)};
      static_assert(sizeof(pairs) == kLanes * sizeof(Rect16));
      std::memcpy(&rects[first], pairs, count * sizeof(Rect16));
      visible += std::popcount(simd::bits(keep));
    }
    first_item[t + 1] = visible;
#pragma omp barrier
#pragma omp single
    {
      for (int u = 0; u < threads; ++u) first_item[u + 1] += first_item[u];
      items.resize(first_item[threads]);
    }
    std::size_t k = first_item[t];
    std::uint64_t any_set = 0, all_set = ~std::uint64_t{0};  // OR and AND of the keys
    for (std::size_t i = begin; i < end; ++i) {
      const Rect16 rect = rects[i];
      if (rect.x1 == rect.x0) continue;
      const std::uint64_t key = std::bit_cast<std::uint32_t>(p.depths[i]);
      items[k++] = {key << 32 | std::uint32_t(i), rect};
      any_set |= key;
      all_set &= key;
    }
    key_or[t] = any_set;
    key_and[t] = all_set;
  }
  std::uint64_t any_set = 0, all_set = ~std::uint64_t{0};
  for (int t = 0; t < threads; ++t) {
    any_set |= key_or[t];
    all_set &= key_and[t];
  }
  varying = std::uint32_t(any_set & ~all_set);
  return items;
}

}  // namespace

TileBins bin_tiles(const Projected& projected, const float* opacities, int width, int height,
                   const RenderOptions& options) {
  TileBins bins;
  bin_tiles(projected, opacities, width, height, options, bins);
  return bins;
}

void bin_tiles(const Projected& projected, const float* opacities, int width, int height,
               const RenderOptions& options, TileBins& bins) {
  bins.tiles_x = tile_count(width);
  bins.tiles_y = tile_count(height);
  const int num_tiles = bins.num_tiles();

  // The visible Gaussians in depth order; those that reach no tile are dropped here.
  if (bins.tiles_x > UINT16_MAX || bins.tiles_y > UINT16_MAX)
    fail("bin_tiles: a {}x{} image has more than {} tiles on a side", width, height, UINT16_MAX);
  std::uint32_t varying = 0;
  UninitVector<DepthItem> by_depth =
      depth_items(projected, opacities, bins.tiles_x, bins.tiles_y, options, varying);
  radix_sort_by_key(by_depth, varying);
  const std::size_t v = by_depth.size();

  // Counting sort by tile: each thread takes a contiguous run of the depth order, counts its
  // intersections per tile, and scatters them after those of the threads before it. A thread
  // counts through a 2-D difference array (+1 at two corners of each rect, -1 at the other two,
  // then prefix sums over rows and columns): four increments per Gaussian and no loop over its
  // tiles, whose varying trip counts the branch predictor cannot learn.
  const int threads = std::max(1, std::min<int>(omp_get_max_threads(), int(v / 1024) + 1));
  const int tiles_x = bins.tiles_x, grid_x = tiles_x + 1;
  const std::size_t grid = std::size_t(grid_x) * (bins.tiles_y + 1);
  std::vector<std::int64_t> tile_counts(std::size_t(threads) * grid, 0);  // [threads, grid]
  bins.isect_offsets.assign(num_tiles + 1, 0);
  bool too_many = false;
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
    const std::size_t begin = v * t / threads, end = v * (t + 1) / threads;
    // Tile (tx, ty) is entry ty * grid_x + tx: the last column and row only absorb the -1s.
    std::int64_t* count = &tile_counts[std::size_t(t) * grid];
    for (std::size_t k = begin; k < end; ++k) {
      const Rect16& r = by_depth[k].rect;
      ++count[r.y0 * grid_x + r.x0];
      --count[r.y0 * grid_x + r.x1];
      --count[r.y1 * grid_x + r.x0];
      ++count[r.y1 * grid_x + r.x1];
    }
    for (int ty = 0; ty < bins.tiles_y; ++ty)
      for (int tx = 1; tx < tiles_x; ++tx) count[ty * grid_x + tx] += count[ty * grid_x + tx - 1];
    for (int ty = 1; ty < bins.tiles_y; ++ty)
      for (int tx = 0; tx < tiles_x; ++tx) count[ty * grid_x + tx] += count[(ty - 1) * grid_x + tx];
#pragma omp barrier
#pragma omp single
    {
      std::int64_t offset = 0;
      for (int tile = 0; tile < num_tiles; ++tile) {
        const std::size_t entry = std::size_t(tile / tiles_x) * grid_x + tile % tiles_x;
        bins.isect_offsets[tile] = std::int32_t(std::min<std::int64_t>(offset, INT32_MAX));
        for (int u = 0; u < threads; ++u) {
          const std::int64_t c = tile_counts[std::size_t(u) * grid + entry];
          tile_counts[std::size_t(u) * grid + entry] = offset;
          offset += c;
        }
      }
      too_many = offset > INT32_MAX;
      bins.isect_offsets[num_tiles] = std::int32_t(std::min<std::int64_t>(offset, INT32_MAX));
      if (!too_many) bins.gaussian_from_isect.resize(std::size_t(offset));
    }
    if (!too_many)
      for (std::size_t k = begin; k < end; ++k) {
        const Rect16& r = by_depth[k].rect;
        const std::int32_t g = by_depth[k].gaussian();
        for (int ty = r.y0; ty < r.y1; ++ty)
          for (int tx = r.x0; tx < r.x1; ++tx)
            bins.gaussian_from_isect[count[ty * grid_x + tx]++] = g;
      }
  }
  if (too_many) fail("bin_tiles: more than 2^31 tile intersections");
}

}  // namespace retimegs::render
