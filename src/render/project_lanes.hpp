#pragma once
// Stage 1 in float, 16 Gaussians at a time (one per simd lane): the same EWA projection and
// vector-Jacobian product as the scalar templates in project.cpp (which the double-precision
// reference keeps using), for project_forward<float> and project_backward<float>.
#include "retimegs/core/gaussians.hpp"
#include "retimegs/render/options.hpp"
#include "retimegs/render/project.hpp"

namespace retimegs::render {

// The part of check_gaussians that project_forward_lanes does not do in its own pass: channel
// count, array sizes and finite features.
template <typename T>
void check_sizes_and_features(const GaussiansT<T>& gaussians);

// Writes every row of `out` (its arrays keep their capacity).
void project_forward_lanes(const GaussiansT<float>& gaussians, const PinholeT<float>& camera,
                           const RenderOptions& options, ProjectedT<float>& out);

void project_backward_lanes(const GaussiansT<float>& gaussians, const PinholeT<float>& camera,
                            const ProjectedT<float>& projected, const RenderOptions& options,
                            GaussianGradsT<float>& grads);

}  // namespace retimegs::render
