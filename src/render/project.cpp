// Stage 1: EWA projection (Zwicker et al. 2002) as gsplat computes it, forward and backward.
#include "retimegs/render/project.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "project_lanes.hpp"
#include "retimegs/core/error.hpp"
#include "simd.hpp"

namespace retimegs::render {
namespace {

template <typename T>
void check_size(const std::vector<T>& v, std::size_t expected, const char* field,
                const char* shape) {
  if (v.size() != expected)
    fail("gaussians.{}: has {} values, expected {} ({})", field, v.size(), expected, shape);
}

constexpr std::size_t kParallelValues = 1 << 16;  // below: one thread (fork/join would dominate)

// Whether every value is finite (exponent bits not all ones), as an or-reduction over the bits
// that the compiler vectorises, split over the threads (tens of megabytes per training step); the
// caller then looks for the first bad value only on failure.
template <typename T>
bool all_finite(const std::vector<T>& v) {
  using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
  constexpr Bits kExponent = sizeof(T) == 4 ? Bits(0x7f800000u) : Bits(0x7ff0000000000000ull);
  Bits bad = 0;
#pragma omp parallel for simd schedule(static) reduction(| : bad) if (v.size() >= kParallelValues)
  for (std::size_t k = 0; k < v.size(); ++k)
    bad |= Bits((std::bit_cast<Bits>(v[k]) & kExponent) == kExponent);
  return bad == 0;
}

template <typename T>
void check_finite(const std::vector<T>& v, int row_size, const char* field) {
  if (all_finite(v)) return;
  for (std::size_t k = 0; k < v.size(); ++k)
    if (!std::isfinite(v[k]))
      fail("gaussians.{}[{}][{}] is {} (must be finite)", field, k / row_size, k % row_size,
           double(v[k]));
}

// The Gaussian's scales, exp(log_scale) (the scalar path runs in double only).
template <typename T>
void scales_of(const GaussiansT<T>& g, std::size_t i, T (&scale)[3]) {
  for (int k = 0; k < 3; ++k) scale[k] = std::exp(g.log_scales[3 * i + k]);
}

}  // namespace

template <typename T>
void check_sizes_and_features(const GaussiansT<T>& g) {
  const std::size_t n = g.size();
  if (g.channels < 1) fail("gaussians: channel count must be >= 1, got {}", g.channels);
  check_size(g.means, 3 * n, "means", "[N, 3]");
  check_size(g.log_scales, 3 * n, "log_scales", "[N, 3]");
  check_size(g.quats, 4 * n, "quats", "[N, 4]");
  check_size(g.features, n * g.channels, "features", "[N, C]");
  check_finite(g.features, g.channels, "features");
}

template <typename T>
void check_gaussians(const GaussiansT<T>& g) {
  check_sizes_and_features(g);
  check_finite(g.means, 3, "means");
  check_finite(g.log_scales, 3, "log_scales");
  check_finite(g.quats, 4, "quats");
  check_finite(g.opacities, 1, "opacities");
  // Opacities in [0, 1] and non-zero quaternions: a vectorisable pass first, the message second.
  const std::size_t n = g.size();
  bool bad = false;
#pragma omp parallel for schedule(static) reduction(| : bad) if (n >= kParallelValues)
  for (std::size_t i = 0; i < n; ++i) {
    const T* q = &g.quats[4 * i];
    bad |= !(g.opacities[i] >= 0 && g.opacities[i] <= 1) |
           (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] == 0);
  }
  if (!bad) return;
  for (std::size_t i = 0; i < n; ++i) {
    if (!(g.opacities[i] >= 0 && g.opacities[i] <= 1))
      fail("gaussians.opacities[{}] is {} (must be in [0, 1])", i, double(g.opacities[i]));
    const T* q = &g.quats[4 * i];
    if (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] == 0)
      fail("gaussians.quats[{}] is zero (cannot be normalised)", i);
  }
}

template <typename T>
std::array<T, 2> alpha_extent(const T* conic, T opacity, const RenderOptions& options) {
  constexpr T kInf = std::numeric_limits<T>::infinity();
  if (!(options.min_alpha > 0)) return {kInf, kInf};
  // opacity * exp(-sigma) >= min_alpha  <=>  sigma <= log(opacity / min_alpha). In float,
  // bin_tiles' vector logarithm, so that both find the same rects.
  T level;
  if constexpr (std::is_same_v<T, float>)
    level = simd::log_nonnegative(simd::splat(opacity / options.min_alpha))[0];
  else
    level = std::log(opacity / T(options.min_alpha));
  T ext[2];
  alpha_extent_of_level(conic, level, ext);
  return {ext[0], ext[1]};
}

template <typename T>
TileRect blend_tile_rect(const T* mean2d, const T* conic, int radius, T opacity, int tiles_x,
                         int tiles_y, const RenderOptions& options) {
  const TileRect rect = radius_tile_rect(mean2d[0], mean2d[1], radius, tiles_x, tiles_y);
  if (!options.tight_tile_bounds || rect.area() <= 0) return rect;
  const auto [ext_x, ext_y] = alpha_extent(conic, opacity, options);
  if (!std::isfinite(ext_x) || !std::isfinite(ext_y)) return rect;
  const T ext[2] = {ext_x, ext_y};
  return cut_tile_rect(rect, mean2d, ext);
}

