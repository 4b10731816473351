// Stage 3: tile-based front-to-back compositing and its back-to-front vector-Jacobian product.
//
// A 16x16 tile is 4x4 blocks of 4x4 pixels, one simd::vf per block (lane 4 * row + column of
// the block). For each Gaussian of the tile's depth-ordered list, footprint_blocks finds in
// closed form the blocks that hold a pixel centre of its alpha >= min_alpha ellipse, and only
// those blocks are visited: square blocks hug the small footprints of typical scenes (sigma
// 1.5-4 px) far better than 16x1 rows, most of whose lanes would fall outside the footprint.
//
// The forward goes block-major over chunks of 64 list entries: the chunk's footprints first,
// then each block with live pixels runs over the chunk entries that reach it with its pixel
// state (transmittance, colour, last contributor) in registers and stops when its pixels
// saturate. (Gaussian-major, the state of 16 blocks would live in memory, and every update
// would be a chain of loads and stores.) The backward walks the list back to front from the last
// contributor, Gaussian-major: each Gaussian's gradient is accumulated in registers over its
// blocks, then added to the thread's gradient buffer once.
//
// Both loops are bound by each (Gaussian, block) visit's dependency chain (record -> log2 alpha
// -> exp2 -> compositing, ~70 cycles), not by their instruction count: the out-of-order window
// holds only two or three visits' waiting instructions. Hence the forward reads a chunk's
// records from a contiguous copy and computes alphas two entries ahead of the compositing, and
// the backward computes a Gaussian's alphas for all its blocks before their gradients.
//
// Threads: tiles are independent in the forward (dynamic schedule). In the backward each thread
// takes a fixed run of neighbouring tiles of about equal work and sums into its own gradient
// buffer; the buffers are summed in thread order, so that a given thread count always gives the
// same bits.
#include "retimegs/render/blend.hpp"

#include <omp.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

#include "retimegs/core/error.hpp"
#include "simd.hpp"

namespace retimegs::render {
namespace {

using simd::vf;
using simd::vi;
constexpr int kLanes = simd::kLanes;
constexpr int kBlockSide = 4;                             // pixels per block side
constexpr int kBlocksPerSide = kTileSize / kBlockSide;    // 4
constexpr int kBlocks = kBlocksPerSide * kBlocksPerSide;  // per tile
static_assert(kBlockSide * kBlockSide == kLanes, "one vector per block");
static_assert(sizeof(CacheLine) == sizeof(vf), "records are whole vectors");
static_assert(kTileSize == kLanes, "footprint_blocks: one lane per tile row");
static_assert(kBlocks <= 16, "block masks are saved as 16 bits");
constexpr int kMaxStaticChannels = 8;  // channel counts (with depth) that get a compiled kernel

// Lane l of a block is pixel (row l / 4, column l % 4) of the block.
const vf kLaneColumn = {0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3};
const vf kLaneRow = {0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3};
// footprint_blocks puts the 16 rows of a tile in the lanes.
const vf kTileRow = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
// Lane 4r + j of footprint_blocks' result is block (r, j): its first and last tile column.
const vf kBlockFirstColumn = {0, 4, 8, 12, 0, 4, 8, 12, 0, 4, 8, 12, 0, 4, 8, 12};
const vf kBlockLastColumn = kBlockFirstColumn + float(kBlockSide - 1);
static_assert(kBlocksPerSide == 4, "the lane tables above are for 4x4 blocks of 4x4 pixels");

// Where tile pixel (row, column) lives in the block-major state: [block, lane] flattened.
inline int state_index(int row, int column) {
  const int block = row / kBlockSide * kBlocksPerSide + column / kBlockSide;
  return block * kLanes + row % kBlockSide * kBlockSide + column % kBlockSide;
}

// The footprint test widens the level sigma <= ln(opacity / min_alpha) by 1 % + 0.01, far more
// than the float rounding of sigma (a few ulps of its largest term) and of the fast exp (3e-7):
// a pixel that the blend composites is never left out. The cost is ~0.5 % more lanes.
constexpr float kLevelRelMargin = 1.01f, kLevelAbsMargin = 0.01f;

// One 2-D Gaussian packed for the blend: header, then its features (+ depth). The footprint of a
// tile row at offset dy = v - y from the centre is the interval of pixel-centre columns
// du + kRowCentreSlope dy +- sqrt(kHalfWidth2Level - kHalfWidth2Slope dy^2) (footprint_blocks).
enum Field {
  kU,
  kV,
  kHalfA,  // a log2(e) / 2: the conic scaled so that sigma log2(e) comes out (log2_alpha)
  kB,      // b log2(e)
  kHalfC,  // c log2(e) / 2
  kOpacity,
  kLog2Opacity,
  kRowCentreSlope,   // b / a
  kHalfWidth2Level,  // 2 level / a; +inf when min_alpha <= 0 (no footprint limit)
  kHalfWidth2Slope,  // det / a^2 = (a c - b^2) / a^2
  kHeader
};

// Floats per record for C' channels: the header and the features, rounded up to whole cache lines.
constexpr int record_stride(int channels_ext) {
  return (kHeader + channels_ext + kLanes - 1) / kLanes * kLanes;
}

// The blend's view of the inputs, shared by forward and backward.
struct Context {
  const BlendInputs* in;
  const TileBins* bins;
  const RenderOptions* options;
  int channels_ext;               // C (+ 1 when depth is composited)
  int stride;                     // kHeader + channels_ext, rounded up to whole cache lines
  std::vector<float> background;  // [channels_ext]
  // [N, stride] floats, 64-byte aligned, in `records` or borrowed from the forward; rows of
  // culled Gaussians (never binned) are left uninitialised.
  UninitVector<CacheLine> records;
  const float* packed = nullptr;

