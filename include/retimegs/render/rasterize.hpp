#pragma once
// The differentiable CPU rasteriser (README.md, Architecture): 3D Gaussians + camera -> image of C
// channels, alpha and (optionally) depth over a background, and the gradient with respect to every
// input. Stages: project.hpp (EWA projection, culling), bin_tiles.hpp (16x16 tiles, radix +
// counting sort), blend.hpp (front-to-back compositing). Threads: OpenMP (core/parallel.hpp).
//
//   auto out = render::rasterize_forward(gaussians, camera, background, options);
//   use out.blend.image, out.blend.alpha, out.blend.depth
//   auto grads = render::rasterize_backward(gaussians, camera, background, options, out,
//                                           v_image, v_alpha, v_depth);
#include "retimegs/core/camera.hpp"
#include "retimegs/core/gaussians.hpp"
#include "retimegs/render/bin_tiles.hpp"
#include "retimegs/render/blend.hpp"
#include "retimegs/render/options.hpp"
#include "retimegs/render/project.hpp"

namespace retimegs::render {

// The images and everything the backward needs.
struct RenderOutput {
  Projected projected;
  TileBins bins;
  BlendOutput blend;  // image [H, W, C], alpha [H, W], depth [H, W], saved per-pixel state
  // Scratch of the reusing rasterize_backward (the blend's per-thread gradient buffers), kept here
  // so that one RenderOutput held across passes also keeps the backward's memory.
  UninitVector<float> backward_buffers;
};

// Throws Error unless the camera has a positive size, finite positive focal lengths, a finite
// principal point and a rigid world_to_camera.
void check_camera(const Camera& camera);
// Throws Error unless the C background values are finite (nullptr, black, passes).
void check_background(const float* background, int channels);

// background: C values (nullptr = black).
RenderOutput rasterize_forward(const Gaussians& gaussians, const Camera& camera,
                               const float* background, const RenderOptions& options = {});
// The same into `out`, whose arrays keep their capacity: a loop that renders every step (training)
// reuses one RenderOutput instead of allocating tens of megabytes per render.
void rasterize_forward(const Gaussians& gaussians, const Camera& camera, const float* background,
                       const RenderOptions& options, RenderOutput& out);

// v_image [H, W, C] required; v_alpha [H, W] and v_depth [H, W] optional (nullptr = zero).
// `forward` must come from rasterize_forward with the same arguments.
GaussianGrads rasterize_backward(const Gaussians& gaussians, const Camera& camera,
                                 const float* background, const RenderOptions& options,
                                 const RenderOutput& forward, const float* v_image,
                                 const float* v_alpha = nullptr, const float* v_depth = nullptr);
// The same into `grads`, whose arrays keep their capacity, with forward.backward_buffers as the
// scratch (the only part of `forward` it changes).
void rasterize_backward(const Gaussians& gaussians, const Camera& camera, const float* background,
                        const RenderOptions& options, RenderOutput& forward, const float* v_image,
                        GaussianGrads& grads, const float* v_alpha = nullptr,
                        const float* v_depth = nullptr);

}  // namespace retimegs::render
