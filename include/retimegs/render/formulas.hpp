#pragma once
// The rasteriser's per-Gaussian and per-pixel formulas, written once for both devices (DESIGN.md
// §3): the CPU stages (project.cpp, project_lanes.cpp, bin_tiles.cpp, blend.cpp, reference.cpp)
// and the CUDA kernels (src/cuda/) call these, so that CI's CPU tests exercise the math the GPU
// runs. Templates on a value type V do arithmetic only, in a fixed order, so that they take a
// scalar (float, double) as well as the CPU's simd lanes (one Gaussian per lane); T is then the
// scalar type of the constants. Functions on a scalar T alone may branch.
#include <array>
#include <cmath>
#include <cstdint>

#include "retimegs/core/hd.hpp"
#include "retimegs/core/pinhole.hpp"
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
// The blend computes alpha as 2^(log2(opacity) - sigma log2(e)) (log2_alpha).
constexpr float kLog2e = 1.44269504088896341f, kLn2 = 0.693147180559945f;

// std::min, std::max and std::clamp with their exact comparisons (and so their NaN results),
// which device code cannot call (they are constexpr host functions for nvcc).
template <typename T>
RETIMEGS_HD inline T min_of(T a, T b) {
  return b < a ? b : a;
}
template <typename T>
RETIMEGS_HD inline T max_of(T a, T b) {
  return a < b ? b : a;
}
template <typename T>
RETIMEGS_HD inline T clamp_to(T x, T lo, T hi) {
  return x < lo ? lo : hi < x ? hi : x;
}

// ---------------------------------------------------------------------------------------------
// Fast exponentials: the blend's alphas (and the float projection's scales) on both devices.

// 2^f for f in [0, 1) by 1 + f q(f), q the degree-4 polynomial of least maximum relative error
// (Lawson's iteration on 4001 points; float coefficients): 2^0 exactly, 2e-7 relative in float
// arithmetic. Evaluated by Estrin's scheme, (1 + c1 f) + f^2 ((c2 + c3 f) + f^2 (c4 + c5 f)):
// three multiply-adds deep instead of Horner's five. The blend waits on this chain for every
// Gaussian-pixel pair; the shorter chain lets more pairs overlap.
template <typename V>
RETIMEGS_HD inline V exp2_fraction(V f) {
  const V f2 = f * f;
  const V low = f * 0.693151295f + 1.0f;
  const V mid = f * 0.055799935f + 0.240164444f;
  const V high = f * 0.00186714449f + 0.00901699997f;
  return low + f2 * (mid + f2 * high);
}

// 2^y for y < 128 as 2^floor(y) * exp2_fraction(y - floor(y)) (the CPU's simd::exp2, one
// value); y below -126 counts as -126 (the result, ~1e-38, is far under every threshold).
RETIMEGS_HD inline float exp2_approx(float y) {
  constexpr float kMinExponent = -126.0f;
  const float c = y < kMinExponent ? kMinExponent : y;  // also maps NaN to NaN
  const float n = std::floor(c);
  return std::ldexp(exp2_fraction(c - n), int(n));
}

// ---------------------------------------------------------------------------------------------
// Projection (stage 1): EWA splatting as gsplat computes it.

// The field-of-view guard's bounds for one camera (kFovGuard): x/z in [-x_neg, x_pos] and y/z in
// [-y_neg, y_pos].
template <typename T>
struct FovGuardT {
  T x_pos, x_neg, y_pos, y_neg;

  RETIMEGS_HD explicit FovGuardT(const PinholeT<T>& camera) {
    const T tan_x = T(0.5) * camera.width / camera.fx, tan_y = T(0.5) * camera.height / camera.fy;
    x_pos = (camera.width - camera.cx) / camera.fx + T(kFovGuard) * tan_x;
    x_neg = camera.cx / camera.fx + T(kFovGuard) * tan_x;
    y_pos = (camera.height - camera.cy) / camera.fy + T(kFovGuard) * tan_y;
    y_neg = camera.cy / camera.fy + T(kFovGuard) * tan_y;
  }
};

// Symmetric 3x3 matrices keep 6 entries: 00 01 02 11 12 22; entry (i, j) is sym(i, j).
RETIMEGS_HD constexpr int sym(int i, int j) {
  const int lo = i < j ? i : j, hi = i < j ? j : i;
  return lo * (5 - lo) / 2 + hi;
}