  // Packs the records (into `storage`'s memory), or borrows `saved` (from blend_forward with the
  // same inputs) when given.
  Context(const BlendInputs& blend_in, const TileBins& tile_bins, const RenderOptions& opts,
          const UninitVector<CacheLine>* saved = nullptr, UninitVector<CacheLine>&& storage = {})
      : in(&blend_in), bins(&tile_bins), options(&opts), records(std::move(storage)) {
    const Projected& p = *in->projected;
    const int c = in->channels;
    channels_ext = c + (options->render_depth ? 1 : 0);
    stride = record_stride(channels_ext);
    background.assign(channels_ext, 0.0f);
    if (in->background) std::copy(in->background, in->background + c, background.begin());
    const std::size_t n = p.size();
    const std::size_t lines = n * stride / kLanes;
    if (saved && lines > 0 && saved->size() == lines) {
      packed = saved->front().values;
      return;
    }
    records.resize(lines);
    packed = lines > 0 ? records.front().values : nullptr;
    const float log_min_alpha = options->min_alpha > 0 ? std::log(options->min_alpha) : 0.0f;
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t g = 0; g < std::ptrdiff_t(n); ++g) {
      if (p.radii[g] <= 0) continue;
      float* s = records[std::size_t(g) * stride / kLanes].values;
      const float opacity = in->opacities[g];
      s[kU] = p.means2d[2 * g];
      s[kV] = p.means2d[2 * g + 1];
      const BlendConicT<float> conic = blend_conic(&p.conics[3 * g], opacity);
      s[kHalfA] = conic.half_a;
      s[kB] = conic.b;
      s[kHalfC] = conic.half_c;
      s[kOpacity] = opacity;
      const float log2_opacity = conic.log2_opacity;
      s[kLog2Opacity] = log2_opacity;
      // det in double: a c and b^2 nearly cancel for thin footprints.
      const double a = p.conics[3 * g], b = p.conics[3 * g + 1], cc = p.conics[3 * g + 2];
      const double det = a * cc - b * b;
      if (options->min_alpha > 0 && a > 0 && det > 0) {
        const float level =
            std::max(0.0f, log2_opacity * kLn2 - log_min_alpha) * kLevelRelMargin + kLevelAbsMargin;
        s[kRowCentreSlope] = float(b / a);
        s[kHalfWidth2Level] = float(2 * level / a);
        s[kHalfWidth2Slope] = float(det / (a * a));
      } else {
        s[kRowCentreSlope] = 0.0f;
        s[kHalfWidth2Level] = std::numeric_limits<float>::infinity();
        s[kHalfWidth2Slope] = 0.0f;
      }
      std::copy(in->features + g * c, in->features + (g + 1) * c, s + kHeader);
      if (options->render_depth) s[kHeader + c] = p.depths[g];
    }
  }

  const float* splat(std::int32_t g) const {
    return packed + std::size_t(g) * stride;
  }
};

// Blocks of a tile that may hold a pixel centre where the Gaussian's alpha >= min_alpha.
// du = u - (x0 + 0.5), dv = v - (y0 + 0.5): the centre relative to the tile's first pixel centre.
// For a fixed row, sigma is a quadratic in the column, so the columns with sigma <= level form
// one interval [lo, hi]; the lanes hold the tile's 16 rows. A block row (4 tile rows, lanes
// 4r .. 4r + 3) takes the hull of its rows' intervals, and block (r, j) is kept when that hull
// overlaps the block's columns 4j .. 4j + 3: lane 4r + j of the last comparison, i.e. bit
// 4r + j of the result. (The hull can add a block between two rows' intervals: a superset is
// all the blend needs, and the test is ~10 instructions shorter than the union per row.)
inline std::uint32_t footprint_blocks(const float* s, float du, float dv) {
  const vf dy = dv - kTileRow;  // [16 rows]
  const vf half_width2 = s[kHalfWidth2Level] - s[kHalfWidth2Slope] * dy * dy;
  const simd::mask row_hit = simd::greater_equal(half_width2, simd::splat(0.0f));
  const vf half_width = simd::sqrt_nonnegative(half_width2);
  const vf centre = du + s[kRowCentreSlope] * dy;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  const vf lo = simd::group4_min(simd::select(row_hit, centre - half_width, simd::splat(kInf)));
  const vf hi = simd::group4_max(simd::select(row_hit, centre + half_width, simd::splat(-kInf)));
  return simd::bits(simd::less_equal(lo, kBlockLastColumn) &
                    simd::greater_equal(hi, kBlockFirstColumn));
}

// Pops the lowest set bit of `mask` and returns its index.
template <typename Bits>
inline int pop_bit(Bits& mask) {
  const int bit = std::countr_zero(mask);
  mask &= mask - 1;
  return bit;
}

// Intersections ahead of the current one whose records are prefetched: the records are scattered
// over the packed array, so the loop would otherwise wait on one cache miss at a time.
constexpr int kPrefetchDistance = 32;

// A tile and its depth-ordered list of Gaussians.
struct TileList {
  int x0 = 0, y0 = 0, rows = 0, columns = 0, count = 0;
  std::int32_t begin = 0;                  // the tile's first intersection
  const std::int32_t* gaussian = nullptr;  // [count] Gaussian index of each list entry
  const Context* ctx = nullptr;

