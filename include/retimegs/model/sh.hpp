#pragma once
// Real spherical harmonics colour (3DGS / gsplat convention, degree 0..3): for a unit view
// direction d, colour = max(sum_k b_k(d) h_k + 0.5, 0) per channel. Forward and vector-Jacobian
// product, templated on the scalar so tests run them in double.
#include <cstddef>

#include "retimegs/model/sh_formulas.hpp"  // the formulas; kMaxShDegree, kMaxShCoeffs, sh_coeffs

namespace retimegs::model {

// The K = (degree + 1)^2 basis values at unit direction d (unused entries untouched).
template <typename T>
void sh_basis(int degree, const T d[3], T basis[kMaxShCoeffs]);

// One colour from coefficients h [K, 3] and the *unnormalised* direction dir (mean - camera
// centre). Returns the clamped colour in rgb[3].
template <typename T>
void sh_color(int degree, const T* h, const T dir[3], T rgb[3]);

// VJP of sh_color: accumulates v_h [K, 3] and v_dir [3] (both +=) from v_rgb [3]. The clamp at 0
// passes no gradient where it is active.
template <typename T>
void sh_color_vjp(int degree, const T* h, const T dir[3], const T v_rgb[3], T* v_h, T v_dir[3]);

}  // namespace retimegs::model