// Rotation matrix [3, 3] (row-major) of the unit quaternion (w, x, y, z).
template <typename V>
RETIMEGS_HD inline void quat_to_rotation(V w, V x, V y, V z, V (&r)[9]) {
  r[0] = 1 - 2 * (y * y + z * z), r[1] = 2 * (x * y - w * z), r[2] = 2 * (x * z + w * y);
  r[3] = 2 * (x * y + w * z), r[4] = 1 - 2 * (x * x + z * z), r[5] = 2 * (y * z - w * x);
  r[6] = 2 * (x * z - w * y), r[7] = 2 * (y * z + w * x), r[8] = 1 - 2 * (x * x + y * y);
}

// Vector-Jacobian product of quat_to_rotation: d loss / d (w, x, y, z) given d loss / d R.
template <typename V>
RETIMEGS_HD inline void quat_to_rotation_vjp(V w, V x, V y, V z, const V (&v)[3][3], V (&v_q)[4]) {
  v_q[0] = 2 * (-z * v[0][1] + y * v[0][2] + z * v[1][0] - x * v[1][2] - y * v[2][0] + x * v[2][1]);
  v_q[1] = 2 * (y * v[0][1] + z * v[0][2] + y * v[1][0] - 2 * x * v[1][1] - w * v[1][2] +
                z * v[2][0] + w * v[2][1] - 2 * x * v[2][2]);
  v_q[2] = 2 * (-2 * y * v[0][0] + x * v[0][1] + w * v[0][2] + x * v[1][0] + z * v[1][2] -
                w * v[2][0] + z * v[2][1] - 2 * y * v[2][2]);
  v_q[3] = 2 * (-2 * z * v[0][0] - w * v[0][1] + x * v[0][2] + w * v[1][0] - 2 * z * v[1][1] +
                y * v[1][2] + x * v[2][0] + y * v[2][1]);
}

// The normalisation q / |q|: d loss / d q given d loss / d (q / |q|) = v_qhat.
template <typename V>
RETIMEGS_HD inline void normalize_quat_vjp(const V (&qhat)[4], V qnorm, const V (&v_qhat)[4],
                                           V (&v_q)[4]) {
  const V dot =
      qhat[0] * v_qhat[0] + qhat[1] * v_qhat[1] + qhat[2] * v_qhat[2] + qhat[3] * v_qhat[3];
  for (int k = 0; k < 4; ++k) v_q[k] = (v_qhat[k] - qhat[k] * dot) / qnorm;
}

// M = R diag(scale) and the world-space covariance M M^T (symmetric).
template <typename V>
RETIMEGS_HD inline void world_covariance(const V (&r)[9], const V (&scale)[3], V (&m)[9],
                                         V (&cov)[6]) {
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) m[3 * i + k] = r[3 * i + k] * scale[k];
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j)
      cov[sym(i, j)] =
          m[3 * i] * m[3 * j] + m[3 * i + 1] * m[3 * j + 1] + m[3 * i + 2] * m[3 * j + 2];
}

// Camera-space covariance Rv cov_world Rv^T (symmetric), Rv the camera's rotation [3, 3].
template <typename T, typename V>
RETIMEGS_HD inline void camera_covariance(const T (&rv)[9], const V (&cov_world)[6],
                                          V (&cov_cam)[6]) {
  V rc[9];  // Rv cov_world
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      rc[3 * i + j] = rv[3 * i] * cov_world[sym(0, j)] + rv[3 * i + 1] * cov_world[sym(1, j)] +
                      rv[3 * i + 2] * cov_world[sym(2, j)];
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j)
      cov_cam[sym(i, j)] =
          rc[3 * i] * rv[3 * j] + rc[3 * i + 1] * rv[3 * j + 1] + rc[3 * i + 2] * rv[3 * j + 2];
}