  TileList(const Context& context, int tile) : ctx(&context) {
    const int tx = tile % ctx->bins->tiles_x, ty = tile / ctx->bins->tiles_x;
    x0 = tx * kTileSize;
    y0 = ty * kTileSize;
    rows = std::min(kTileSize, ctx->in->height - y0);
    columns = std::min(kTileSize, ctx->in->width - x0);
    begin = ctx->bins->isect_offsets[tile];
    count = ctx->bins->isect_offsets[tile + 1] - begin;
    gaussian = &ctx->bins->gaussian_from_isect[begin];
  }

  const float* splat(int k) const { return ctx->splat(gaussian[k]); }
  // The record's first and last cache lines: a record with more than 6 features (+ depth) spans
  // two (the lines between, from 23 on, are left to the hardware prefetcher).
  void prefetch(int k) const {
    if (k < 0 || k >= count) return;
    const float* s = splat(k);
    simd::prefetch(s);
    if (ctx->stride > kLanes) simd::prefetch(s + ctx->stride - 1);
  }

  // The centre of Gaussian s relative to the tile's first pixel centre (footprint_blocks).
  float du(const float* s) const { return s[kU] - (float(x0) + 0.5f); }
  float dv(const float* s) const { return s[kV] - (float(y0) + 0.5f); }

  // Pixel centres of block b's lanes (exact: integers + 1/2).
  vf pixel_x(int block) const {
    return (float(x0) + 0.5f + float(block % kBlocksPerSide * kBlockSide)) + kLaneColumn;
  }
  vf pixel_y(int block) const {
    return (float(y0) + 0.5f + float(block / kBlocksPerSide * kBlockSide)) + kLaneRow;
  }

  // Lanes of block b whose pixel is inside the image.
  simd::mask pixels_in_image(int block) const {
    const vf column = kLaneColumn + float(block % kBlocksPerSide * kBlockSide);
    const vf row = kLaneRow + float(block / kBlocksPerSide * kBlockSide);
    return simd::less(column, simd::splat(float(columns))) &
           simd::less(row, simd::splat(float(rows)));
  }
};

// log2_alpha (formulas.hpp) of a packed record.
inline vf record_log2_alpha(const float* s, vf dx, vf dy) {
  return log2_alpha(simd::splat(s[kHalfA]), simd::splat(s[kB]), simd::splat(s[kHalfC]),
                    simd::splat(s[kLog2Opacity]), dx, dy);
}

// Compositing rule constants as vectors (both stop rules are one `<` comparison: stop_below).
struct Rule {
  vf alpha_clamp, min_alpha, stop_below;
  explicit Rule(const RenderOptions& o)
      : alpha_clamp(simd::splat(o.alpha_clamp)),
        min_alpha(simd::splat(o.min_alpha)),
        stop_below(simd::splat(render::stop_below(o))) {}
};

// Per-pixel state of a tile, one vector per block; channel planes are [channel][block].
struct TileState {
  std::vector<vf> transmittance, channel_a, channel_b;  // [16], [C', 16], [C', 16]
  std::vector<vi> last, count;                          // [16]
  std::vector<simd::mask> alive;                        // [16]
  std::vector<vf> chunk_records;                        // [kChunk, stride / 16] (forward)

