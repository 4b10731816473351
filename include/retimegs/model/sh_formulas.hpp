#pragma once
// The spherical harmonics formulas of model/sh.hpp, RETIMEGS_HD (DESIGN.md §3), written once: the
// CUDA kernels (src/cuda/slice.cu) call these directly, the CPU through sh.hpp's out-of-line
// sh_basis, sh_color and sh_color_vjp (src/model/sh.cpp).
#include <cmath>

#include "retimegs/core/hd.hpp"

namespace retimegs::model {

constexpr int kMaxShDegree = 3;
constexpr int kMaxShCoeffs = 16;
constexpr double kShC0 = 0.28209479177387814;  // 1 / (2 sqrt(pi)): the DC basis function

RETIMEGS_HD inline constexpr int sh_coeffs(int degree) {
  return (degree + 1) * (degree + 1);
}

namespace sh_formula {

// Basis constants of the real spherical harmonics (3DGS `sh_utils.py`, gsplat); scalars rather
// than arrays, which device code could not index.
constexpr double C1 = 0.4886025119029199;
constexpr double C2_0 = 1.0925484305920792, C2_1 = -1.0925484305920792, C2_2 = 0.31539156525252005,
                 C2_3 = -1.0925484305920792, C2_4 = 0.5462742152960396;
constexpr double C3_0 = -0.5900435899266435, C3_1 = 2.890611442640554, C3_2 = -0.4570457994644658,
                 C3_3 = 0.3731763325901154, C3_4 = -0.4570457994644658, C3_5 = 1.445305721320277,
                 C3_6 = -0.5900435899266435;

// Basis values and their gradients with respect to the unit direction (x, y, z).
template <typename T>
RETIMEGS_HD inline void basis_and_gradient(int degree, const T d[3], T b[kMaxShCoeffs],
                                           T g[kMaxShCoeffs][3]) {
  const T x = d[0], y = d[1], z = d[2];
  b[0] = T(kShC0);
  g[0][0] = g[0][1] = g[0][2] = 0;
  if (degree < 1) return;
  b[1] = -T(C1) * y, b[2] = T(C1) * z, b[3] = -T(C1) * x;
  g[1][0] = 0, g[1][1] = -T(C1), g[1][2] = 0;
  g[2][0] = 0, g[2][1] = 0, g[2][2] = T(C1);
  g[3][0] = -T(C1), g[3][1] = 0, g[3][2] = 0;
  if (degree < 2) return;
  const T xx = x * x, yy = y * y, zz = z * z;
  b[4] = T(C2_0) * x * y;
  g[4][0] = T(C2_0) * y, g[4][1] = T(C2_0) * x, g[4][2] = 0;
  b[5] = T(C2_1) * y * z;
  g[5][0] = 0, g[5][1] = T(C2_1) * z, g[5][2] = T(C2_1) * y;
  b[6] = T(C2_2) * (2 * zz - xx - yy);
  g[6][0] = -2 * T(C2_2) * x, g[6][1] = -2 * T(C2_2) * y, g[6][2] = 4 * T(C2_2) * z;
  b[7] = T(C2_3) * x * z;
  g[7][0] = T(C2_3) * z, g[7][1] = 0, g[7][2] = T(C2_3) * x;
  b[8] = T(C2_4) * (xx - yy);
  g[8][0] = 2 * T(C2_4) * x, g[8][1] = -2 * T(C2_4) * y, g[8][2] = 0;
  if (degree < 3) return;
  b[9] = T(C3_0) * y * (3 * xx - yy);
  g[9][0] = T(C3_0) * 6 * x * y, g[9][1] = T(C3_0) * (3 * xx - 3 * yy), g[9][2] = 0;
  b[10] = T(C3_1) * x * y * z;
  g[10][0] = T(C3_1) * y * z, g[10][1] = T(C3_1) * x * z, g[10][2] = T(C3_1) * x * y;
  b[11] = T(C3_2) * y * (4 * zz - xx - yy);
  g[11][0] = T(C3_2) * (-2 * x * y), g[11][1] = T(C3_2) * (4 * zz - xx - 3 * yy),
  g[11][2] = T(C3_2) * 8 * y * z;
  b[12] = T(C3_3) * z * (2 * zz - 3 * xx - 3 * yy);
  g[12][0] = T(C3_3) * (-6 * x * z), g[12][1] = T(C3_3) * (-6 * y * z),
  g[12][2] = T(C3_3) * (6 * zz - 3 * xx - 3 * yy);
  b[13] = T(C3_4) * x * (4 * zz - xx - yy);
  g[13][0] = T(C3_4) * (4 * zz - 3 * xx - yy), g[13][1] = T(C3_4) * (-2 * x * y),
  g[13][2] = T(C3_4) * 8 * x * z;
  b[14] = T(C3_5) * z * (xx - yy);
  g[14][0] = T(C3_5) * 2 * x * z, g[14][1] = T(C3_5) * (-2 * y * z), g[14][2] = T(C3_5) * (xx - yy);
  b[15] = T(C3_6) * x * (xx - 3 * yy);
  g[15][0] = T(C3_6) * (3 * xx - 3 * yy), g[15][1] = T(C3_6) * (-6 * x * y), g[15][2] = 0;
}

template <typename T>
RETIMEGS_HD inline T normalize(const T dir[3], T unit[3]) {
  const T norm = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  const T inv = norm > T(0) ? T(1) / norm : T(0);
  for (int a = 0; a < 3; ++a) unit[a] = dir[a] * inv;
  return norm;
}
template <typename T>
RETIMEGS_HD inline void basis_values(int degree, const T d[3], T basis[kMaxShCoeffs]) {
  T unused[kMaxShCoeffs][3];
  basis_and_gradient(degree, d, basis, unused);
}

// The clamped colour of coefficients h [K, 3] at the basis values of a direction.
template <typename T>
RETIMEGS_HD inline void color_of_basis(int degree, const T* h, const T basis[kMaxShCoeffs],
                                       T rgb[3]) {
  for (int c = 0; c < 3; ++c) {
    T sum = T(0.5);
    for (int k = 0; k < sh_coeffs(degree); ++k) sum += basis[k] * h[3 * k + c];
    rgb[c] = sum > T(0) ? sum : T(0);
  }
}

// sh.hpp's sh_color: the colour of h at the unnormalised direction dir.
template <typename T>
RETIMEGS_HD inline void color(int degree, const T* h, const T dir[3], T rgb[3]) {
  T unit[3], basis[kMaxShCoeffs];
  normalize(dir, unit);
  basis_values(degree, unit, basis);
  color_of_basis(degree, h, basis, rgb);
}

template <typename T>
RETIMEGS_HD inline void color_vjp(int degree, const T* h, const T dir[3], const T v_rgb[3], T* v_h,
                                  T v_dir[3]) {
  T unit[3], basis[kMaxShCoeffs], grad[kMaxShCoeffs][3];
  const T norm = normalize(dir, unit);
  basis_and_gradient(degree, unit, basis, grad);
  const int count = sh_coeffs(degree);
  T v_unit[3] = {0, 0, 0};
  for (int c = 0; c < 3; ++c) {
    T sum = T(0.5);
    for (int k = 0; k < count; ++k) sum += basis[k] * h[3 * k + c];
    if (!(sum > T(0))) continue;  // clamped channel
    for (int k = 0; k < count; ++k) {
      v_h[3 * k + c] += basis[k] * v_rgb[c];
      for (int a = 0; a < 3; ++a) v_unit[a] += grad[k][a] * h[3 * k + c] * v_rgb[c];
    }
  }
  if (!(norm > T(0))) return;
  // d unit / d dir = (I - u u^T) / |dir|
  const T dot = v_unit[0] * unit[0] + v_unit[1] * unit[1] + v_unit[2] * unit[2];
  for (int a = 0; a < 3; ++a) v_dir[a] += (v_unit[a] - unit[a] * dot) / norm;
}

}  // namespace sh_formula
}  // namespace retimegs::model
