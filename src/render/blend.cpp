// Stage 3: tile-based front-to-back compositing and its back-to-front vector-Jacobian product.
//
// Each tile row of 16 pixels is one simd::vf; a tile's per-pixel state (16 vectors per quantity)
// stays in L1. The forward walks the tile's depth-ordered list front to back and updates, per
// Gaussian, only the rows that its alpha >= min_alpha ellipse reaches; the backward walks it back
// to front from the last contributor, accumulating each Gaussian's gradient in registers over
// those rows, then adds it to the thread's gradient buffer.
//
// Threads: tiles are independent in the forward (dynamic schedule). The backward uses a static
// round-robin tile schedule and one gradient buffer per thread, summed in thread order, so that
// a given thread count always gives the same bits.
#include "retimegs/render/blend.hpp"

#include <omp.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <memory>
#include <vector>

#include "retimegs/core/error.hpp"
#include "simd.hpp"

namespace retimegs::render {
namespace {

using simd::vf;
using simd::vi;
constexpr int kLanes = simd::kLanes;
static_assert(kLanes == kTileSize, "one vector per tile row");
constexpr int kMaxStaticChannels = 8;  // channel counts (with depth) that get a compiled kernel

// One 2-D Gaussian packed for the blend: header, then its features (+ depth).
// kExtentV: half-height of the region where alpha >= min_alpha (alpha_extent).
enum Field { kU, kV, kHalfA, kB, kHalfC, kOpacity, kLog2Opacity, kExtentV, kHeader };

// The blend's view of the inputs, shared by forward and backward.
struct Context {
  const BlendInputs* in;
  const TileBins* bins;
  const RenderOptions* options;
  int channels_ext;               // C (+ 1 when depth is composited)
  int stride;                     // kHeader + channels_ext, rounded up to whole cache lines
  std::vector<vf> packed;         // [N, stride] floats, 64-byte aligned
  std::vector<float> background;  // [channels_ext]

  Context(const BlendInputs& blend_in, const TileBins& tile_bins, const RenderOptions& opts)
      : in(&blend_in), bins(&tile_bins), options(&opts) {
    const Projected& p = *in->projected;
    const int c = in->channels;
    channels_ext = c + (options->render_depth ? 1 : 0);
    stride = (kHeader + channels_ext + kLanes - 1) / kLanes * kLanes;
    background.assign(channels_ext, 0.0f);
    if (in->background) std::copy(in->background, in->background + c, background.begin());
    const std::size_t n = p.size();
    packed.resize(n * stride / kLanes);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t g = 0; g < std::ptrdiff_t(n); ++g) {
      if (p.radii[g] <= 0) continue;
      float* s = reinterpret_cast<float*>(packed.data()) + g * stride;
      s[kU] = p.means2d[2 * g];
      s[kV] = p.means2d[2 * g + 1];
      s[kHalfA] = 0.5f * p.conics[3 * g];
      s[kB] = p.conics[3 * g + 1];
      s[kHalfC] = 0.5f * p.conics[3 * g + 2];
      s[kOpacity] = in->opacities[g];
      s[kLog2Opacity] = std::log2(in->opacities[g]);
      s[kExtentV] = alpha_extent(&p.conics[3 * g], in->opacities[g], *options)[1];
      std::copy(in->features + g * c, in->features + (g + 1) * c, s + kHeader);
      if (options->render_depth) s[kHeader + c] = p.depths[g];
    }
  }

  const float* splat(std::int32_t g) const {
    return reinterpret_cast<const float*>(packed.data()) + std::size_t(g) * stride;
  }
};

// Bits [begin, end) of a row mask, 0 <= begin < end <= 16.
inline std::uint32_t rows_between(int begin, int end) {
  return ((1u << end) - 1u) & ~((1u << begin) - 1u);
}

// Intersections ahead of the current one whose records are prefetched: the records are scattered
// over the packed array, so the loop would otherwise wait on one cache miss at a time.
constexpr int kPrefetchDistance = 32;

// A tile and its depth-ordered list of Gaussians.
struct TileList {
  int x0 = 0, y0 = 0, rows = 0, count = 0;
  vf px;                                   // pixel-centre u of each lane
  const std::int32_t* gaussian = nullptr;  // [count] Gaussian index of each list entry
  const Context* ctx = nullptr;