  void reset(int channels) {
    transmittance.assign(kBlocks, vf{});
    channel_a.assign(std::size_t(channels) * kBlocks, vf{});
    channel_b.assign(std::size_t(channels) * kBlocks, vf{});
    last.assign(kBlocks, vi{});
    count.assign(kBlocks, vi{});
    alive.assign(kBlocks, simd::mask{});
  }
};

// The lane values of a block-major state array, [16 blocks, 16 lanes] flattened.
template <typename V>
auto* lanes_of(std::vector<V>& v) {
  return reinterpret_cast<std::remove_reference_t<decltype(v[0][0])>*>(v.data());
}

// Intersections whose footprints are found together; each block then runs over its members of
// the chunk with its state in registers. 64: one bit per entry in a block's member mask, and the
// chunk's records (4 KB for C <= 6) stay in L1 while the 16 blocks read them.
constexpr int kChunk = 64;

// members[b] bit j = footprint[j] has block b, for j < n (the transposed 64 x 16 bit matrix).
inline void block_members(const std::uint16_t* footprint, int n,
                          std::uint64_t (&members)[kBlocks]) {
#if defined(__AVX512BW__)
  alignas(64) std::uint16_t padded[kChunk] = {};
  std::copy(footprint, footprint + n, padded);
  const __m512i low = _mm512_load_si512(padded), high = _mm512_load_si512(padded + 32);
  for (int b = 0; b < kBlocks; ++b) {
    const __m512i bit = _mm512_set1_epi16(short(1 << b));
    members[b] = std::uint64_t(_mm512_test_epi16_mask(low, bit)) |
                 std::uint64_t(_mm512_test_epi16_mask(high, bit)) << 32;
  }
#else
  for (int b = 0; b < kBlocks; ++b) {
    std::uint64_t m = 0;
    for (int j = 0; j < n; ++j) m |= std::uint64_t(footprint[j] >> b & 1) << j;
    members[b] = m;
  }
#endif
}

// Front to back over the tile's list, a chunk at a time: the footprints of the chunk's Gaussians
// first, then each block that still has live pixels composites the chunk's Gaussians that reach
// it, with its pixel state in registers, until its pixels saturate. Per pixel this is the same
// sequence of operations as one Gaussian at a time over the whole tile, so the same bits.
template <int kC>
void forward_tile(const Context& ctx, const Rule& rule, const TileList& list, TileState& st,
                  BlendOutput& out) {
  const int channels = kC > 0 ? kC : ctx.channels_ext;
  const int c_image = ctx.in->channels, width = ctx.in->width;
  // The record stride, a compile-time constant when the channel count is.
  const int stride = kC > 0 ? record_stride(kC) : ctx.stride;
  st.reset(channels);
  st.chunk_records.resize(std::size_t(kChunk) * stride / kLanes);
  std::uint32_t live_blocks = 0;
  for (int block = 0; block < kBlocks; ++block) {
    st.transmittance[block] = simd::splat(1.0f);
    st.alive[block] = list.pixels_in_image(block);
    live_blocks |= std::uint32_t(simd::any(st.alive[block])) << block;
  }
  for (int k = 0; k < kPrefetchDistance; ++k) list.prefetch(k);
  std::uint16_t* footprint = out.footprint_blocks.data() + list.begin;  // [count]
  for (int chunk = 0; chunk < list.count && live_blocks; chunk += kChunk) {
    const int n = std::min(kChunk, list.count - chunk);
    // The chunk's records are copied next to each other: the blend then finds entry j at
    // records + j * stride, without the index load and multiply that the scattered records need
    // (the blend's time goes into each pair's dependency chain, and this shortens it).
    float* records = lanes_of(st.chunk_records);  // [kChunk, stride]
    for (int j = 0; j < n; ++j) {
      list.prefetch(chunk + j + kPrefetchDistance);
      const float* s = list.splat(chunk + j);
      std::memcpy(records + j * stride, s, stride * sizeof(float));
      footprint[chunk + j] = std::uint16_t(footprint_blocks(s, list.du(s), list.dv(s)));
    }
    std::uint64_t members[kBlocks];
    block_members(footprint + chunk, n, members);
    for (std::uint32_t todo = live_blocks; todo;) {
      const int block = pop_bit(todo);
      std::uint64_t member = members[block];
      if (!member) continue;
      // The block's state, in registers for the loop.
      vf t = st.transmittance[block];
      vi last = st.last[block], count = st.count[block];
      simd::mask alive = st.alive[block];
      vf acc_fixed[kC > 0 ? kC : 1];
      vf* acc = kC > 0 ? acc_fixed : st.channel_b.data();  // [C']
      for (int c = 0; c < channels; ++c) acc[c] = st.channel_a[c * kBlocks + block];
      const vf px = list.pixel_x(block), py = list.pixel_y(block);
      // Software-pipelined two entries ahead: (j1, alpha1) and (j2, alpha2) are the next entries
      // with their alphas computed, in program order before the current entry is composited, so
      // that their chains are under way while the compositing waits on the current one. Two is
      // the depth kept: a third, held in an array, is slower.
      const auto alpha_of = [&](int j) {
        const float* s = records + j * stride;
        return simd::min(rule.alpha_clamp,
                         simd::exp2(record_log2_alpha(s, s[kU] - px, s[kV] - py)));
      };
      int j1 = pop_bit(member), j2 = 0;
      vf alpha1 = alpha_of(j1), alpha2{};
      bool has2 = member != 0;
      if (has2) {
        j2 = pop_bit(member);
        alpha2 = alpha_of(j2);
      }
      for (bool more = true; more;) {
        const int j = j1, k = chunk + j;
        const float* s = records + j * stride;
        const vf alpha = alpha1;
        more = has2;
        j1 = j2;
        alpha1 = alpha2;
        has2 = member != 0;
        if (has2) {
          j2 = pop_bit(member);
          alpha2 = alpha_of(j2);
        }
        const simd::mask composite = alive & simd::greater_equal(alpha, rule.min_alpha);
        const vf next_t = t - alpha * t;
        const simd::mask stop = composite & simd::less(next_t, rule.stop_below);
        const simd::mask add = simd::and_not(composite, stop);
        const vf weight = simd::mul_or_zero(add, alpha, t);
        for (int c = 0; c < channels; ++c) acc[c] += weight * s[kHeader + c];
        t = simd::select(add, next_t, t);
        last = simd::select(add, simd::splat_int(k + 1), last);
        count = simd::count_if(count, add);
        alive = simd::and_not(alive, stop);
        // Checked only when a pixel saturated (rare, so well predicted).
        if (simd::any(stop) && !simd::any(alive)) break;
      }
      if (!simd::any(alive)) live_blocks &= ~(1u << block);
      st.transmittance[block] = t;
      st.last[block] = last;
      st.count[block] = count;
      st.alive[block] = alive;
      for (int c = 0; c < channels; ++c) st.channel_a[c * kBlocks + block] = acc[c];
    }
  }
  const float* t = lanes_of(st.transmittance);
  const std::int32_t* last = lanes_of(st.last);
  const std::int32_t* count = lanes_of(st.count);
  const float* value = lanes_of(st.channel_a);  // [C', 16 blocks x 16 lanes]
  constexpr int kPlane = kBlocks * kLanes;
  for (int row = 0; row < list.rows; ++row) {
    for (int column = 0; column < list.columns; ++column) {
      const int i = state_index(row, column);
      const std::size_t pixel = std::size_t(list.y0 + row) * width + list.x0 + column;
      simd::store_stream(&out.final_T[pixel], t[i]);
      simd::store_stream(&out.alpha[pixel], 1.0f - t[i]);
      simd::store_stream(&out.last_contributor[pixel], last[i]);
      simd::store_stream(&out.n_contrib[pixel], count[i]);
      for (int c = 0; c < c_image; ++c)
        simd::store_stream(&out.image.data[pixel * c_image + c],
                           value[c * kPlane + i] + t[i] * ctx.background[c]);
      if (ctx.options->render_depth)
        simd::store_stream(&out.depth[pixel], value[c_image * kPlane + i]);
    }
  }
}

// Layout of a row of the per-thread gradient buffers.
enum GradField { kGradU, kGradV, kGradA, kGradB, kGradC, kGradOpacity, kGradHeader };

// Back to front over the tile's list from its last contributor; each Gaussian visits the blocks
// of its footprint that have pixels it contributed to, accumulating its gradient in registers.
template <int kC>
void backward_tile(const Context& ctx, const Rule& rule, const TileList& list,
                   const BlendOutput& fwd, const float* v_image, const float* v_alpha,
                   const float* v_depth, TileState& st, float* grad_buffer) {
  const int channels = kC > 0 ? kC : ctx.channels_ext;
  const int c_image = ctx.in->channels, width = ctx.in->width;
  const int grad_stride = kGradHeader + ctx.channels_ext;
  st.reset(channels);
  vf* v_out = st.channel_b.data();  // [C', 16] upstream gradient of each channel
  // v_alpha_out T_final - v_behind per pixel, with v_behind = sum_c v_out_c behind_c and
  // behind_c = what the Gaussians behind the current one and the background add to channel c.
  // Kept as one value per pixel: compositing a Gaussian subtracts weight * sum_c v_out_c f_c.
  vf* v_final_minus_behind = st.channel_a.data();  // [16]
  {
    float* t = lanes_of(st.transmittance);
    float* v_out_lanes = lanes_of(st.channel_b);  // [C', 16 blocks x 16 lanes]
    float* v_final_minus_behind_lanes = lanes_of(st.channel_a);
    std::int32_t* last = lanes_of(st.last);
    constexpr int kPlane = kBlocks * kLanes;
    for (int row = 0; row < list.rows; ++row) {
      for (int column = 0; column < list.columns; ++column) {
        const int i = state_index(row, column);
        const std::size_t pixel = std::size_t(list.y0 + row) * width + list.x0 + column;
        t[i] = fwd.final_T[pixel];
        float v_bg = 0.0f;
        for (int c = 0; c < c_image; ++c) {
          const float v = v_image[pixel * c_image + c];
          v_out_lanes[c * kPlane + i] = v;
          v_bg += v * ctx.background[c];
        }
        if (ctx.options->render_depth && v_depth)
          v_out_lanes[c_image * kPlane + i] = v_depth[pixel];
        v_final_minus_behind_lanes[i] = (v_alpha ? v_alpha[pixel] * t[i] : 0.0f) - t[i] * v_bg;
        last[i] = fwd.last_contributor[pixel];
      }
    }
  }
  vf px[kBlocks], py[kBlocks];  // pixel centres of each block's lanes
  for (int block = 0; block < kBlocks; ++block) {
    px[block] = list.pixel_x(block);
    py[block] = list.pixel_y(block);
  }
  vi block_last{};  // [16 blocks] largest last contributor of each block
  for (int block = 0; block < kBlocks; ++block)
    block_last[block] = simd::reduce_max(st.last[block]);
  const std::int32_t max_last = simd::reduce_max(block_last);

  vf v_feat_fixed[kC > 0 ? kC : 1];
  std::vector<vf> v_feat_dynamic(kC > 0 ? 0 : channels);
  vf* v_feat = kC > 0 ? v_feat_fixed : v_feat_dynamic.data();
  // Locals (the stores to the state and the buffer could alias the context's fields otherwise,
  // and each would be reloaded per entry); the record stride a compile-time constant when the
  // channel count is.
  const float* const packed = ctx.packed;
  const std::int32_t* const gaussian = list.gaussian;
  const int stride = kC > 0 ? record_stride(kC) : ctx.stride;
  const std::uint16_t* const footprint = fwd.footprint_blocks.data() + list.begin;  // [count]
  const auto record = [&](int k) { return packed + std::size_t(gaussian[k]) * stride; };
  // The Gaussian's record and its row of the gradient buffer are both scattered in memory; a row
  // (grad_stride floats, not padded) may straddle two cache lines: both are fetched.
  const auto prefetch = [&](int k) {
    if (k < 0) return;
    const float* s = record(k);
    simd::prefetch(s);
    if (stride > kLanes) simd::prefetch(s + stride - 1);
    const float* row = grad_buffer + std::size_t(gaussian[k]) * grad_stride;
    simd::prefetch(row);
    simd::prefetch(row + grad_stride - 1);
  };
  for (int k = max_last - 1; k >= max_last - 1 - kPrefetchDistance; --k) prefetch(k);
  for (int k = max_last - 1; k >= 0; --k) {
    prefetch(k - kPrefetchDistance);
    std::uint32_t todo = simd::bits(simd::less(simd::splat_int(k), block_last)) & footprint[k];
    if (!todo) continue;
    const float* s = record(k);
    const float a = 2.0f * kLn2 * s[kHalfA], b = kLn2 * s[kB], c_conic = 2.0f * kLn2 * s[kHalfC];
    // With w = d loss / d alpha_raw * alpha_raw = -d loss / d sigma per pixel, the gradient is
    // sum w, sum w dx, sum w dy, sum w dx^2, sum w dx dy, sum w dy^2 (combined after the loop).
    SigmaSumsT<vf> sums_of{};
    for (int c = 0; c < channels; ++c) v_feat[c] = vf{};
    const vi index = simd::splat_int(k);
    // The record as vectors, once per Gaussian (the state stores below may alias it otherwise).
    const vf u = simd::splat(s[kU]), v = simd::splat(s[kV]);
    const vf half_a = simd::splat(s[kHalfA]), b_conic = simd::splat(s[kB]),
             half_c = simd::splat(s[kHalfC]);
    const vf log2_opacity = simd::splat(s[kLog2Opacity]);
    vf feature_fixed[kC > 0 ? kC : 1];
    if constexpr (kC > 0)
      for (int c = 0; c < kC; ++c) feature_fixed[c] = simd::splat(s[kHeader + c]);
    // The alphas of all the blocks first: independent chains that overlap, and the second loop
    // then starts from them.
    vf alpha_raw_of[kBlocks];
    for (std::uint32_t first = todo; first;) {
      const int block = pop_bit(first);
      alpha_raw_of[block] = simd::exp2(
          log2_alpha(half_a, b_conic, half_c, log2_opacity, u - px[block], v - py[block]));
    }
    while (todo) {
      const int block = pop_bit(todo);
      const vf dx = u - px[block], dy = v - py[block];
      const vf alpha_raw = alpha_raw_of[block];
      const vf alpha = simd::min(rule.alpha_clamp, alpha_raw);
      const simd::mask composite =
          simd::less(index, st.last[block]) & simd::greater_equal(alpha, rule.min_alpha);
      const vf inv_one_minus = simd::reciprocal(1.0f - alpha);
      // T in front of this Gaussian, recovered from T behind it.
      const vf t =
          simd::select(composite, st.transmittance[block] * inv_one_minus, st.transmittance[block]);
      st.transmittance[block] = t;
      const vf weight = simd::mul_or_zero(composite, alpha, t);
      vf v_out_dot_f{};  // sum_c v_out_c f_c
      for (int c = 0; c < channels; ++c) {
        const vf v_o = v_out[c * kBlocks + block];
        v_feat[c] += weight * v_o;
        v_out_dot_f += v_o * (kC > 0 ? feature_fixed[c] : simd::splat(s[kHeader + c]));
      }
      // d out_c / d alpha = f_c T - behind_c / (1 - alpha); d alpha_out / d alpha = T_f / (1-alpha)
      const vf v_alpha_px = v_out_dot_f * t + v_final_minus_behind[block] * inv_one_minus;
      v_final_minus_behind[block] -= weight * v_out_dot_f;
      // alpha = opacity * G unless clamped (then no gradient flows), G = exp(-sigma):
      // d alpha / d opacity = G, d alpha / d sigma = -alpha.
      const simd::mask unclamped = composite & simd::less_equal(alpha_raw, rule.alpha_clamp);
      sigma_vjp_accumulate(simd::mul_or_zero(unclamped, alpha_raw, v_alpha_px), dx, dy, sums_of);
    }
    // d sigma / d (u, v) = (a dx + b dy, b dx + c dy); d sigma / d (a, b, c) = (dx^2 / 2, dx dy,
    // dy^2 / 2); d alpha_raw / d opacity = alpha_raw / opacity.
    const vf sums =
        simd::sum8({sums_of.w, sums_of.w_dx, sums_of.w_dy, sums_of.w_dx2, sums_of.w_dxdy,
                    sums_of.w_dy2, v_feat[0], channels > 1 ? v_feat[1] : vf{}});
    const float conic[3] = {a, b, c_conic};
    float v_mean2d[2], v_conic[3];
    sigma_vjp_combine(conic, sums[1], sums[2], sums[3], sums[4], sums[5], v_mean2d, v_conic);
    float* g = grad_buffer + std::size_t(gaussian[k]) * grad_stride;
    g[kGradU] += v_mean2d[0];
    g[kGradV] += v_mean2d[1];
    g[kGradA] += v_conic[0];
    g[kGradB] += v_conic[1];
    g[kGradC] += v_conic[2];
    g[kGradOpacity] += sums[0] / s[kOpacity];
    for (int c = 0; c < channels; ++c)
      g[kGradHeader + c] += c < 2 ? sums[6 + c] : simd::sum(v_feat[c]);
  }
}

// Calls f.template operator()<kC>() with kC = the channel count when it has a compiled kernel,
// else 0 (the run-time channel loop).
template <typename F>
void dispatch_channels(int channels, F&& f) {
  switch (channels) {
    case 1:
      return f.template operator()<1>();
    case 2:
      return f.template operator()<2>();
    case 3:
      return f.template operator()<3>();
    case 4:
      return f.template operator()<4>();
    case 5:
      return f.template operator()<5>();
    case 6:
      return f.template operator()<6>();
    case 7:
      return f.template operator()<7>();
    case 8:
      return f.template operator()<8>();
    default:
      return f.template operator()<0>();
  }
}
static_assert(kMaxStaticChannels == 8, "dispatch_channels lists 1..kMaxStaticChannels");

void check_inputs(const BlendInputs& in, const TileBins& bins) {
  if (!in.projected) fail("blend: projected Gaussians are required");
  if (in.projected->size() > 0 && (!in.opacities || !in.features))
    fail("blend: opacities and features are required");
  if (in.channels < 1) fail("blend: channel count must be >= 1, got {}", in.channels);
  if (in.width < 1 || in.height < 1) fail("blend: image size {}x{} is empty", in.width, in.height);
  if (bins.tiles_x != tile_count(in.width) || bins.tiles_y != tile_count(in.height))
    fail("blend: tile bins ({}x{} tiles) do not match the {}x{} image", bins.tiles_x, bins.tiles_y,
         in.width, in.height);
}

// The backward's tiles split into one contiguous run (row-major) per thread, of about equal work:
// first_tile[t] .. first_tile[t + 1] - 1 are thread t's. The work of a tile is estimated as the
// pairs it composited (the forward's n_contrib) plus kPixelCost per pixel for its setup and
// writeback. Deterministic for a given forward and thread count.
std::vector<int> balanced_tile_runs(const BlendOutput& forward, const TileBins& bins, int width,
                                    int height, int threads) {
  constexpr std::int64_t kPixelCost = 4;
  std::vector<std::int64_t> cost(bins.num_tiles() + 1, 0);  // [tiles + 1] prefix sums
#pragma omp parallel for schedule(static)
  for (int ty = 0; ty < bins.tiles_y; ++ty)
    for (int y = ty * kTileSize; y < std::min(height, (ty + 1) * kTileSize); ++y)
      for (int x = 0; x < width; ++x)
        cost[ty * bins.tiles_x + x / kTileSize + 1] +=
            forward.n_contrib[std::size_t(y) * width + x] + kPixelCost;
  for (int tile = 0; tile < bins.num_tiles(); ++tile) cost[tile + 1] += cost[tile];
  std::vector<int> first_tile(threads + 1, bins.num_tiles());
  for (int t = 0; t < threads; ++t) {
    const std::int64_t target = cost.back() * t / threads;
    first_tile[t] = int(std::lower_bound(cost.begin(), cost.end() - 1, target) - cost.begin());
  }
  return first_tile;
}

}  // namespace

