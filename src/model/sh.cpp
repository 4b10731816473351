// The CPU's spherical harmonics, compiled as before the formulas moved: model/sh_formulas.hpp
// holds the same formulas for the CUDA kernels (TODO: one copy; see the slice-cuda report).
#include "retimegs/model/sh.hpp"

#include <cmath>

namespace retimegs::model {

namespace {
// Basis constants of the real spherical harmonics (3DGS `sh_utils.py`, gsplat).
constexpr double C1 = 0.4886025119029199;
constexpr double C2[5] = {1.0925484305920792, -1.0925484305920792, 0.31539156525252005,
                          -1.0925484305920792, 0.5462742152960396};
constexpr double C3[7] = {-0.5900435899266435, 2.890611442640554,   -0.4570457994644658,
                          0.3731763325901154,  -0.4570457994644658, 1.445305721320277,
                          -0.5900435899266435};

// Basis values and their gradients with respect to the unit direction (x, y, z).
template <typename T>
void basis_and_gradient(int degree, const T d[3], T b[kMaxShCoeffs], T g[kMaxShCoeffs][3]) {
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
  b[4] = T(C2[0]) * x * y;
  g[4][0] = T(C2[0]) * y, g[4][1] = T(C2[0]) * x, g[4][2] = 0;
  b[5] = T(C2[1]) * y * z;
  g[5][0] = 0, g[5][1] = T(C2[1]) * z, g[5][2] = T(C2[1]) * y;
  b[6] = T(C2[2]) * (2 * zz - xx - yy);
  g[6][0] = -2 * T(C2[2]) * x, g[6][1] = -2 * T(C2[2]) * y, g[6][2] = 4 * T(C2[2]) * z;
  b[7] = T(C2[3]) * x * z;
  g[7][0] = T(C2[3]) * z, g[7][1] = 0, g[7][2] = T(C2[3]) * x;
  b[8] = T(C2[4]) * (xx - yy);
  g[8][0] = 2 * T(C2[4]) * x, g[8][1] = -2 * T(C2[4]) * y, g[8][2] = 0;
  if (degree < 3) return;
  b[9] = T(C3[0]) * y * (3 * xx - yy);
  g[9][0] = T(C3[0]) * 6 * x * y, g[9][1] = T(C3[0]) * (3 * xx - 3 * yy), g[9][2] = 0;
  b[10] = T(C3[1]) * x * y * z;
  g[10][0] = T(C3[1]) * y * z, g[10][1] = T(C3[1]) * x * z, g[10][2] = T(C3[1]) * x * y;
  b[11] = T(C3[2]) * y * (4 * zz - xx - yy);
  g[11][0] = T(C3[2]) * (-2 * x * y), g[11][1] = T(C3[2]) * (4 * zz - xx - 3 * yy),
  g[11][2] = T(C3[2]) * 8 * y * z;
  b[12] = T(C3[3]) * z * (2 * zz - 3 * xx - 3 * yy);
  g[12][0] = T(C3[3]) * (-6 * x * z), g[12][1] = T(C3[3]) * (-6 * y * z),
  g[12][2] = T(C3[3]) * (6 * zz - 3 * xx - 3 * yy);
  b[13] = T(C3[4]) * x * (4 * zz - xx - yy);
  g[13][0] = T(C3[4]) * (4 * zz - 3 * xx - yy), g[13][1] = T(C3[4]) * (-2 * x * y),
  g[13][2] = T(C3[4]) * 8 * x * z;
  b[14] = T(C3[5]) * z * (xx - yy);
  g[14][0] = T(C3[5]) * 2 * x * z, g[14][1] = T(C3[5]) * (-2 * y * z),
  g[14][2] = T(C3[5]) * (xx - yy);
  b[15] = T(C3[6]) * x * (xx - 3 * yy);
  g[15][0] = T(C3[6]) * (3 * xx - 3 * yy), g[15][1] = T(C3[6]) * (-6 * x * y), g[15][2] = 0;
}

template <typename T>
T normalize(const T dir[3], T unit[3]) {
  const T norm = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  const T inv = norm > T(0) ? T(1) / norm : T(0);
  for (int a = 0; a < 3; ++a) unit[a] = dir[a] * inv;
  return norm;
}
}  // namespace

template <typename T>
void sh_basis(int degree, const T d[3], T basis[kMaxShCoeffs]) {
  T unused[kMaxShCoeffs][3];
  basis_and_gradient(degree, d, basis, unused);
}

template <typename T>
void sh_color(int degree, const T* h, const T dir[3], T rgb[3]) {
  T unit[3], basis[kMaxShCoeffs];
  normalize(dir, unit);
  sh_basis(degree, unit, basis);
  for (int c = 0; c < 3; ++c) {
    T sum = T(0.5);
    for (int k = 0; k < sh_coeffs(degree); ++k) sum += basis[k] * h[3 * k + c];
    rgb[c] = sum > T(0) ? sum : T(0);
  }
}

template <typename T>
void sh_color_vjp(int degree, const T* h, const T dir[3], const T v_rgb[3], T* v_h, T v_dir[3]) {
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

template void sh_basis<float>(int, const float*, float*);
template void sh_basis<double>(int, const double*, double*);
template void sh_color<float>(int, const float*, const float*, float*);
template void sh_color<double>(int, const double*, const double*, double*);
template void sh_color_vjp<float>(int, const float*, const float*, const float*, float*, float*);
template void sh_color_vjp<double>(int, const double*, const double*, const double*, double*,
                                   double*);

}  // namespace retimegs::model
