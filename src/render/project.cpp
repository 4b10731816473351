// Stage 1: EWA projection (Zwicker et al. 2002) as gsplat computes it, forward and backward.
#include "retimegs/render/project.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

#include <Eigen/Core>

#include "constants.hpp"
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

template <typename T>
using Mat3 = Eigen::Matrix<T, 3, 3>;
template <typename T>
using Mat2 = Eigen::Matrix<T, 2, 2>;
template <typename T>
using Mat23 = Eigen::Matrix<T, 2, 3>;
template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;

template <typename T>
Mat3<T> rotation_of(const PinholeT<T>& camera) {
  return Eigen::Map<const Eigen::Matrix<T, 3, 3, Eigen::RowMajor>>(camera.rotation.data());
}

// Rotation matrix of a unit quaternion (w, x, y, z).
template <typename T>
Mat3<T> quat_to_rotation(T w, T x, T y, T z) {
  Mat3<T> r;
  r << 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),  //
      2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),   //
      2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y);
  return r;
}

// Vector-Jacobian product of quat_to_rotation: d loss / d (w, x, y, z) given d loss / d R.
template <typename T>
std::array<T, 4> quat_to_rotation_vjp(T w, T x, T y, T z, const Mat3<T>& v) {
  return {2 * (-z * v(0, 1) + y * v(0, 2) + z * v(1, 0) - x * v(1, 2) - y * v(2, 0) + x * v(2, 1)),
          2 * (y * v(0, 1) + z * v(0, 2) + y * v(1, 0) - 2 * x * v(1, 1) - w * v(1, 2) +
               z * v(2, 0) + w * v(2, 1) - 2 * x * v(2, 2)),
          2 * (-2 * y * v(0, 0) + x * v(0, 1) + w * v(0, 2) + x * v(1, 0) + z * v(1, 2) -
               w * v(2, 0) + z * v(2, 1) - 2 * y * v(2, 2)),
          2 * (-2 * z * v(0, 0) - w * v(0, 1) + x * v(0, 2) + w * v(1, 0) - 2 * z * v(1, 1) +
               y * v(1, 2) + x * v(2, 0) + y * v(2, 1))};
}

// Everything the forward computes for one Gaussian that the backward needs again.
template <typename T>
struct Geometry {
  Vec3<T> p;         // camera-space mean
  T qnorm;           // |q|
  T qw, qx, qy, qz;  // normalised quaternion
  Mat3<T> rq;        // rotation of the Gaussian
  Vec3<T> scale;     // exp(log_scale)
  Mat3<T> m;         // rq * diag(scale)
  Mat3<T> cov_cam;   // camera-space 3-D covariance
  Mat23<T> jac;      // d pixel / d camera point, at the guarded point
  T tx_over_z, ty_over_z;
  bool clamped_x, clamped_y;
  Mat2<T> cov2d;  // blurred 2-D covariance
};

