#pragma once
// Stage 1 in float, 16 Gaussians at a time (one per simd lane): the same EWA projection and
// vector-Jacobian product as the scalar templates in project.cpp (which the double-precision
// reference keeps using), for project_forward<float> and project_backward<float>.
#include "constants.hpp"
#include "retimegs/core/gaussians.hpp"
#include "retimegs/render/options.hpp"
#include "retimegs/render/project.hpp"

namespace retimegs::render {

// The field-of-view guard's bounds for one camera (kFovGuard): x/z in [-x_neg, x_pos] and y/z in
// [-y_neg, y_pos].
template <typename T>
struct FovGuardT {
  T x_pos, x_neg, y_pos, y_neg;

  explicit FovGuardT(const PinholeT<T>& camera) {
    const T tan_x = T(0.5) * camera.width / camera.fx, tan_y = T(0.5) * camera.height / camera.fy;
    x_pos = (camera.width - camera.cx) / camera.fx + T(kFovGuard) * tan_x;
    x_neg = camera.cx / camera.fx + T(kFovGuard) * tan_x;
    y_pos = (camera.height - camera.cy) / camera.fy + T(kFovGuard) * tan_y;
    y_neg = camera.cy / camera.fy + T(kFovGuard) * tan_y;
  }
};

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
