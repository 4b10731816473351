// Stage 3 on the GPU: one 16x16 thread block per tile, one thread per pixel. The forward walks the
// tile's depth-ordered list front to back, a batch of 256 Gaussians at a time fetched into shared
// memory by the block; the backward walks it back to front from the block's last contributor,
// recovering each pixel's transmittance by division (as gsplat does) and summing each Gaussian's
// gradient over a warp before one atomicAdd per value. Per pixel, the same operations in the same
// order as blend.cpp's lanes (alpha by log2_alpha and exp2_approx, the clamp, min_alpha, the stop
// rule, the compositing), so the images agree with the CPU's to float rounding.
#include "blend.hpp"

#include <cuda_runtime.h>

#include <algorithm>

#include "retimegs/core/error.hpp"
#include "retimegs/cuda/check.hpp"

namespace retimegs::cuda {
namespace {

using render::kTileSize;
constexpr int kBlockPixels = kTileSize * kTileSize;  // threads per block, Gaussians per batch
constexpr unsigned kFullWarp = 0xffffffffu;

// The per-pixel channel loops: kC channels when the count has a compiled kernel, else the
// run-time count in arrays of kMaxBlendChannels.
template <int kC>
struct Channels {
  static constexpr int kArray = kC > 0 ? kC : kMaxBlendChannels;
  __device__ static int count(const BlendParams& p) { return kC > 0 ? kC : p.channels_ext; }
};

// Feature c of Gaussian g: its features, then (depth) its camera z.
__device__ inline float feature(const BlendParams& p, const float* features,
                                const float4& record_high, int g, int c) {
  return c < p.channels ? __ldg(&features[std::size_t(g) * p.channels + c]) : record_high.w;
}

// The pixel of this thread and its tile's list.
struct TilePixel {
  int x, y;
  bool inside;
  float px, py;  // pixel centre
  int begin, end;
  int rank;  // thread index in the block

