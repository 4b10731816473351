#pragma once
// Stage 1: EWA projection of 3D Gaussians to 2-D image-space Gaussians (gsplat's
// project_gaussians / fully_fused_projection), with culling, and its vector-Jacobian product.
#include <array>
#include <cstdint>
#include <vector>

#include "retimegs/core/gaussians.hpp"
#include "retimegs/core/pinhole.hpp"
#include "retimegs/render/formulas.hpp"  // TileRect, radius_tile_rect
#include "retimegs/render/options.hpp"

namespace retimegs::render {

// The stages take the camera as core's pinhole (also named render::PinholeT by their callers).
using retimegs::PinholeT;

// 2-D Gaussians, one row per input Gaussian. Culled rows have radius 0 and all-zero values.
template <typename T>
struct ProjectedT {
  UninitVector<T> means2d;  // [N, 2] pixel coordinates (u, v), pixel centres at +0.5
  UninitVector<T> conics;   // [N, 3] (a, b, c) of the inverse 2-D covariance [[a, b], [b, c]]
  UninitVector<T> depths;   // [N] camera z
  UninitVector<std::int32_t> radii;  // [N] ceil(3 sigma_max) in pixels; 0 = culled

  std::size_t size() const { return radii.size(); }
};
using Projected = ProjectedT<float>;

// radius_tile_rect, and with options.tight_tile_bounds also only the tiles that the
// alpha >= min_alpha ellipse of the Gaussian reaches. This rect defines which (pixel, Gaussian)
// pairs are composited, in the fast path and the reference alike.
template <typename T>
TileRect blend_tile_rect(const T* mean2d, const T* conic, int radius, T opacity, int tiles_x,
                         int tiles_y, const RenderOptions& options);

// Half-extents (pixels) of the region where opacity * exp(-sigma) >= min_alpha, with a margin for
// rounding; +infinity when min_alpha <= 0.
template <typename T>
std::array<T, 2> alpha_extent(const T* conic, T opacity, const RenderOptions& options);

// Throws Error naming the field and the index of the first bad value: a NaN or infinite entry,
// an opacity outside [0, 1], a zero quaternion, or arrays whose sizes disagree.
template <typename T>
void check_gaussians(const GaussiansT<T>& gaussians);

// Validates the Gaussians as check_gaussians does (in float, the fields the projection reads are
// checked in the same pass as they are projected). Culls a Gaussian (radius 0) when: camera z <
// near_plane, the blurred 2-D covariance is singular, opacity <= 0 or < min_alpha (it could never
// be composited), or the radius rule's tile rectangle is empty (off image).
template <typename T>
ProjectedT<T> project_forward(const GaussiansT<T>& gaussians, const PinholeT<T>& camera,
                              const RenderOptions& options);
// The same into `out`, whose arrays keep their capacity (float; double reallocates).
template <typename T>
void project_forward(const GaussiansT<T>& gaussians, const PinholeT<T>& camera,
                     const RenderOptions& options, ProjectedT<T>& out);

// Given grads.v_means2d, v_conics, v_depths (for rows with radius > 0), sets grads.v_means,
// v_log_scales and v_quats (zero for culled rows). Clamped directions of the field-of-view guard
// get zero gradient, as in gsplat.
template <typename T>
void project_backward(const GaussiansT<T>& gaussians, const PinholeT<T>& camera,
                      const ProjectedT<T>& projected, const RenderOptions& options,
                      GaussianGradsT<T>& grads);

}  // namespace retimegs::render
