#pragma once
// The numbers of the projection and tile rules that the scalar templates of project.cpp and the
// 16-lane code of project_lanes.cpp and bin_tiles.cpp share: the fast paths cull, size and bin
// the Gaussians as the double-precision reference does only with the same constants.
#include "retimegs/render/options.hpp"

namespace retimegs::render {

// gsplat v0.1.13 compute_radius: lambda = b + sqrt(max(b^2 - det, 0.1)); the floor keeps the
// square root of a round-off-negative discriminant finite.
constexpr double kRadiusDiscriminantFloor = 0.1;
constexpr double kRadiusSigmas = 3.0;  // the footprint is 3 standard deviations of the major axis
// Field-of-view guard of the Jacobian: x/z is clamped to the image plus 30 % of its half-width
// (gsplat: lim = 1.3 * tan_fov, measured from the principal point).
constexpr double kFovGuard = 0.3;
// Pixel coordinates are clamped to this before integer conversion (far off-image anyway).
constexpr double kMaxPixelCoordinate = 1e8;
// The lanes multiply by this where the scalar rule divides by kTileSize: the same result, as
// kTileSize is a power of two.
static_assert((kTileSize & (kTileSize - 1)) == 0);
constexpr float kInverseTileSize = 1.0f / kTileSize;
// alpha_extent's margin on the half-extents of the alpha >= min_alpha ellipse: 0.1 % + 0.01 px
// covers the rounding of sigma and of the fast exp in the blend.
constexpr double kExtentRelMargin = 1.001, kExtentAbsMargin = 0.01;

}  // namespace retimegs::render
