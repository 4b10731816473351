#pragma once
// ModelRenderer's GPU half (model_renderer_cuda.cpp), built with the CUDA backend only.

#include "retimegs/cuda/primitives.hpp"
#include "retimegs/cuda/rasterize.hpp"
#include "retimegs/cuda/slice.hpp"
#include "retimegs/playback/model_renderer.hpp"

namespace retimegs::playback {

struct ModelRenderer::Gpu {
  cuda::DevicePrimitives primitives;  // a 4D model's, uploaded once
  cuda::DeviceTimeSlice sliced;       // its batch at the last (t, camera)
  cuda::DeviceGaussians splats;       // a static model's Gaussians for the last camera
  cuda::DeviceRenderOutput out;

  explicit Gpu(const LoadedModel& model);
  // ModelRenderer::draw_side on the device, `model` the one given to the constructor: the image,
  // and when given its alpha and (with options.render_depth) its composited depth sum_i z_i w_i.
  Image draw(const LoadedModel& model, const Camera& camera, double t, const float* background,
             const render::RenderOptions& options, model::SeamSide side, double side_seam,
             UninitVector<float>* alpha, UninitVector<float>* composited_depth);
};

}  // namespace retimegs::playback
