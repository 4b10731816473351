#pragma once
// The CUDA blend (stage 3), forward and backward: launched by rasterize.cu.
#include <cstdint>

#include "retimegs/cuda/rasterize.hpp"
#include "retimegs/render/formulas.hpp"

namespace retimegs::cuda {

// The blend's view of one Gaussian, written by the projection kernel: [N, 8] floats, two float4.
enum BlendRecordField {
  kRecU,
  kRecV,
  kRecHalfA,  // the conic scaled for log2_alpha (render::BlendConicT)
  kRecB,
  kRecHalfC,
  kRecLog2Opacity,
  kRecOpacity,
  kRecDepth,
  kRecordFloats
};

// What every blend thread needs besides the arrays, passed by value.
struct BlendParams {
  int width = 0, height = 0, tiles_x = 0, tiles_y = 0;
  int channels = 0;      // C
  int channels_ext = 0;  // C (+ 1 when depth is composited)
  float alpha_clamp = 0, min_alpha = 0;
  float stop_below = 0;                      // render::stop_below
  float background[kMaxBlendChannels] = {};  // [C']; the depth channel composites over 0
};

BlendParams blend_params(const render::RenderOptions& options, int width, int height, int channels,
                         const float* background);

void blend_forward(const BlendParams& params, const DeviceTileBins& bins, const float* records,
                   const float* features, DeviceBlendOutput& out);

// Adds into grads.v_means2d, v_conics, v_opacities, v_features and v_depths (zeroed by the
// caller).
void blend_backward(const BlendParams& params, const DeviceTileBins& bins, const float* records,
                    const float* features, const DeviceBlendOutput& forward, const float* v_image,
                    const float* v_alpha, const float* v_depth, DeviceGaussianGrads& grads);

}  // namespace retimegs::cuda