  TileList(const Context& context, int tile) : ctx(&context) {
    const int tx = tile % ctx->bins->tiles_x, ty = tile / ctx->bins->tiles_x;
    x0 = tx * kTileSize;
    y0 = ty * kTileSize;
    rows = std::min(kTileSize, ctx->in->height - y0);
    for (int l = 0; l < kLanes; ++l) px[l] = float(x0 + l) + 0.5f;
    const std::int32_t begin = ctx->bins->isect_offsets[tile];
    count = ctx->bins->isect_offsets[tile + 1] - begin;
    gaussian = &ctx->bins->gaussian_from_isect[begin];
  }

  const float* splat(int k) const { return ctx->splat(gaussian[k]); }
  void prefetch(int k) const {
    if (k >= 0 && k < count) simd::prefetch(splat(k));
  }

  // Rows of the tile whose centre y0 + row + 0.5 is within the Gaussian's extent: |v - y| <= e.
  std::uint32_t row_mask(const float* s) const {
    const float lo = s[kV] - s[kExtentV] - float(y0) - 0.5f;
    const float hi = s[kV] + s[kExtentV] - float(y0) - 0.5f;
    const int row_begin = lo <= 0.0f ? 0 : int(std::min(std::ceil(lo), float(kTileSize)));
    const int row_end = hi < 0.0f ? 0 : int(std::min(std::floor(hi) + 1.0f, float(rows)));
    return row_end > row_begin ? rows_between(row_begin, row_end) : 0u;
  }
};

// Compositing rule constants as vectors. Both stop rules become one `<` comparison:
// T' <= t  <=>  T' < nextafter(t, +inf) for floats.
struct Rule {
  vf alpha_clamp, min_alpha, stop_below;
  explicit Rule(const RenderOptions& o)
      : alpha_clamp(simd::splat(o.alpha_clamp)),
        min_alpha(simd::splat(o.min_alpha)),
        stop_below(simd::splat(o.stop_rule == StopRule::kAtOrBelow
                                   ? std::nextafter(o.min_transmittance, INFINITY)
                                   : o.min_transmittance)) {}
};

// sigma = 0.5 (a dx^2 + c dy^2) + b dx dy with dx = u - px, dy = v - py (gsplat's convention),
// split into the part that is the same for every row of a tile and the per-row rest. sigma >= 0
// for a positive-definite conic, so (unlike gsplat) there is no sigma < 0 test.
struct RowInvariant {
  vf dx, half_a_dx2, b_dx;
  RowInvariant(const float* s, vf px)
      : dx(s[kU] - px), half_a_dx2(s[kHalfA] * dx * dx), b_dx(s[kB] * dx) {}
  vf sigma(const float* s, float dy) const { return half_a_dx2 + b_dx * dy + s[kHalfC] * dy * dy; }
};

// Pops the lowest set bit of `mask` and returns its index.
inline int pop_row(std::uint32_t& mask) {
  const int row = std::countr_zero(mask);
  mask &= mask - 1;
  return row;
}

// Per-pixel state of a tile, one vector per row; channel planes are [channel][row].
struct TileState {
  std::vector<vf> transmittance, channel_a, channel_b;  // [16], [C', 16], [C', 16]
  std::vector<vf> v_alpha_final_t;                      // [16]
  std::vector<vi> last, count;                          // [16]
  std::vector<simd::mask> alive;                        // [16]

