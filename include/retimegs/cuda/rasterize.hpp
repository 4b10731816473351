#pragma once
// The differentiable rasteriser on an NVIDIA GPU: render/rasterize.hpp's pipeline with its arrays
// resident on the device, stage for stage the CPU renderer's rules (render/formulas.hpp holds the
// per-Gaussian and per-pixel math that both run):
//   project   one thread per Gaussian: EWA projection, culling, tile rect, blend record
//   bin       per-Gaussian tile counts, cub::DeviceScan, keys (tile << 32 | depth bits) and
//             cub::DeviceRadixSort over only the bits in which keys differ, per-tile ranges:
//             the CPU's order (by tile, then depth, ties by Gaussian index)
//   blend     one 16x16 thread block per tile, the tile's Gaussians fetched in batches into
//             shared memory, front to back; backward back to front per pixel, reduced over each
//             warp before the atomicAdd into the gradient
// One host synchronisation per forward (the intersection count, to size the sort) and none in
// the backward. Outputs and scratch keep their allocations across calls.
//
//   cuda::DeviceGaussians g;  g.upload(gaussians);
//   cuda::DeviceRenderOutput out;
//   cuda::rasterize_forward(g, camera, background, options, out);   // out.blend.image, ...
//   cuda::rasterize_backward(g, camera, background, options, out, v_image, v_alpha, v_depth,
//                            grads);
#include <cstdint>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/gaussians.hpp"
#include "retimegs/cuda/buffer.hpp"
#include "retimegs/render/options.hpp"
#include "retimegs/render/rasterize.hpp"

namespace retimegs::cuda {

// Channels (C, plus one when depth is composited) the blend composites per pixel: 3, 4, 7 and 8
// have compiled kernels, the others up to this maximum run a generic one.
constexpr int kMaxBlendChannels = 32;

// GaussiansT<float> on the device, the same [N, ...] layouts.
struct DeviceGaussians {
  int channels = 3;
  DeviceBuffer<float> means, log_scales, quats, opacities, features;

  std::size_t size() const { return opacities.size(); }
  // Copies g in (the buffers keep their allocations where large enough). Throws Error when its
  // arrays' sizes disagree (render::check_gaussians's message); the values are checked by the
  // forward.
  void upload(const Gaussians& g);
  Gaussians download() const;
};

// GaussianGradsT<float> on the device.
struct DeviceGaussianGrads {
  int channels = 3;
  DeviceBuffer<float> v_means, v_log_scales, v_quats, v_opacities, v_features;
  DeviceBuffer<float> v_means2d, v_conics, v_depths;

  std::size_t size() const { return v_opacities.size(); }
  GaussianGrads download() const;
};

// The 2-D Gaussians, as render::Projected.
struct DeviceProjected {
  DeviceBuffer<float> means2d, conics, depths;  // [N, 2], [N, 3], [N]
  DeviceBuffer<std::int32_t> radii;             // [N] 0 = culled
};

// The tile lists, as render::TileBins.
struct DeviceTileBins {
  int tiles_x = 0, tiles_y = 0;
  std::int64_t intersections = 0;                  // M
  DeviceBuffer<std::int32_t> isect_offsets;        // [tiles + 1]
  DeviceBuffer<std::int32_t> gaussian_from_isect;  // [M]
};

// The images and the per-pixel state the backward reads, as render::BlendOutput.
struct DeviceBlendOutput {
  int width = 0, height = 0, channels = 0;
  DeviceBuffer<float> image;                    // [H, W, C]
  DeviceBuffer<float> alpha;                    // [H, W]
  DeviceBuffer<float> depth;                    // [H, W] empty unless render_depth
  DeviceBuffer<float> final_T;                  // [H, W]
  DeviceBuffer<std::int32_t> last_contributor;  // [H, W] 1 + tile-list position; 0 = none
  DeviceBuffer<std::int32_t> n_contrib;         // [H, W]
};

// Scratch of the forward (the backward reads `records`).
struct DeviceRenderScratch {
  DeviceBuffer<std::int32_t> rects;            // [N, 4] tile rect x0 y0 x1 y1
  DeviceBuffer<std::int64_t> tile_counts;      // [N + 1] the rects' areas, then a 0
  DeviceBuffer<std::int64_t> tile_offsets;     // [N + 1] their exclusive sum: [N] = M
  DeviceBuffer<std::uint64_t> keys, keys_alt;  // [M] tile << 32 | depth bits
  DeviceBuffer<std::int32_t> values_alt;       // [M]
  DeviceBuffer<float> records;                 // [N, 8] the blend's view of each Gaussian
  DeviceBuffer<std::uint8_t> cub_storage;      // CUB's temporary storage
  DeviceBuffer<std::uint32_t> summary;         // [3] invalid input, OR and AND of depth bits
};

struct DeviceRenderOutput {
  DeviceProjected projected;
  DeviceTileBins bins;
  DeviceBlendOutput blend;
  DeviceRenderScratch scratch;
};

// render::rasterize_forward on the device. background: C host values (nullptr = black). Throws
// Error as the CPU renderer does (camera, Gaussians, background), and for more than
// kMaxBlendChannels channels.
void rasterize_forward(const DeviceGaussians& gaussians, const Camera& camera,
                       const float* background, const render::RenderOptions& options,
                       DeviceRenderOutput& out);

// render::rasterize_backward on the device: v_image [H, W, C] (device, required), v_alpha [H, W]
// and v_depth [H, W] (device, nullptr = zero; v_depth needs options.render_depth). `forward` must
// come from rasterize_forward with the same arguments. Sets every field of `grads` (sizes
// included). Sums in the order the atomics land: not bitwise repeatable.
void rasterize_backward(const DeviceGaussians& gaussians, const Camera& camera,
                        const float* background, const render::RenderOptions& options,
                        DeviceRenderOutput& forward, const float* v_image, const float* v_alpha,
                        const float* v_depth, DeviceGaussianGrads& grads);

// The host convenience API (tests, benchmarks): everything copied back into the CPU renderer's
// types. The blend's CPU-only fields (footprint_blocks, records) stay empty.
void download(const DeviceRenderOutput& device, render::RenderOutput& host);

}  // namespace retimegs::cuda