BlendOutput blend_forward(const BlendInputs& in, const TileBins& bins,
                          const RenderOptions& options) {
  BlendOutput out;
  blend_forward(in, bins, options, out);
  return out;
}

void blend_forward(const BlendInputs& in, const TileBins& bins, const RenderOptions& options,
                   BlendOutput& out) {
  check_inputs(in, bins);
  Context ctx(in, bins, options, nullptr, std::move(out.records));
  const Rule rule(options);
  const std::size_t pixels = std::size_t(in.width) * in.height;
  // Left unset here: every tile writes all its pixels.
  out.image.width = in.width, out.image.height = in.height, out.image.channels = in.channels;
  out.image.data.resize(pixels * in.channels);
  out.alpha.resize(pixels);
  if (options.render_depth) out.depth.resize(pixels);
  out.final_T.resize(pixels);
  out.last_contributor.resize(pixels);
  out.n_contrib.resize(pixels);
  out.footprint_blocks.resize(bins.num_intersections());
  dispatch_channels(ctx.channels_ext, [&]<int kC>() {
#pragma omp parallel
    {
      const simd::FlushDenormals flush;
      TileState state;
      // Results do not depend on which thread draws which tile: dynamic balances the load.
#pragma omp for schedule(dynamic, 1) nowait
      for (int tile = 0; tile < bins.num_tiles(); ++tile) {
        forward_tile<kC>(ctx, rule, TileList(ctx, tile), state, out);
      }
      simd::stream_fence();  // before the region's closing barrier publishes the outputs
    }
  });
  out.records = std::move(ctx.records);  // the buffer moves: ctx.packed is not used again
}