  void reset(int channels) {
    transmittance.assign(kTileSize, vf{});
    channel_a.assign(std::size_t(channels) * kTileSize, vf{});
    channel_b.assign(std::size_t(channels) * kTileSize, vf{});
    v_alpha_final_t.assign(kTileSize, vf{});
    last.assign(kTileSize, vi{});
    count.assign(kTileSize, vi{});
    alive.assign(kTileSize, simd::mask{});
  }
};

// Front to back over the tile's list; each Gaussian updates the rows it can reach that still
// have live pixels, without data-dependent branches inside a row update.
template <int kC>
void forward_tile(const Context& ctx, const Rule& rule, const TileList& list, TileState& st,
                  BlendOutput& out) {
  const int channels = kC > 0 ? kC : ctx.channels_ext;
  const int c_image = ctx.in->channels, width = ctx.in->width;
  st.reset(channels);
  vf* acc = st.channel_a.data();  // [C', 16] sum of f alpha T
  const simd::mask lanes_in_image = simd::lanes_below(std::min(kLanes, width - list.x0));
  for (int row = 0; row < list.rows; ++row) {
    st.transmittance[row] = simd::splat(1.0f);
    st.alive[row] = lanes_in_image;
  }
  std::uint32_t live_rows = list.rows > 0 ? rows_between(0, list.rows) : 0u;
  for (int k = 0; k < kPrefetchDistance; ++k) list.prefetch(k);
  for (int k = 0; k < list.count && live_rows; ++k) {
    list.prefetch(k + kPrefetchDistance);
    const float* s = list.splat(k);
    std::uint32_t todo = live_rows & list.row_mask(s);
    if (!todo) continue;
    const RowInvariant inv(s, list.px);
    const vi index = simd::splat_int(k + 1);
    while (todo) {
      const int row = pop_row(todo);
      const float dy = s[kV] - (float(list.y0 + row) + 0.5f);
      const vf alpha_raw = simd::opacity_times_exp_neg(inv.sigma(s, dy), s[kLog2Opacity]);
      const vf alpha = simd::min(rule.alpha_clamp, alpha_raw);
      const simd::mask composite = st.alive[row] & simd::greater_equal(alpha, rule.min_alpha);
      const vf t = st.transmittance[row];
      const vf next_t = t * (1.0f - alpha);
      const simd::mask stop = composite & simd::less(next_t, rule.stop_below);
      const simd::mask add = simd::and_not(composite, stop);
      const vf weight = simd::mul_or_zero(add, alpha, t);
      for (int c = 0; c < channels; ++c) acc[c * kTileSize + row] += weight * s[kHeader + c];
      st.transmittance[row] = simd::select(add, next_t, t);
      st.last[row] = simd::select(add, index, st.last[row]);
      st.count[row] = simd::count_if(st.count[row], add);
      const simd::mask still_alive = simd::and_not(st.alive[row], stop);
      st.alive[row] = still_alive;
      live_rows &= ~(std::uint32_t(!simd::any(still_alive)) << row);
    }
  }
  const int lanes = std::min(kLanes, width - list.x0);
  for (int row = 0; row < list.rows; ++row) {
    const std::size_t first = std::size_t(list.y0 + row) * width + list.x0;  // lane 0's pixel
    const vf t = st.transmittance[row];
    if (lanes == kLanes) {  // whole row inside the image: contiguous in the [H, W] planes
      simd::store(&out.final_T[first], t);
      simd::store(&out.alpha[first], 1.0f - t);
      simd::store(&out.last_contributor[first], st.last[row]);
      simd::store(&out.n_contrib[first], st.count[row]);
      if (ctx.options->render_depth) simd::store(&out.depth[first], acc[c_image * kTileSize + row]);
    } else {
      for (int l = 0; l < lanes; ++l) {
        out.final_T[first + l] = t[l];
        out.alpha[first + l] = 1.0f - t[l];
        out.last_contributor[first + l] = st.last[row][l];
        out.n_contrib[first + l] = st.count[row][l];
        if (ctx.options->render_depth) out.depth[first + l] = acc[c_image * kTileSize + row][l];
      }
    }
    for (int c = 0; c < c_image; ++c) {
      const vf value = acc[c * kTileSize + row] + t * ctx.background[c];
      float* dst = &out.image.data[first * c_image + c];
      for (int l = 0; l < lanes; ++l) dst[std::size_t(l) * c_image] = value[l];
    }
  }
}

// Layout of a row of the per-thread gradient buffers.
enum GradField { kGradU, kGradV, kGradA, kGradB, kGradC, kGradOpacity, kGradHeader };

// Back to front over the tile's list from its last contributor; each Gaussian visits the rows it
// can reach that have pixels it contributed to, accumulating its gradient in registers.
template <int kC>
void backward_tile(const Context& ctx, const Rule& rule, const TileList& list,
                   const BlendOutput& fwd, const float* v_image, const float* v_alpha,
                   const float* v_depth, TileState& st, float* grad_buffer) {
  const int channels = kC > 0 ? kC : ctx.channels_ext;
  const int c_image = ctx.in->channels, width = ctx.in->width;
  const int grad_stride = kGradHeader + ctx.channels_ext;
  st.reset(channels);
  vf* v_out = st.channel_b.data();  // [C', 16] upstream gradient of each channel
  // v_behind = sum_c v_out_c behind_c, with behind_c = what the Gaussians behind the current one
  // and the background add to channel c. Kept as one dot product per pixel: compositing a
  // Gaussian adds weight * sum_c v_out_c f_c to it.
  vf* v_behind = st.channel_a.data();     // [16]
  std::int32_t row_last[kTileSize] = {};  // max last contributor of each row
  for (int row = 0; row < list.rows; ++row) {
    const int y = list.y0 + row;
    for (int l = 0; l < kLanes && list.x0 + l < width; ++l) {
      const std::size_t pixel = std::size_t(y) * width + list.x0 + l;
      const float t = fwd.final_T[pixel];
      st.transmittance[row][l] = t;
      float v_bg = 0.0f;
      for (int c = 0; c < c_image; ++c) {
        const float v = v_image[pixel * c_image + c];
        v_out[c * kTileSize + row][l] = v;
        v_bg += v * ctx.background[c];
      }
      v_behind[row][l] = t * v_bg;
      if (ctx.options->render_depth && v_depth)
        v_out[c_image * kTileSize + row][l] = v_depth[pixel];
      st.v_alpha_final_t[row][l] = v_alpha ? v_alpha[pixel] * t : 0.0f;
      st.last[row][l] = fwd.last_contributor[pixel];
      row_last[row] = std::max(row_last[row], fwd.last_contributor[pixel]);
    }
  }
  const std::int32_t max_last = *std::max_element(row_last, row_last + kTileSize);

  vf v_feat_fixed[kC > 0 ? kC : 1];
  std::vector<vf> v_feat_dynamic(kC > 0 ? 0 : channels);
  vf* v_feat = kC > 0 ? v_feat_fixed : v_feat_dynamic.data();
  // The Gaussian's record and its row of the gradient buffer are both scattered in memory.
  const auto prefetch = [&](int k) {
    if (k < 0) return;
    list.prefetch(k);
    simd::prefetch(grad_buffer + std::size_t(list.gaussian[k]) * grad_stride);
  };
  for (int k = max_last - 1; k >= max_last - 1 - kPrefetchDistance; --k) prefetch(k);
  for (int k = max_last - 1; k >= 0; --k) {
    prefetch(k - kPrefetchDistance);
    std::uint32_t active_rows = 0;
    for (int row = 0; row < kTileSize; ++row)
      active_rows |= std::uint32_t(k < row_last[row]) << row;
    const float* s = list.splat(k);
    std::uint32_t todo = active_rows & list.row_mask(s);
    if (!todo) continue;
    const float a = 2.0f * s[kHalfA], b = s[kB], c_conic = 2.0f * s[kHalfC];
    const float inv_opacity = 1.0f / s[kOpacity];
    const RowInvariant inv(s, list.px);
    const vf dx = inv.dx, half_dx = 0.5f * dx;
    vf v_u{}, v_v{}, v_a{}, v_b{}, v_c{}, v_opacity{};
    for (int c = 0; c < channels; ++c) v_feat[c] = vf{};
    const vi index = simd::splat_int(k);
    while (todo) {
      const int row = pop_row(todo);
      const float dy = s[kV] - (float(list.y0 + row) + 0.5f);
      const vf alpha_raw = simd::opacity_times_exp_neg(inv.sigma(s, dy), s[kLog2Opacity]);
      const vf alpha = simd::min(rule.alpha_clamp, alpha_raw);
      const simd::mask composite =
          simd::less(index, st.last[row]) & simd::greater_equal(alpha, rule.min_alpha);
      const vf inv_one_minus = simd::reciprocal(1.0f - alpha);
      // T in front of this Gaussian, recovered from T behind it.
      const vf t =
          simd::select(composite, st.transmittance[row] * inv_one_minus, st.transmittance[row]);
      st.transmittance[row] = t;
      const vf weight = simd::mul_or_zero(composite, alpha, t);
      vf v_out_dot_f{};  // sum_c v_out_c f_c
      for (int c = 0; c < channels; ++c) {
        const vf v_o = v_out[c * kTileSize + row];
        v_feat[c] += weight * v_o;
        v_out_dot_f += v_o * s[kHeader + c];
      }
      // d out_c / d alpha = f_c T - behind_c / (1 - alpha); d alpha_out / d alpha = T_f / (1-alpha)
      vf v_alpha_px = v_out_dot_f * t + (st.v_alpha_final_t[row] - v_behind[row]) * inv_one_minus;
      v_behind[row] += weight * v_out_dot_f;
      // alpha = opacity * G unless clamped (then no gradient flows), G = exp(-sigma):
      // d alpha / d opacity = G, d alpha / d sigma = -alpha.
      const simd::mask unclamped = composite & simd::less_equal(alpha_raw, rule.alpha_clamp);
      v_alpha_px = simd::select(unclamped, v_alpha_px, vf{});
      const vf v_alpha_raw = alpha_raw * v_alpha_px;
      v_opacity += v_alpha_raw;                                     // times 1 / opacity below
      const vf g_dx = -v_alpha_raw * dx, g_dy = -v_alpha_raw * dy;  // v_sigma * (dx, dy)
      v_a += half_dx * g_dx;
      v_b += dx * g_dy;
      v_c += (0.5f * dy) * g_dy;
      v_u += a * g_dx + b * g_dy;
      v_v += b * g_dx + c_conic * g_dy;
    }
    float* g = grad_buffer + std::size_t(list.gaussian[k]) * grad_stride;
    g[kGradU] += simd::sum(v_u);
    g[kGradV] += simd::sum(v_v);
    g[kGradA] += simd::sum(v_a);
    g[kGradB] += simd::sum(v_b);
    g[kGradC] += simd::sum(v_c);
    g[kGradOpacity] += simd::sum(v_opacity) * inv_opacity;
    for (int c = 0; c < channels; ++c) g[kGradHeader + c] += simd::sum(v_feat[c]);
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
  if (bins.tiles_x != (in.width + kTileSize - 1) / kTileSize ||
      bins.tiles_y != (in.height + kTileSize - 1) / kTileSize)
    fail("blend: tile bins ({}x{} tiles) do not match the {}x{} image", bins.tiles_x, bins.tiles_y,
         in.width, in.height);
}

}  // namespace

BlendOutput blend_forward(const BlendInputs& in, const TileBins& bins,
                          const RenderOptions& options) {
  check_inputs(in, bins);
  const Context ctx(in, bins, options);
  const Rule rule(options);
  const std::size_t pixels = std::size_t(in.width) * in.height;
  BlendOutput out;
  out.image = Image(in.width, in.height, in.channels);
  out.alpha.resize(pixels);
  if (options.render_depth) out.depth.resize(pixels);
  out.final_T.resize(pixels);
  out.last_contributor.resize(pixels);
  out.n_contrib.resize(pixels);
  dispatch_channels(ctx.channels_ext, [&]<int kC>() {
#pragma omp parallel
    {
      const simd::FlushDenormals flush;
      TileState state;
      // Results do not depend on which thread draws which tile: dynamic balances the load.
#pragma omp for schedule(dynamic, 1)
      for (int tile = 0; tile < bins.num_tiles(); ++tile) {
        forward_tile<kC>(ctx, rule, TileList(ctx, tile), state, out);
      }
    }
  });
  return out;
}

void blend_backward(const BlendInputs& in, const TileBins& bins, const RenderOptions& options,
                    const BlendOutput& forward, const float* v_image, const float* v_alpha,
                    const float* v_depth, GaussianGrads& grads) {
  check_inputs(in, bins);
  if (!v_image) fail("blend_backward: v_image is required");
  if (v_depth && !options.render_depth)
    fail("blend_backward: v_depth given but the forward did not render depth");
  const Context ctx(in, bins, options);
  const Rule rule(options);
  const std::size_t n = in.projected->size();
  const int c = in.channels;
  const int grad_stride = kGradHeader + ctx.channels_ext;
  const int threads = omp_get_max_threads();
  // [threads, N, grad_stride]: each thread owns the tiles of a static schedule and sums into its
  // own rows, so the order of every sum is fixed by the thread count alone.
  // Left uninitialised here and zeroed by its own thread (in parallel, and first touch puts the
  // pages near that thread).
  const std::size_t buffer_size = n * grad_stride;
  const std::unique_ptr<float[]> buffers(new float[threads * buffer_size]);
  dispatch_channels(ctx.channels_ext, [&]<int kC>() {
#pragma omp parallel num_threads(threads)
    {
      const simd::FlushDenormals flush;
      TileState state;
      float* buffer = &buffers[omp_get_thread_num() * buffer_size];
      std::fill(buffer, buffer + buffer_size, 0.0f);
#pragma omp for schedule(static, 1)
      for (int tile = 0; tile < bins.num_tiles(); ++tile) {
        backward_tile<kC>(ctx, rule, TileList(ctx, tile), forward, v_image, v_alpha, v_depth, state,
                          buffer);
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
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t g = 0; g < std::ptrdiff_t(n); ++g) {
    float sum[kGradHeader + kMaxStaticChannels + 1];
    std::vector<float> sum_dynamic(grad_stride > int(std::size(sum)) ? grad_stride : 0);
    float* total = sum_dynamic.empty() ? sum : sum_dynamic.data();
    std::fill(total, total + grad_stride, 0.0f);
    for (int t = 0; t < threads; ++t) {
      const float* row = &buffers[t * buffer_size + g * grad_stride];
      for (int k = 0; k < grad_stride; ++k) total[k] += row[k];
    }
    grads.v_means2d[2 * g] = total[kGradU];
    grads.v_means2d[2 * g + 1] = total[kGradV];
    grads.v_conics[3 * g] = total[kGradA];
    grads.v_conics[3 * g + 1] = total[kGradB];
    grads.v_conics[3 * g + 2] = total[kGradC];
    grads.v_opacities[g] = total[kGradOpacity];
    std::copy(total + kGradHeader, total + kGradHeader + c, &grads.v_features[g * c]);
    grads.v_depths[g] = options.render_depth ? total[kGradHeader + c] : 0.0f;
  }
}

}  // namespace retimegs::render