  __device__ TilePixel(const BlendParams& p, const std::int32_t* isect_offsets) {
    x = blockIdx.x * kTileSize + threadIdx.x;
    y = blockIdx.y * kTileSize + threadIdx.y;
    inside = x < p.width && y < p.height;
    px = float(x) + 0.5f;
    py = float(y) + 0.5f;
    const int tile = blockIdx.y * p.tiles_x + blockIdx.x;
    begin = isect_offsets[tile];
    end = isect_offsets[tile + 1];
    rank = threadIdx.y * kTileSize + threadIdx.x;
  }
  __device__ std::size_t pixel(const BlendParams& p) const { return std::size_t(y) * p.width + x; }
};

// alpha before the clamp of a record (two float4: u v half_a b, half_c log2_opacity opacity z)
// at offset (dx, dy) = mean2d - pixel centre.
__device__ inline float alpha_raw_of(const float4& low, const float4& high, float dx, float dy) {
  return render::exp2_approx(render::log2_alpha(low.z, low.w, high.x, high.y, dx, dy));
}
// min(alpha_clamp, alpha_raw) as the lanes' vminps takes it.
__device__ inline float clamped(const BlendParams& p, float alpha_raw) {
  return p.alpha_clamp < alpha_raw ? p.alpha_clamp : alpha_raw;
}

template <int kC>
__global__ void __launch_bounds__(kBlockPixels)
    blend_forward_kernel(BlendParams p, const std::int32_t* __restrict__ isect_offsets,
                         const std::int32_t* __restrict__ gaussian_from_isect,
                         const float4* __restrict__ records, const float* __restrict__ features,
                         float* __restrict__ image, float* __restrict__ alpha_out,
                         float* __restrict__ depth_out, float* __restrict__ final_T,
                         std::int32_t* __restrict__ last_contributor,
                         std::int32_t* __restrict__ n_contrib) {
  __shared__ std::int32_t s_id[kBlockPixels];
  __shared__ float4 s_low[kBlockPixels], s_high[kBlockPixels];
  const TilePixel tp(p, isect_offsets);
  const int channels = Channels<kC>::count(p);
  float acc[Channels<kC>::kArray];
  for (int c = 0; c < channels; ++c) acc[c] = 0.0f;
  float t = 1.0f;
  bool done = !tp.inside;
  std::int32_t last = 0, count = 0;
  for (int first = tp.begin; first < tp.end; first += kBlockPixels) {
    // Every pixel saturated (or outside the image): the rest of the list is not needed.
    if (__syncthreads_count(done) == kBlockPixels) break;
    const int k = first + tp.rank;
    if (k < tp.end) {
      const std::int32_t g = gaussian_from_isect[k];
      s_id[tp.rank] = g;
      s_low[tp.rank] = records[2 * std::size_t(g)];
      s_high[tp.rank] = records[2 * std::size_t(g) + 1];
    }
    __syncthreads();
    const int n = min(kBlockPixels, tp.end - first);
    for (int j = 0; !done && j < n; ++j) {
      const float4 low = s_low[j], high = s_high[j];
      const float alpha = clamped(p, alpha_raw_of(low, high, low.x - tp.px, low.y - tp.py));
      if (!(alpha >= p.min_alpha)) continue;
      const float next_t = t - alpha * t;
      if (next_t < p.stop_below) {
        done = true;
        break;
      }
      const float weight = alpha * t;
      const int g = s_id[j];
      for (int c = 0; c < channels; ++c) acc[c] += weight * feature(p, features, high, g, c);
      t = next_t;
      last = first - tp.begin + j + 1;
      ++count;
    }
  }
  if (!tp.inside) return;
  const std::size_t pixel = tp.pixel(p);
  final_T[pixel] = t;
  alpha_out[pixel] = 1.0f - t;
  last_contributor[pixel] = last;
  n_contrib[pixel] = count;
  for (int c = 0; c < channels; ++c) {
    if (c < p.channels)
      image[pixel * p.channels + c] = acc[c] + t * p.background[c];
    else
      depth_out[pixel] = acc[c];
  }
}

__device__ inline float warp_sum(float v) {
  for (int offset = 16; offset > 0; offset /= 2) v += __shfl_xor_sync(kFullWarp, v, offset);
  return v;
}

template <int kC>
__global__ void __launch_bounds__(kBlockPixels)
    blend_backward_kernel(BlendParams p, const std::int32_t* __restrict__ isect_offsets,
                          const std::int32_t* __restrict__ gaussian_from_isect,
                          const float4* __restrict__ records, const float* __restrict__ features,
                          const float* __restrict__ final_T,
                          const std::int32_t* __restrict__ last_contributor,
                          const float* __restrict__ v_image, const float* __restrict__ v_alpha,
                          const float* __restrict__ v_depth, float* __restrict__ v_means2d,
                          float* __restrict__ v_conics, float* __restrict__ v_opacities,
                          float* __restrict__ v_features, float* __restrict__ v_depths) {
  __shared__ std::int32_t s_id[kBlockPixels];
  __shared__ float4 s_low[kBlockPixels], s_high[kBlockPixels];
  __shared__ std::int32_t s_max_last;
  const TilePixel tp(p, isect_offsets);
  const int channels = Channels<kC>::count(p);
  const std::size_t pixel = tp.inside ? tp.pixel(p) : 0;
  // The pixel's state behind its last contributor: T_final, the upstream gradient of each channel,
  // and v_alpha_out T_final - sum_c v_out_c behind_c (behind_c = what the Gaussians behind the
  // current one and the background add to channel c; blend.cpp's v_final_minus_behind).
  float t = 1.0f, v_final_minus_behind = 0.0f;
  float v_out[Channels<kC>::kArray];
  for (int c = 0; c < channels; ++c) v_out[c] = 0.0f;
  std::int32_t last = 0;
  if (tp.inside) {
    t = final_T[pixel];
    last = last_contributor[pixel];
    float v_bg = 0.0f;
    for (int c = 0; c < channels; ++c) {
      if (c < p.channels) {
        v_out[c] = v_image[pixel * p.channels + c];
        v_bg += v_out[c] * p.background[c];
      } else {
        v_out[c] = v_depth ? v_depth[pixel] : 0.0f;
      }
    }
    v_final_minus_behind = (v_alpha ? v_alpha[pixel] * t : 0.0f) - t * v_bg;
  }
  if (tp.rank == 0) s_max_last = 0;
  __syncthreads();
  atomicMax(&s_max_last, last);
  __syncthreads();
  const int max_last = s_max_last;
  const int lane = tp.rank % 32;

  // List positions [batch_end - n, batch_end), back to front; entry j of the batch is position
  // batch_end - 1 - j.
  for (int batch_end = max_last; batch_end > 0; batch_end -= kBlockPixels) {
    const int n = min(kBlockPixels, batch_end);
    __syncthreads();  // the previous batch is consumed
    if (tp.rank < n) {
      const std::int32_t g = gaussian_from_isect[tp.begin + batch_end - 1 - tp.rank];
      s_id[tp.rank] = g;
      s_low[tp.rank] = records[2 * std::size_t(g)];
      s_high[tp.rank] = records[2 * std::size_t(g) + 1];
    }
    __syncthreads();
    for (int j = 0; j < n; ++j) {
      const int k = batch_end - 1 - j;
      const float4 low = s_low[j], high = s_high[j];
      bool composite = false;
      render::SigmaSumsT<float> sums{};
      float v_feature[Channels<kC>::kArray];
      if (k < last) {
        const float dx = low.x - tp.px, dy = low.y - tp.py;
        const float alpha_raw = alpha_raw_of(low, high, dx, dy);
        const float alpha = clamped(p, alpha_raw);
        composite = alpha >= p.min_alpha;
        if (composite) {
          // T in front of this Gaussian, recovered from T behind it.
          const float inv_one_minus = 1.0f / (1.0f - alpha);
          t = t * inv_one_minus;
          const float weight = alpha * t;
          float v_out_dot_f = 0.0f;  // sum_c v_out_c f_c
          for (int c = 0; c < channels; ++c) {
            v_feature[c] = weight * v_out[c];
            v_out_dot_f += v_out[c] * feature(p, features, high, s_id[j], c);
          }
          // d out_c / d alpha = f_c T - behind_c / (1 - alpha); d alpha_out / d alpha =
          // T_final / (1 - alpha).
          const float v_alpha_px = v_out_dot_f * t + v_final_minus_behind * inv_one_minus;
          v_final_minus_behind -= weight * v_out_dot_f;
          // alpha = opacity G unless clamped (then no gradient flows): w = -d loss / d sigma.
          const float w = alpha_raw <= p.alpha_clamp ? alpha_raw * v_alpha_px : 0.0f;
          render::sigma_vjp_accumulate(w, dx, dy, sums);
        }
      }
      if (!__any_sync(kFullWarp, composite)) continue;
      if (!composite)
        for (int c = 0; c < channels; ++c) v_feature[c] = 0.0f;
      sums.w = warp_sum(sums.w);
      sums.w_dx = warp_sum(sums.w_dx);
      sums.w_dy = warp_sum(sums.w_dy);
      sums.w_dx2 = warp_sum(sums.w_dx2);
      sums.w_dxdy = warp_sum(sums.w_dxdy);
      sums.w_dy2 = warp_sum(sums.w_dy2);
      for (int c = 0; c < channels; ++c) v_feature[c] = warp_sum(v_feature[c]);
      if (lane != 0) continue;
      const std::size_t g = std::size_t(s_id[j]);
      // The conic as the records hold it (blend.cpp recovers it the same way).
      const float conic[3] = {2.0f * render::kLn2 * low.z, render::kLn2 * low.w,
                              2.0f * render::kLn2 * high.x};
      float v_mean2d[2], v_conic[3];
      render::sigma_vjp_combine(conic, sums.w_dx, sums.w_dy, sums.w_dx2, sums.w_dxdy, sums.w_dy2,
                                v_mean2d, v_conic);
      atomicAdd(&v_means2d[2 * g], v_mean2d[0]);
      atomicAdd(&v_means2d[2 * g + 1], v_mean2d[1]);
      for (int c = 0; c < 3; ++c) atomicAdd(&v_conics[3 * g + c], v_conic[c]);
      // d alpha_raw / d opacity = alpha_raw / opacity.
      atomicAdd(&v_opacities[g], sums.w / high.z);
      for (int c = 0; c < channels; ++c) {
        if (c < p.channels)
          atomicAdd(&v_features[g * p.channels + c], v_feature[c]);
        else
          atomicAdd(&v_depths[g], v_feature[c]);
      }
    }
  }
}

// Calls f.template operator()<kC>() with kC = the channel count when it has a compiled kernel,
// else 0 (the run-time channel loops).
template <typename F>
void dispatch_channels(int channels_ext, F&& f) {
  switch (channels_ext) {
    case 3:
      return f.template operator()<3>();
    case 4:
      return f.template operator()<4>();
    case 7:
      return f.template operator()<7>();
    case 8:
      return f.template operator()<8>();
    default:
      return f.template operator()<0>();
  }
}

dim3 tile_grid(const BlendParams& p) {
  return dim3(unsigned(p.tiles_x), unsigned(p.tiles_y));
}
const dim3 kTileBlock(kTileSize, kTileSize);

}  // namespace

BlendParams blend_params(const render::RenderOptions& options, int width, int height, int channels,
                         const float* background) {
  BlendParams p;
  p.width = width;
  p.height = height;
  p.tiles_x = render::tile_count(width);
  p.tiles_y = render::tile_count(height);
  p.channels = channels;
  p.channels_ext = channels + (options.render_depth ? 1 : 0);
  if (p.channels_ext > kMaxBlendChannels)
    fail("cuda rasterizer: {} channels{} exceed the maximum of {}", channels,
         options.render_depth ? " + depth" : "", kMaxBlendChannels);
  p.alpha_clamp = options.alpha_clamp;
  p.min_alpha = options.min_alpha;
  p.stop_below = render::stop_below(options);
  if (background) std::copy(background, background + channels, p.background);
  return p;
}

void blend_forward(const BlendParams& p, const DeviceTileBins& bins, const float* records,
                   const float* features, DeviceBlendOutput& out) {
  const std::size_t pixels = std::size_t(p.width) * p.height;
  out.width = p.width, out.height = p.height, out.channels = p.channels;
  out.image.resize(pixels * p.channels);
  out.alpha.resize(pixels);
  out.depth.resize(p.channels_ext > p.channels ? pixels : 0);
  out.final_T.resize(pixels);
  out.last_contributor.resize(pixels);
  out.n_contrib.resize(pixels);
  dispatch_channels(p.channels_ext, [&]<int kC>() {
    blend_forward_kernel<kC><<<tile_grid(p), kTileBlock>>>(
        p, bins.isect_offsets.data(), bins.gaussian_from_isect.data(),
        reinterpret_cast<const float4*>(records), features, out.image.data(), out.alpha.data(),
        out.depth.empty() ? nullptr : out.depth.data(), out.final_T.data(),
        out.last_contributor.data(), out.n_contrib.data());
  });
  check(cudaGetLastError(), "blend_forward launch");
}

void blend_backward(const BlendParams& p, const DeviceTileBins& bins, const float* records,
                    const float* features, const DeviceBlendOutput& forward, const float* v_image,
                    const float* v_alpha, const float* v_depth, DeviceGaussianGrads& grads) {
  dispatch_channels(p.channels_ext, [&]<int kC>() {
    blend_backward_kernel<kC><<<tile_grid(p), kTileBlock>>>(
        p, bins.isect_offsets.data(), bins.gaussian_from_isect.data(),
        reinterpret_cast<const float4*>(records), features, forward.final_T.data(),
        forward.last_contributor.data(), v_image, v_alpha, v_depth, grads.v_means2d.data(),
        grads.v_conics.data(), grads.v_opacities.data(), grads.v_features.data(),
        grads.v_depths.data());
  });
  check(cudaGetLastError(), "blend_backward launch");
}

}  // namespace retimegs::cuda