void blend_backward(const BlendInputs& in, const TileBins& bins, const RenderOptions& options,
                    const BlendOutput& forward, const float* v_image, const float* v_alpha,
                    const float* v_depth, GaussianGrads& grads) {
  UninitVector<float> sums;
  blend_backward(in, bins, options, forward, v_image, v_alpha, v_depth, grads, sums);
}

void blend_backward(const BlendInputs& in, const TileBins& bins, const RenderOptions& options,
                    const BlendOutput& forward, const float* v_image, const float* v_alpha,
                    const float* v_depth, GaussianGrads& grads, UninitVector<float>& buffers) {
  check_inputs(in, bins);
  if (!v_image) fail("blend_backward: v_image is required");
  if (v_depth && !options.render_depth)
    fail("blend_backward: v_depth given but the forward did not render depth");
  if (forward.footprint_blocks.size() != bins.num_intersections() ||
      forward.n_contrib.size() != std::size_t(in.width) * in.height)
    fail("blend_backward: the saved forward does not match these tile bins");
  const Context ctx(in, bins, options, &forward.records);
  const Rule rule(options);
  const std::size_t n = in.projected->size();
  const int c = in.channels;
  const int grad_stride = kGradHeader + ctx.channels_ext;
  const int threads = omp_get_max_threads();
  // [threads, N, grad_stride]: each thread owns a fixed run of tiles and sums into its own
  // buffer, so the order of every sum is fixed by the thread count alone. Runs of neighbouring
  // tiles rather than every threads-th tile: a thread then writes the rows of the Gaussians of its
  // part of the image only (with round-robin tiles every thread would write nearly every row,
  // scattered over its whole buffer). Left uninitialised here and zeroed by its own thread (in
  // parallel, and first touch puts the pages near that thread).
  const std::size_t buffer_size = n * grad_stride;
  buffers.resize(threads * buffer_size);
  const std::vector<int> first_tile =
      balanced_tile_runs(forward, bins, in.width, in.height, threads);
  dispatch_channels(ctx.channels_ext, [&]<int kC>() {
#pragma omp parallel num_threads(threads)
    {
      const simd::FlushDenormals flush;
      TileState state;
      // Run r sums into buffer r (all runs are done should the runtime start fewer threads).
      for (int run = omp_get_thread_num(); run < threads; run += omp_get_num_threads()) {
        float* buffer = &buffers[run * buffer_size];
        std::fill(buffer, buffer + buffer_size, 0.0f);
        for (int tile = first_tile[run]; tile < first_tile[run + 1]; ++tile)
          backward_tile<kC>(ctx, rule, TileList(ctx, tile), forward, v_image, v_alpha, v_depth,
                            state, buffer);
      }
    }
  });

  grads.channels = c;
  // Every row is written below.
  grads.v_means2d.resize(2 * n);
  grads.v_conics.resize(3 * n);
  grads.v_opacities.resize(n);
  grads.v_features.resize(n * c);
  grads.v_depths.resize(n);
  // The buffers are summed into the first, in thread order (0 + b0 + b1 + ... as bits), as
  // contiguous arrays; then its rows are split into the outputs. (Summing row by row into a small
  // array on the stack stalled each row on store forwarding: ~2 ms of the 50k-Gaussian scene.)
  float* total = buffers.data();
#pragma omp parallel
  {
    for (int t = 1; t < threads; ++t) {
      const float* other = &buffers[t * buffer_size];
#pragma omp for schedule(static)
      for (std::ptrdiff_t i = 0; i < std::ptrdiff_t(buffer_size); ++i) total[i] += other[i];
    }
#pragma omp for schedule(static)
    for (std::ptrdiff_t g = 0; g < std::ptrdiff_t(n); ++g) {
      const float* row = &total[g * grad_stride];
      grads.v_means2d[2 * g] = row[kGradU];
      grads.v_means2d[2 * g + 1] = row[kGradV];
      grads.v_conics[3 * g] = row[kGradA];
      grads.v_conics[3 * g + 1] = row[kGradB];
      grads.v_conics[3 * g + 2] = row[kGradC];
      grads.v_opacities[g] = row[kGradOpacity];
      std::copy(row + kGradHeader, row + kGradHeader + c, &grads.v_features[g * c]);
      grads.v_depths[g] = options.render_depth ? row[kGradHeader + c] : 0.0f;
    }
  }
}

}  // namespace retimegs::render