// The blurred 2-D covariance J cov_cam J^T + low_pass I (00 01 11), and J cov_cam [2, 3], which
// the backward needs again.
template <typename T, typename V>
RETIMEGS_HD inline void image_covariance(const PinholeJacobianT<V>& jac, const V (&c)[6],
                                         T low_pass, V (&jc)[2][3], V (&cov2d)[3]) {
  for (int j = 0; j < 3; ++j) {
    jc[0][j] = jac.j00 * c[sym(0, j)] + jac.j02 * c[sym(2, j)];
    jc[1][j] = jac.j11 * c[sym(1, j)] + jac.j12 * c[sym(2, j)];
  }
  cov2d[0] = jc[0][0] * jac.j00 + jc[0][2] * jac.j02 + low_pass;
  cov2d[1] = jc[0][1] * jac.j11 + jc[0][2] * jac.j12;
  cov2d[2] = jc[1][1] * jac.j11 + jc[1][2] * jac.j12 + low_pass;
}

template <typename V>
RETIMEGS_HD inline V determinant2(const V (&cov2d)[3]) {
  return cov2d[0] * cov2d[2] - cov2d[1] * cov2d[1];
}

// The conic (a, b, c): the inverse [[a, b], [b, c]] of the 2-D covariance, det its determinant.
template <typename V>
RETIMEGS_HD inline void conic_of(const V (&cov2d)[3], V det, V (&conic)[3]) {
  conic[0] = cov2d[2] / det, conic[1] = -cov2d[1] / det, conic[2] = cov2d[0] / det;
}

// The larger eigenvalue of the 2-D covariance (gsplat v0.1.13 compute_radius), whose 3 sigma
// ceil'd is the radius.
template <typename T>
RETIMEGS_HD inline T major_eigenvalue(const T (&cov2d)[3], T det) {
  const T half_trace = T(0.5) * (cov2d[0] + cov2d[2]);
  return half_trace + std::sqrt(max_of(half_trace * half_trace - det, T(kRadiusDiscriminantFloor)));
}
template <typename T>
RETIMEGS_HD inline int radius_of(T lambda) {
  return int(std::ceil(T(kRadiusSigmas) * std::sqrt(lambda)));
}

// conic = cov2d^-1: d loss / d cov2d = -conic V conic, V the symmetric form of v_conic; returned
// as the full 2x2.
template <typename T, typename V>
RETIMEGS_HD inline void conic_vjp(const V (&conic)[3], const V (&v_conic)[3], V (&v_cov2d)[2][2]) {
  const V ca = conic[0], cb = conic[1], cc = conic[2];
  const V va = v_conic[0], vb = T(0.5) * v_conic[1], vc = v_conic[2];
  const V cv[2][2] = {{ca * va + cb * vb, ca * vb + cb * vc},
                      {cb * va + cc * vb, cb * vb + cc * vc}};
  v_cov2d[0][0] = -(cv[0][0] * ca + cv[0][1] * cb);
  v_cov2d[0][1] = -(cv[0][0] * cb + cv[0][1] * cc);
  v_cov2d[1][0] = -(cv[1][0] * ca + cv[1][1] * cb);
  v_cov2d[1][1] = -(cv[1][0] * cb + cv[1][1] * cc);
}

