// The rasteriser pipeline: project (which validates the Gaussians) -> bin_tiles -> blend, and back.
#include "retimegs/render/rasterize.hpp"

#include <cmath>
#include <string>

#include "retimegs/core/error.hpp"

namespace retimegs::render {
namespace {

BlendInputs blend_inputs(const Gaussians& g, const Camera& camera, const Projected& projected,
                         const float* background) {
  BlendInputs in;
  in.projected = &projected;
  in.opacities = g.opacities.data();
  in.features = g.features.data();
  in.channels = g.channels;
  in.background = background;
  in.width = camera.width;
  in.height = camera.height;
  return in;
}

}  // namespace

void check_camera(const Camera& camera) {
  const std::string what = "camera '" + camera.name + "'";
  if (camera.width < 1 || camera.height < 1)
    fail("{}: image size {}x{} is empty", what, camera.width, camera.height);
  if (!(std::isfinite(camera.fx) && std::isfinite(camera.fy) && camera.fx > 0 && camera.fy > 0))
    fail("{}: focal lengths fx = {}, fy = {} must be finite and positive", what, camera.fx,
         camera.fy);
  if (!(std::isfinite(camera.cx) && std::isfinite(camera.cy)))
    fail("{}: principal point ({}, {}) must be finite", what, camera.cx, camera.cy);
  check_rigid(camera.world_to_camera, what + " world_to_camera");
}

void check_background(const float* background, int channels) {
  if (background)
    for (int c = 0; c < channels; ++c)
      if (!std::isfinite(background[c]))
        fail("background[{}] is {} (must be finite)", c, background[c]);
}

RenderOutput rasterize_forward(const Gaussians& gaussians, const Camera& camera,
                               const float* background, const RenderOptions& options) {
  RenderOutput out;
  rasterize_forward(gaussians, camera, background, options, out);
  return out;
}

void rasterize_forward(const Gaussians& gaussians, const Camera& camera, const float* background,
                       const RenderOptions& options, RenderOutput& out) {
  check_camera(camera);
  check_background(background, gaussians.channels);
  // project_forward validates the Gaussians.
  project_forward(gaussians, PinholeT<float>(camera), options, out.projected);
  bin_tiles(out.projected, gaussians.opacities.data(), camera.width, camera.height, options,
            out.bins);
  blend_forward(blend_inputs(gaussians, camera, out.projected, background), out.bins, options,
                out.blend);
}

namespace {

// Both rasterize_backward overloads: into `grads`, with `buffers` as the blend's scratch.
void backward_into(const Gaussians& gaussians, const Camera& camera, const float* background,
                   const RenderOptions& options, const RenderOutput& forward, const float* v_image,
                   const float* v_alpha, const float* v_depth, GaussianGrads& grads,
                   UninitVector<float>& buffers) {
  if (forward.projected.size() != gaussians.size() ||
      forward.blend.final_T.size() != std::size_t(camera.width) * camera.height)
    fail("rasterize_backward: the saved forward does not match these Gaussians and camera");
  grads.channels = gaussians.channels;  // each stage sizes (and fills) its own fields
  blend_backward(blend_inputs(gaussians, camera, forward.projected, background), forward.bins,
                 options, forward.blend, v_image, v_alpha, v_depth, grads, buffers);
  project_backward(gaussians, PinholeT<float>(camera), forward.projected, options, grads);
}

}  // namespace

GaussianGrads rasterize_backward(const Gaussians& gaussians, const Camera& camera,
                                 const float* background, const RenderOptions& options,
                                 const RenderOutput& forward, const float* v_image,
                                 const float* v_alpha, const float* v_depth) {
  GaussianGrads grads;
  UninitVector<float> buffers;
  backward_into(gaussians, camera, background, options, forward, v_image, v_alpha, v_depth, grads,
                buffers);
  return grads;
}

void rasterize_backward(const Gaussians& gaussians, const Camera& camera, const float* background,
                        const RenderOptions& options, RenderOutput& forward, const float* v_image,
                        GaussianGrads& grads, const float* v_alpha, const float* v_depth) {
  backward_into(gaussians, camera, background, options, forward, v_image, v_alpha, v_depth, grads,
                forward.backward_buffers);
}

}  // namespace retimegs::render
