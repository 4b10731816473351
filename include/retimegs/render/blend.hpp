#pragma once
// Stage 3: front-to-back alpha compositing of the binned 2-D Gaussians, per 16x16 tile, and its
// back-to-front vector-Jacobian product. Float only (the fast path); see reference.hpp for the
// double-precision per-pixel version.
#include <cstdint>
#include <vector>

#include "retimegs/core/gaussians.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/core/memory.hpp"
#include "retimegs/render/bin_tiles.hpp"
#include "retimegs/render/options.hpp"
#include "retimegs/render/project.hpp"

namespace retimegs::render {

// What the compositing reads besides the bins. Pointers are borrowed, not owned.
struct BlendInputs {
  const Projected* projected = nullptr;
  const float* opacities = nullptr;   // [N]
  const float* features = nullptr;    // [N, C]
  int channels = 0;                   // C
  const float* background = nullptr;  // [C]; nullptr = black
  int width = 0, height = 0;
};

// 64 bytes, the unit of the blend's packed Gaussian records (written once, in parallel).
struct alignas(64) CacheLine {
  float values[16];
};

struct BlendOutput {
  Image image;                // [H, W, C] sum_i f_i alpha_i T_i + T_final * background
  UninitVector<float> alpha;  // [H, W] 1 - T_final
  UninitVector<float> depth;  // [H, W] sum_i z_i alpha_i T_i; empty unless render_depth
  // Saved for the backward.
  UninitVector<float> final_T;                  // [H, W] transmittance left after compositing
  UninitVector<std::int32_t> last_contributor;  // [H, W] 1 + tile-list position of the last
                                                // Gaussian composited; 0 = none
  UninitVector<std::int32_t> n_contrib;         // [H, W] how many Gaussians were composited
  // [M] per tile intersection: the 4x4-pixel blocks of its tile (bit 4 * block row + block
  // column) that hold a pixel centre of the Gaussian's alpha >= min_alpha ellipse. Set for the
  // intersections that the forward reached before its tile saturated (all the backward visits);
  // the others are left unset.
  UninitVector<std::uint16_t> footprint_blocks;
  // [N, lines per Gaussian] the Gaussians packed for the blend (blend.cpp's record layout), so
  // that the backward does not pack them again.
  UninitVector<CacheLine> records;
};

BlendOutput blend_forward(const BlendInputs& in, const TileBins& bins,
                          const RenderOptions& options);
// The same into `out`, whose arrays keep their capacity.
void blend_forward(const BlendInputs& in, const TileBins& bins, const RenderOptions& options,
                   BlendOutput& out);

// Upstream gradients v_image [H, W, C] (required), v_alpha [H, W] and v_depth [H, W] (nullptr =
// zero; v_depth requires options.render_depth). `forward` must come from blend_forward with the
// same inputs and bins: its footprint_blocks and records are reused, not recomputed. Sets
// grads.v_means2d, v_conics, v_opacities, v_features and v_depths. Each thread takes one
// contiguous run of tiles (balanced by the forward's n_contrib) into its own gradient buffer; the
// buffers are summed in thread order: deterministic for a given thread count.
void blend_backward(const BlendInputs& in, const TileBins& bins, const RenderOptions& options,
                    const BlendOutput& forward, const float* v_image, const float* v_alpha,
                    const float* v_depth, GaussianGrads& grads);
// The same with the per-thread gradient buffers [threads, N, stride] in `buffers`, scratch whose
// capacity a caller keeps across calls (its contents on return are not part of the result).
void blend_backward(const BlendInputs& in, const TileBins& bins, const RenderOptions& options,
                    const BlendOutput& forward, const float* v_image, const float* v_alpha,
                    const float* v_depth, GaussianGrads& grads, UninitVector<float>& buffers);

}  // namespace retimegs::render