// The vector-Jacobian product of cov2d = J cov_cam J^T + low-pass (image_covariance) and of
// cov_cam = Rv M M^T Rv^T, M = R diag(scale) (camera_covariance, world_covariance): d loss / d J
// (the Jacobian's four entries), d loss / d R and d loss / d log_scale.
template <typename T, typename V>
RETIMEGS_HD inline void covariance_vjp(const PinholeJacobianT<V>& jac, const V (&jc)[2][3],
                                       const T (&rv)[9], const V (&r)[9], const V (&scale)[3],
                                       const V (&m)[9], const V (&v_cov2d)[2][2],
                                       PinholeJacobianT<V>& v_jac_out, V (&v_r)[3][3],
                                       V (&v_log_scale)[3]) {
  // v_jac = 2 v_cov2d J cov_cam, v_cov_cam = J^T v_cov2d J.
  V v_jac[2][3];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j)
      v_jac[i][j] = 2 * (v_cov2d[i][0] * jc[0][j] + v_cov2d[i][1] * jc[1][j]);
  v_jac_out = {v_jac[0][0], v_jac[0][2], v_jac[1][1], v_jac[1][2]};
  const V zero{};
  const V j[2][3] = {{jac.j00, zero, jac.j02}, {zero, jac.j11, jac.j12}};
  V wj[2][3];  // v_cov2d J
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < 3; ++k) wj[i][k] = v_cov2d[i][0] * j[0][k] + v_cov2d[i][1] * j[1][k];
  V v_cov_cam[3][3];
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) v_cov_cam[i][k] = j[0][i] * wj[0][k] + j[1][i] * wj[1][k];
  // v_cov_world = Rv^T v_cov_cam Rv.
  V tmp[3][3], v_cov3d[3][3];  // v_cov_cam Rv, Rv^T v_cov_cam Rv
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k)
      tmp[i][k] =
          v_cov_cam[i][0] * rv[k] + v_cov_cam[i][1] * rv[3 + k] + v_cov_cam[i][2] * rv[6 + k];
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k)
      v_cov3d[i][k] = rv[i] * tmp[0][k] + rv[3 + i] * tmp[1][k] + rv[6 + i] * tmp[2][k];
  // v_m = 2 v_cov3d M, v_r = v_m diag(scale), v_scale_k = column k of v_m . column k of R.
  V v_m[3][3];
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) {
      v_m[i][k] = 2 * (v_cov3d[i][0] * m[k] + v_cov3d[i][1] * m[3 + k] + v_cov3d[i][2] * m[6 + k]);
      v_r[i][k] = v_m[i][k] * scale[k];
    }
  for (int k = 0; k < 3; ++k) {
    const V v_scale = v_m[0][k] * r[k] + v_m[1][k] * r[3 + k] + v_m[2][k] * r[6 + k];
    v_log_scale[k] = v_scale * scale[k];
  }
}

// d loss / d (camera-space mean) through the pixel centre u = fx x / (z + offset) + cx (and v)
// and the depth z: v_p before the Jacobian's share.
template <typename T, typename V>
RETIMEGS_HD inline void mean2d_vjp(const PinholeT<T>& camera, V x, V y, V z, T centre_depth_offset,
                                   V v_u, V v_v, V v_depth, V (&v_p)[3]) {
  const V rzc = 1 / (z + centre_depth_offset);
  v_p[0] = camera.fx * rzc * v_u;
  v_p[1] = camera.fy * rzc * v_v;
  v_p[2] = -(camera.fx * x * v_u + camera.fy * y * v_v) * rzc * rzc + v_depth;
}

// d loss / d (world mean) = Rv^T d loss / d (camera-space mean).
template <typename T, typename V>
RETIMEGS_HD inline void world_mean_vjp(const T (&rv)[9], const V (&v_p)[3], V (&v_mean)[3]) {
  for (int k = 0; k < 3; ++k) v_mean[k] = rv[k] * v_p[0] + rv[3 + k] * v_p[1] + rv[6 + k] * v_p[2];
}

// e^x for |x| < 87 (log-scales) as the CPU's float projection computes it: 2^(x log2(e)) by
// exp2_approx (below).
RETIMEGS_HD inline float exp_approx(float x) {
  return exp2_approx(x * kLog2e);
}

// Everything the projection of one Gaussian computes that its backward needs again, in one scalar
// type (the CPU's simd lanes keep the same values per lane: project_lanes.cpp).
template <typename T>
struct ProjectionGeometryT {
  T p[3];                  // camera-space mean
  T qnorm, q[4];           // |q| and the normalised quaternion (w, x, y, z)
  T r[9];                  // [3, 3] rotation of the Gaussian
  T scale[3];              // exp(log_scale)
  T m[9];                  // [3, 3] r diag(scale)
  T cov_cam[6];            // camera-space 3-D covariance
  T jc[2][3];              // [2, 3] J cov_cam
  T tx_over_z, ty_over_z;  // guarded x/z, y/z
  bool clamped_x, clamped_y;
  PinholeJacobianT<T> jac;  // d pixel / d camera point, at the guarded point
  T cov2d[3];               // blurred 2-D covariance: 00 01 11
};