template <typename T>
Geometry<T> geometry(const GaussiansT<T>& g, std::size_t i, const PinholeT<T>& camera,
                     const Mat3<T>& rv, T low_pass) {
  Geometry<T> geo;
  const Vec3<T> mean(g.means[3 * i], g.means[3 * i + 1], g.means[3 * i + 2]);
  geo.p = rv * mean + Vec3<T>(camera.translation[0], camera.translation[1], camera.translation[2]);
  const T* q = &g.quats[4 * i];
  geo.qnorm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  geo.qw = q[0] / geo.qnorm, geo.qx = q[1] / geo.qnorm, geo.qy = q[2] / geo.qnorm,
  geo.qz = q[3] / geo.qnorm;
  geo.rq = quat_to_rotation(geo.qw, geo.qx, geo.qy, geo.qz);
  for (int k = 0; k < 3; ++k) geo.scale[k] = std::exp(g.log_scales[3 * i + k]);
  geo.m = geo.rq * geo.scale.asDiagonal();
  geo.cov_cam = rv * (geo.m * geo.m.transpose()) * rv.transpose();

  const T z = geo.p.z();
  const FovGuardT<T> lim(camera);
  const T xz = geo.p.x() / z, yz = geo.p.y() / z;
  geo.clamped_x = !(xz >= -lim.x_neg && xz <= lim.x_pos);
  geo.clamped_y = !(yz >= -lim.y_neg && yz <= lim.y_pos);
  geo.tx_over_z = std::clamp(xz, -lim.x_neg, lim.x_pos);
  geo.ty_over_z = std::clamp(yz, -lim.y_neg, lim.y_pos);
  geo.jac = camera.jacobian(z * geo.tx_over_z, z * geo.ty_over_z, z).matrix();
  geo.cov2d = geo.jac * geo.cov_cam * geo.jac.transpose();
  geo.cov2d(0, 0) += low_pass;
  geo.cov2d(1, 1) += low_pass;
  return geo;
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
TileRect radius_tile_rect(T u, T v, int radius, int tiles_x, int tiles_y) {
  const T lim = T(kMaxPixelCoordinate), tile = T(kTileSize);
  u = std::clamp(u, -lim, lim);
  v = std::clamp(v, -lim, lim);
  // C-style casts truncate toward zero, as gsplat v0.1.13 does.
  TileRect r;
  r.x0 = std::clamp(int(u / tile - T(radius) / tile), 0, tiles_x);
  r.x1 = std::clamp(int(u / tile + T(radius) / tile) + 1, 0, tiles_x);
  r.y0 = std::clamp(int(v / tile - T(radius) / tile), 0, tiles_y);
  r.y1 = std::clamp(int(v / tile + T(radius) / tile) + 1, 0, tiles_y);
  return r;
}

template <typename T>
std::array<T, 2> alpha_extent(const T* conic, T opacity, const RenderOptions& options) {
  constexpr T kInf = std::numeric_limits<T>::infinity();
  if (!(options.min_alpha > 0)) return {kInf, kInf};
  // opacity * exp(-sigma) >= min_alpha  <=>  sigma <= log(opacity / min_alpha). For a fixed
  // offset dy, min over dx of sigma = dy^2 / (2 cov_yy), with cov = conic^-1; likewise for dx.
  // In float, bin_tiles' vector logarithm, so that both find the same rects.
  T level;
  if constexpr (std::is_same_v<T, float>)
    level = simd::log_nonnegative(simd::splat(opacity / options.min_alpha))[0];
  else
    level = std::log(opacity / T(options.min_alpha));
  if (!(level > 0)) return {0, 0};
  const T det = conic[0] * conic[2] - conic[1] * conic[1];
  const T cov_xx = conic[2] / det, cov_yy = conic[0] / det;
  constexpr T kRelMargin = T(kExtentRelMargin), kAbsMargin = T(kExtentAbsMargin);
  return {std::sqrt(2 * level * cov_xx) * kRelMargin + kAbsMargin,
          std::sqrt(2 * level * cov_yy) * kRelMargin + kAbsMargin};
}

template <typename T>
TileRect blend_tile_rect(const T* mean2d, const T* conic, int radius, T opacity, int tiles_x,
                         int tiles_y, const RenderOptions& options) {
  TileRect rect = radius_tile_rect(mean2d[0], mean2d[1], radius, tiles_x, tiles_y);
  if (!options.tight_tile_bounds || rect.area() <= 0) return rect;
  const auto ext = alpha_extent(conic, opacity, options);
  if (!std::isfinite(ext[0]) || !std::isfinite(ext[1])) return rect;
  const T lim = T(kMaxPixelCoordinate), tile = T(kTileSize);
  const auto floor_tile = [&](T coordinate) {
    return int(std::floor(std::clamp(coordinate, -lim, lim) / tile));
  };
  rect.x0 = std::max(rect.x0, floor_tile(mean2d[0] - ext[0]));
  rect.x1 = std::min(rect.x1, floor_tile(mean2d[0] + ext[0]) + 1);
  rect.y0 = std::max(rect.y0, floor_tile(mean2d[1] - ext[1]));
  rect.y1 = std::min(rect.y1, floor_tile(mean2d[1] + ext[1]) + 1);
  if (rect.x1 <= rect.x0 || rect.y1 <= rect.y0) rect = TileRect{};
  return rect;
}

// One Gaussian at a time: the double-precision reference's path.
template <typename T>
ProjectedT<T> project_forward_scalar(const GaussiansT<T>& g, const PinholeT<T>& camera,
                                     const RenderOptions& options) {
  const std::size_t n = g.size();
  ProjectedT<T> out;
  out.means2d.assign(2 * n, T(0));
  out.conics.assign(3 * n, T(0));
  out.depths.assign(n, T(0));
  out.radii.assign(n, 0);
  const Mat3<T> rv = rotation_of(camera);
  const int tiles_x = tile_count(camera.width);
  const int tiles_y = tile_count(camera.height);
  const T min_opacity = std::max(T(options.min_alpha), T(0));

#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t ii = 0; ii < std::ptrdiff_t(n); ++ii) {
    const std::size_t i = std::size_t(ii);
    const T opacity = g.opacities[i];
    if (!(opacity > 0) || opacity < min_opacity) continue;
    const T z_early = g.means[3 * i] * camera.rotation[6] +
                      g.means[3 * i + 1] * camera.rotation[7] +
                      g.means[3 * i + 2] * camera.rotation[8] + camera.translation[2];
    if (!(z_early >= T(options.near_plane))) continue;  // before the costlier geometry
    const Geometry<T> geo = geometry(g, i, camera, rv, T(options.low_pass));
    const T z = geo.p.z();
    const Mat2<T>& cov = geo.cov2d;
    const T det = cov(0, 0) * cov(1, 1) - cov(0, 1) * cov(0, 1);
    if (!(det > 0)) continue;
    const T b = T(0.5) * (cov(0, 0) + cov(1, 1));
    const T lambda = b + std::sqrt(std::max(b * b - det, T(kRadiusDiscriminantFloor)));
    const int radius = int(std::ceil(T(kRadiusSigmas) * std::sqrt(lambda)));
    const T zc = z + T(options.centre_depth_offset);
    const auto [u, v] = camera.project(geo.p.x(), geo.p.y(), zc);
    if (radius_tile_rect(u, v, radius, tiles_x, tiles_y).area() <= 0) continue;
    out.means2d[2 * i] = u;
    out.means2d[2 * i + 1] = v;
    out.conics[3 * i] = cov(1, 1) / det;
    out.conics[3 * i + 1] = -cov(0, 1) / det;
    out.conics[3 * i + 2] = cov(0, 0) / det;
    out.depths[i] = z;
    out.radii[i] = radius;
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
  const Mat3<T> rv = rotation_of(camera);

#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t ii = 0; ii < std::ptrdiff_t(n); ++ii) {
    const std::size_t i = std::size_t(ii);
    if (projected.radii[i] <= 0) {
      std::fill_n(&grads.v_means[3 * i], 3, T(0));
      std::fill_n(&grads.v_log_scales[3 * i], 3, T(0));
      std::fill_n(&grads.v_quats[4 * i], 4, T(0));
      continue;
    }
    const Geometry<T> geo = geometry(g, i, camera, rv, T(options.low_pass));
    const T z = geo.p.z(), x = geo.p.x(), y = geo.p.y();

    // conic = cov2d^-1: d loss / d cov2d = -conic * V * conic, V the symmetric form of v_conics.
    const T* vc = &grads.v_conics[3 * i];
    Mat2<T> conic, v_conic;
    conic << projected.conics[3 * i], projected.conics[3 * i + 1], projected.conics[3 * i + 1],
        projected.conics[3 * i + 2];
    v_conic << vc[0], T(0.5) * vc[1], T(0.5) * vc[1], vc[2];
    const Mat2<T> v_cov2d = -conic * v_conic * conic;

    // cov2d = J cov_cam J^T (+ low-pass, constant).
    const Mat23<T> v_jac = 2 * v_cov2d * geo.jac * geo.cov_cam;
    const Mat3<T> v_cov_cam = geo.jac.transpose() * v_cov2d * geo.jac;
    // cov_cam = Rv (M M^T) Rv^T, M = Rq diag(s).
    const Mat3<T> v_cov3d = rv.transpose() * v_cov_cam * rv;
    const Mat3<T> v_m = 2 * v_cov3d * geo.m;
    const Mat3<T> v_rq = v_m * geo.scale.asDiagonal();
    for (int k = 0; k < 3; ++k) {
      const T v_scale = v_m.col(k).dot(geo.rq.col(k));
      grads.v_log_scales[3 * i + k] = v_scale * geo.scale[k];
    }
    const auto v_qhat = quat_to_rotation_vjp(geo.qw, geo.qx, geo.qy, geo.qz, v_rq);
    const T qhat[4] = {geo.qw, geo.qx, geo.qy, geo.qz};
    const T dot =
        qhat[0] * v_qhat[0] + qhat[1] * v_qhat[1] + qhat[2] * v_qhat[2] + qhat[3] * v_qhat[3];
    for (int k = 0; k < 4; ++k) grads.v_quats[4 * i + k] = (v_qhat[k] - qhat[k] * dot) / geo.qnorm;

    // Camera-space mean: through the pixel centre, the Jacobian and the depth.
    const T v_u = grads.v_means2d[2 * i], v_v = grads.v_means2d[2 * i + 1];
    const T rzc = 1 / (z + T(options.centre_depth_offset));
    Vec3<T> v_p(camera.fx * rzc * v_u, camera.fy * rzc * v_v,
                -(camera.fx * x * v_u + camera.fy * y * v_v) * rzc * rzc + grads.v_depths[i]);
    // Through the Jacobian, taken at the guarded point (z tx_over_z, z ty_over_z, z).
    const auto [v_tx, v_ty, v_z] = camera.jacobian_vjp(
        z * geo.tx_over_z, z * geo.ty_over_z, z,
        PinholeJacobianT<T>{v_jac(0, 0), v_jac(0, 2), v_jac(1, 1), v_jac(1, 2)});
    v_p.z() += v_z;
    if (geo.clamped_x) {
      v_p.z() += v_tx * geo.tx_over_z;
    } else {
      v_p.x() += v_tx;
    }
    if (geo.clamped_y) {
      v_p.z() += v_ty * geo.ty_over_z;
    } else {
      v_p.y() += v_ty;
    }
    const Vec3<T> v_mean = rv.transpose() * v_p;
    for (int k = 0; k < 3; ++k) grads.v_means[3 * i + k] = v_mean[k];
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
  template TileRect radius_tile_rect<T>(T, T, int, int, int);                                      \
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
