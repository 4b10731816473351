// The CPU's spherical harmonics: model/sh_formulas.hpp's, which the CUDA kernels run too.
#include "retimegs/model/sh.hpp"

#include "retimegs/model/sh_formulas.hpp"

namespace retimegs::model {

template <typename T>
void sh_basis(int degree, const T d[3], T basis[kMaxShCoeffs]) {
  sh_formula::basis_values(degree, d, basis);
}

template <typename T>
void sh_color(int degree, const T* h, const T dir[3], T rgb[3]) {
  sh_formula::color(degree, h, dir, rgb);
}

template <typename T>
void sh_color_vjp(int degree, const T* h, const T dir[3], const T v_rgb[3], T* v_h, T v_dir[3]) {
  sh_formula::color_vjp(degree, h, dir, v_rgb, v_h, v_dir);
}

template void sh_basis<float>(int, const float*, float*);
template void sh_basis<double>(int, const double*, double*);
template void sh_color<float>(int, const float*, const float*, float*);
template void sh_color<double>(int, const double*, const double*, double*);
template void sh_color_vjp<float>(int, const float*, const float*, const float*, float*, float*);
template void sh_color_vjp<double>(int, const double*, const double*, const double*, double*,
                                   double*);

}  // namespace retimegs::model