// mean [3], quat [4] (any non-zero norm), scale [3] = exp(log_scale).
template <typename T>
RETIMEGS_HD inline ProjectionGeometryT<T> projection_geometry(const T* mean, const T* quat,
                                                              const T (&scale)[3],
                                                              const PinholeT<T>& camera,
                                                              const FovGuardT<T>& lim, T low_pass) {
  ProjectionGeometryT<T> geo;
  const auto [px, py, pz] = camera.to_camera(mean[0], mean[1], mean[2]);
  geo.p[0] = px, geo.p[1] = py, geo.p[2] = pz;
  geo.qnorm =
      std::sqrt(quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2] + quat[3] * quat[3]);
  for (int k = 0; k < 4; ++k) geo.q[k] = quat[k] / geo.qnorm;
  quat_to_rotation(geo.q[0], geo.q[1], geo.q[2], geo.q[3], geo.r);
  for (int k = 0; k < 3; ++k) geo.scale[k] = scale[k];
  T cov_world[6];
  world_covariance(geo.r, geo.scale, geo.m, cov_world);
  camera_covariance(camera.rotation, cov_world, geo.cov_cam);
  const T z = geo.p[2];
  const T xz = geo.p[0] / z, yz = geo.p[1] / z;
  geo.clamped_x = !(xz >= -lim.x_neg && xz <= lim.x_pos);
  geo.clamped_y = !(yz >= -lim.y_neg && yz <= lim.y_pos);
  geo.tx_over_z = clamp_to(xz, -lim.x_neg, lim.x_pos);
  geo.ty_over_z = clamp_to(yz, -lim.y_neg, lim.y_pos);
  geo.jac = camera.jacobian(z * geo.tx_over_z, z * geo.ty_over_z, z);
  image_covariance(geo.jac, geo.cov_cam, low_pass, geo.jc, geo.cov2d);
  return geo;
}

// The vector-Jacobian product of one Gaussian's projection: d loss / d (mean, log_scale, raw
// quaternion) given d loss / d (mean2d, conic, depth). Clamped directions of the field-of-view
// guard get zero gradient, as in gsplat (x/z is then a constant times z).
template <typename T>
RETIMEGS_HD inline void projection_vjp(const ProjectionGeometryT<T>& geo, const PinholeT<T>& camera,
                                       T centre_depth_offset, const T* conic, const T* v_conic,
                                       const T* v_mean2d, T v_depth, T (&v_mean)[3],
                                       T (&v_log_scale)[3], T (&v_quat)[4]) {
  const T conic3[3] = {conic[0], conic[1], conic[2]};
  const T v_conic3[3] = {v_conic[0], v_conic[1], v_conic[2]};
  T v_cov2d[2][2];
  conic_vjp<T>(conic3, v_conic3, v_cov2d);
  PinholeJacobianT<T> v_jac;
  T v_r[3][3];
  covariance_vjp(geo.jac, geo.jc, camera.rotation, geo.r, geo.scale, geo.m, v_cov2d, v_jac, v_r,
                 v_log_scale);
  T v_qhat[4];
  quat_to_rotation_vjp(geo.q[0], geo.q[1], geo.q[2], geo.q[3], v_r, v_qhat);
  normalize_quat_vjp(geo.q, geo.qnorm, v_qhat, v_quat);
  // Camera-space mean: through the pixel centre and the depth, then the Jacobian, taken at the
  // guarded point (z tx_over_z, z ty_over_z, z).
  const T x = geo.p[0], y = geo.p[1], z = geo.p[2];
  T v_p[3];
  mean2d_vjp(camera, x, y, z, centre_depth_offset, v_mean2d[0], v_mean2d[1], v_depth, v_p);
  const auto [v_tx, v_ty, v_z] =
      camera.jacobian_vjp(z * geo.tx_over_z, z * geo.ty_over_z, z, v_jac);
  v_p[2] += v_z;
  if (geo.clamped_x) {
    v_p[2] += v_tx * geo.tx_over_z;
  } else {
    v_p[0] += v_tx;
  }
  if (geo.clamped_y) {
    v_p[2] += v_ty * geo.ty_over_z;
  } else {
    v_p[1] += v_ty;
  }
  world_mean_vjp(camera.rotation, v_p, v_mean);
}

// ---------------------------------------------------------------------------------------------
// Tiles (stage 2).

// Tiles [x0, x1) x [y0, y1) that a 2-D Gaussian is binned into.
struct TileRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  RETIMEGS_HD int area() const { return (x1 - x0) * (y1 - y0); }
  RETIMEGS_HD bool contains(int tx, int ty) const {
    return tx >= x0 && tx < x1 && ty >= y0 && ty < y1;
  }
};

