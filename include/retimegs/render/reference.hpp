#pragma once
// The slow, obviously-correct rasteriser that tests compare the fast path with: per pixel, every
// Gaussian in depth order (no tile lists, no sort tricks, no SIMD), in double precision, forward
// and backward. A pixel composites a Gaussian only when the pixel's tile is in the Gaussian's
// blend_tile_rect: that is gsplat's definition of the footprint, which the fast path bins by.
#include <cstdint>
#include <vector>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/gaussians.hpp"
#include "retimegs/render/options.hpp"
#include "retimegs/render/project.hpp"

namespace retimegs::render {

struct ReferenceOutput {
  int width = 0, height = 0, channels = 0;
  std::vector<double> image;            // [H, W, C]
  std::vector<double> alpha;            // [H, W]
  std::vector<double> depth;            // [H, W] empty unless render_depth
  std::vector<double> final_T;          // [H, W]
  std::vector<std::int32_t> n_contrib;  // [H, W]
  ProjectedT<double> projected;
};

// Compositing alone, from given 2-D Gaussians (so that tests can perturb means2d and conics):
// `projected` as project_forward makes it, opacities and features from `gaussians`.
ReferenceOutput reference_blend_forward(const ProjectedT<double>& projected,
                                        const GaussiansT<double>& gaussians, int width, int height,
                                        const double* background, const RenderOptions& options);

// Its vector-Jacobian product: sets grads.v_means2d, v_conics, v_opacities, v_features and
// v_depths (grads sized for the batch).
void reference_blend_backward(const ProjectedT<double>& projected,
                              const GaussiansT<double>& gaussians, int width, int height,
                              const double* background, const RenderOptions& options,
                              const double* v_image, const double* v_alpha, const double* v_depth,
                              GaussianGradsT<double>& grads);

// The whole pipeline: project_forward<double>, then reference_blend_forward.
ReferenceOutput reference_forward(const GaussiansT<double>& gaussians, const Camera& camera,
                                  const double* background /* [C] or nullptr */,
                                  const RenderOptions& options);

// v_image [H, W, C] required; v_alpha, v_depth [H, W] optional (nullptr = zero).
GaussianGradsT<double> reference_backward(const GaussiansT<double>& gaussians, const Camera& camera,
                                          const double* background, const RenderOptions& options,
                                          const double* v_image, const double* v_alpha,
                                          const double* v_depth);

}  // namespace retimegs::render