// One Gaussian at a time (project_gaussian, as the CUDA kernel does): the double-precision
// reference's path.
template <typename T>
ProjectedT<T> project_forward_scalar(const GaussiansT<T>& g, const PinholeT<T>& camera,
                                     const RenderOptions& options) {
  const std::size_t n = g.size();
  ProjectedT<T> out;
  out.means2d.assign(2 * n, T(0));
  out.conics.assign(3 * n, T(0));
  out.depths.assign(n, T(0));
  out.radii.assign(n, 0);
  const FovGuardT<T> lim(camera);

#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t ii = 0; ii < std::ptrdiff_t(n); ++ii) {
    const std::size_t i = std::size_t(ii);
    T scale[3];
    scales_of(g, i, scale);
    const Splat2dT<T> s = project_gaussian(&g.means[3 * i], &g.quats[4 * i], scale, g.opacities[i],
                                           camera, lim, options);
    if (s.radius <= 0) continue;
    out.means2d[2 * i] = s.mean2d[0];
    out.means2d[2 * i + 1] = s.mean2d[1];
    for (int k = 0; k < 3; ++k) out.conics[3 * i + k] = s.conic[k];
    out.depths[i] = s.depth;
    out.radii[i] = s.radius;
  }
  return out;
}

template <typename T>
void project_backward_scalar(const GaussiansT<T>& g, const PinholeT<T>& camera,
                             const ProjectedT<T>& projected, const RenderOptions& options,
                             GaussianGradsT<T>& grads) {
  const std::size_t n = g.size();
  // Every row is written below.
  grads.v_means.resize(3 * n);
  grads.v_log_scales.resize(3 * n);
  grads.v_quats.resize(4 * n);
  const FovGuardT<T> lim(camera);

#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t ii = 0; ii < std::ptrdiff_t(n); ++ii) {
    const std::size_t i = std::size_t(ii);
    if (projected.radii[i] <= 0) {
      std::fill_n(&grads.v_means[3 * i], 3, T(0));
      std::fill_n(&grads.v_log_scales[3 * i], 3, T(0));
      std::fill_n(&grads.v_quats[4 * i], 4, T(0));
      continue;
    }
    T scale[3];
    scales_of(g, i, scale);
    const ProjectionGeometryT<T> geo = projection_geometry(&g.means[3 * i], &g.quats[4 * i], scale,
                                                           camera, lim, T(options.low_pass));
    T v_mean[3], v_log_scale[3], v_quat[4];
    projection_vjp(geo, camera, T(options.centre_depth_offset), &projected.conics[3 * i],
                   &grads.v_conics[3 * i], &grads.v_means2d[2 * i], grads.v_depths[i], v_mean,
                   v_log_scale, v_quat);
    std::copy_n(v_mean, 3, &grads.v_means[3 * i]);
    std::copy_n(v_log_scale, 3, &grads.v_log_scales[3 * i]);
    std::copy_n(v_quat, 4, &grads.v_quats[4 * i]);
  }
}

// Float goes 16 Gaussians at a time (project_lanes.cpp).
template <typename T>
void project_forward(const GaussiansT<T>& g, const PinholeT<T>& camera,
                     const RenderOptions& options, ProjectedT<T>& out) {
  if constexpr (std::is_same_v<T, float>) {
    project_forward_lanes(g, camera, options, out);  // validates as it reads
  } else {
    check_gaussians(g);
    out = project_forward_scalar(g, camera, options);
  }
}

template <typename T>
ProjectedT<T> project_forward(const GaussiansT<T>& g, const PinholeT<T>& camera,
                              const RenderOptions& options) {
  ProjectedT<T> out;
  project_forward(g, camera, options, out);
  return out;
}

template <typename T>
void project_backward(const GaussiansT<T>& g, const PinholeT<T>& camera,
                      const ProjectedT<T>& projected, const RenderOptions& options,
                      GaussianGradsT<T>& grads) {
  if constexpr (std::is_same_v<T, float>) {
    project_backward_lanes(g, camera, projected, options, grads);
  } else {
    project_backward_scalar(g, camera, projected, options, grads);
  }
}

#define RETIMEGS_INSTANTIATE_PROJECT(T)                                                            \
  template void check_sizes_and_features<T>(const GaussiansT<T>&);                                 \
  template void check_gaussians<T>(const GaussiansT<T>&);                                          \
  template std::array<T, 2> alpha_extent<T>(const T*, T, const RenderOptions&);                    \
  template TileRect blend_tile_rect<T>(const T*, const T*, int, T, int, int,                       \
                                       const RenderOptions&);                                      \
  template ProjectedT<T> project_forward<T>(const GaussiansT<T>&, const PinholeT<T>&,              \
                                            const RenderOptions&);                                 \
  template void project_forward<T>(const GaussiansT<T>&, const PinholeT<T>&, const RenderOptions&, \
                                   ProjectedT<T>&);                                                \
  template void project_backward<T>(const GaussiansT<T>&, const PinholeT<T>&,                      \
                                    const ProjectedT<T>&, const RenderOptions&,                    \
                                    GaussianGradsT<T>&);
RETIMEGS_INSTANTIATE_PROJECT(float)
RETIMEGS_INSTANTIATE_PROJECT(double)
#undef RETIMEGS_INSTANTIATE_PROJECT

}  // namespace retimegs::render