// The radius rule of gsplat v0.1.13 (get_tile_bbox): tiles within `radius` pixels of the centre,
// truncating toward zero, so that a Gaussian just left of or above the image still reaches tile 0.
template <typename T>
RETIMEGS_HD inline TileRect radius_tile_rect(T u, T v, int radius, int tiles_x, int tiles_y) {
  const T lim = T(kMaxPixelCoordinate), tile = T(kTileSize);
  u = clamp_to(u, -lim, lim);
  v = clamp_to(v, -lim, lim);
  // C-style casts truncate toward zero, as gsplat v0.1.13 does.
  TileRect r;
  r.x0 = clamp_to(int(u / tile - T(radius) / tile), 0, tiles_x);
  r.x1 = clamp_to(int(u / tile + T(radius) / tile) + 1, 0, tiles_x);
  r.y0 = clamp_to(int(v / tile - T(radius) / tile), 0, tiles_y);
  r.y1 = clamp_to(int(v / tile + T(radius) / tile) + 1, 0, tiles_y);
  return r;
}

// Half-extents (pixels) of the region where sigma <= level (opacity * exp(-sigma) >= min_alpha
// for level = ln(opacity / min_alpha)), with a margin for rounding; zero when level <= 0. For a
// fixed offset dy, min over dx of sigma = dy^2 / (2 cov_yy), with cov = conic^-1; likewise for dx.
template <typename T>
RETIMEGS_HD inline void alpha_extent_of_level(const T* conic, T level, T (&ext)[2]) {
  if (!(level > 0)) {
    ext[0] = ext[1] = T(0);
    return;
  }
  const T det = conic[0] * conic[2] - conic[1] * conic[1];
  const T cov_xx = conic[2] / det, cov_yy = conic[0] / det;
  constexpr T kRelMargin = T(kExtentRelMargin), kAbsMargin = T(kExtentAbsMargin);
  ext[0] = std::sqrt(2 * level * cov_xx) * kRelMargin + kAbsMargin;
  ext[1] = std::sqrt(2 * level * cov_yy) * kRelMargin + kAbsMargin;
}

// `rect` (radius_tile_rect) cut to the tiles that the half-extents `ext` around mean2d reach;
// empty when nothing is left.
template <typename T>
RETIMEGS_HD inline TileRect cut_tile_rect(TileRect rect, const T* mean2d, const T (&ext)[2]) {
  const T lim = T(kMaxPixelCoordinate), tile = T(kTileSize);
  const auto floor_tile = [&](T coordinate) {
    return int(std::floor(clamp_to(coordinate, -lim, lim) / tile));
  };
  rect.x0 = max_of(rect.x0, floor_tile(mean2d[0] - ext[0]));
  rect.x1 = min_of(rect.x1, floor_tile(mean2d[0] + ext[0]) + 1);
  rect.y0 = max_of(rect.y0, floor_tile(mean2d[1] - ext[1]));
  rect.y1 = min_of(rect.y1, floor_tile(mean2d[1] + ext[1]) + 1);
  if (rect.x1 <= rect.x0 || rect.y1 <= rect.y0) rect = TileRect{};
  return rect;
}

// One Gaussian's 2-D image; radius 0 = culled (the other values are then unset).
template <typename T>
struct Splat2dT {
  T mean2d[2];  // pixel coordinates (u, v), pixel centres at +0.5
  T conic[3];   // (a, b, c) of the inverse 2-D covariance
  T depth;      // camera z
  int radius;   // ceil(3 sigma_max) in pixels
};

// The projection of one Gaussian with its culling (project_forward's rules): culled when opacity
// <= 0 or < min_alpha (it could never be composited), camera z < near_plane (tested before the
// costlier geometry), the blurred 2-D covariance is singular, or the radius rule's tile rectangle
// is empty (off image).
template <typename T>
RETIMEGS_HD inline Splat2dT<T> project_gaussian(const T* mean, const T* quat, const T (&scale)[3],
                                                T opacity, const PinholeT<T>& camera,
                                                const FovGuardT<T>& lim,
                                                const RenderOptions& options) {
  Splat2dT<T> out;
  out.radius = 0;
  const T min_opacity = max_of(T(options.min_alpha), T(0));
  if (!(opacity > 0) || opacity < min_opacity) return out;
  const auto [x_early, y_early, z_early] = camera.to_camera(mean[0], mean[1], mean[2]);
  if (!(z_early >= T(options.near_plane))) return out;
  const ProjectionGeometryT<T> geo =
      projection_geometry(mean, quat, scale, camera, lim, T(options.low_pass));
  const T det = determinant2(geo.cov2d);
  if (!(det > 0)) return out;
  const int radius = radius_of(major_eigenvalue(geo.cov2d, det));
  const T zc = geo.p[2] + T(options.centre_depth_offset);
  const auto [u, v] = camera.project(geo.p[0], geo.p[1], zc);
  if (radius_tile_rect(u, v, radius, tile_count(camera.width), tile_count(camera.height)).area() <=
      0)
    return out;
  out.mean2d[0] = u;
  out.mean2d[1] = v;
  T conic[3];
  conic_of(geo.cov2d, det, conic);
  for (int k = 0; k < 3; ++k) out.conic[k] = conic[k];
  out.depth = geo.p[2];
  out.radius = radius;
  return out;
}

// ---------------------------------------------------------------------------------------------
// Compositing (stage 3).

// A 2-D Gaussian as the blend evaluates it: the conic scaled so that sigma log2(e) comes out of
// log2_alpha, and log2(opacity).
template <typename T>
struct BlendConicT {
  T half_a, b, half_c, log2_opacity;  // a log2(e) / 2, b log2(e), c log2(e) / 2
};
RETIMEGS_HD inline BlendConicT<float> blend_conic(const float* conic, float opacity) {
  return {0.5f * kLog2e * conic[0], kLog2e * conic[1], 0.5f * kLog2e * conic[2],
          std::log2(opacity)};
}

// log2 of alpha before the clamp, log2(opacity) - sigma log2(e), with sigma = 0.5 (a dx^2 +
// c dy^2) + b dx dy (gsplat's convention), dx, dy = mean2d - pixel centre: three multiply-adds
// and two multiplies. sigma >= 0 for a positive-definite conic, so (unlike gsplat) there is no
// sigma < 0 test.
template <typename V>
RETIMEGS_HD inline V log2_alpha(V half_a, V b, V half_c, V log2_opacity, V dx, V dy) {
  return (log2_opacity - (half_c * dy) * dy) - dx * (half_a * dx + b * dy);
}

// The transmittance under which compositing stops, as one `<` test: T' <= t  <=>
// T' < nextafter(t, +inf) for floats (StopRule).
inline float stop_below(const RenderOptions& options) {
  return options.stop_rule == StopRule::kAtOrBelow
             ? std::nextafter(options.min_transmittance, INFINITY)
             : options.min_transmittance;
}

// sigma's vector-Jacobian product for one pixel: with w = -d loss / d sigma, d loss / d (u, v) =
// -w (a dx + b dy, b dx + c dy) and d loss / d (a, b, c) = -w (dx^2 / 2, dx dy, dy^2 / 2). The
// blends sum (w, w dx, w dy, w dx^2, w dx dy, w dy^2) over a Gaussian's pixels first and combine
// once (sigma_vjp_combine).
template <typename V>
struct SigmaSumsT {
  V w, w_dx, w_dy, w_dx2, w_dxdy, w_dy2;
};
template <typename V>
RETIMEGS_HD inline void sigma_vjp_accumulate(V w, V dx, V dy, SigmaSumsT<V>& s) {
  const V w_dx = w * dx, w_dy = w * dy;
  s.w += w;
  s.w_dx += w_dx;
  s.w_dy += w_dy;
  s.w_dx2 += w_dx * dx;
  s.w_dxdy += w_dx * dy;
  s.w_dy2 += w_dy * dy;
}
template <typename T>
RETIMEGS_HD inline void sigma_vjp_combine(const T* conic, T w_dx, T w_dy, T w_dx2, T w_dxdy,
                                          T w_dy2, T (&v_mean2d)[2], T (&v_conic)[3]) {
  v_mean2d[0] = -(conic[0] * w_dx + conic[1] * w_dy);
  v_mean2d[1] = -(conic[1] * w_dx + conic[2] * w_dy);
  v_conic[0] = -(T(0.5) * w_dx2);
  v_conic[1] = -w_dxdy;
  v_conic[2] = -(T(0.5) * w_dy2);
}

}  // namespace retimegs::render
