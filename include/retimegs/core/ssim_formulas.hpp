#pragma once
// The per-pixel formulas of SSIM (core/ssim.hpp), which the CPU (in double) and the CUDA image
// loss (cuda/losses.hpp, in float) both run: the window, the constants, the SSIM of one window from
// its moments with its derivatives, and the chain rule from the filtered derivative maps back to
// one pixel of the render.
#include <array>
#include <cmath>

#include "retimegs/core/hd.hpp"

namespace retimegs {

constexpr int kSsimRadius = 5;  // 11×11 window, as 3DGS (conv2d padding = 5)
constexpr int kSsimTaps = 2 * kSsimRadius + 1;
constexpr double kSsimSigma = 1.5;       // Wang et al. 2004, 3DGS
constexpr double kSsimC1 = 0.01 * 0.01;  // (K1·L)², K1 = 0.01, data range L = 1
constexpr double kSsimC2 = 0.03 * 0.03;  // (K2·L)², K2 = 0.03

using SsimWindow = std::array<double, kSsimTaps>;

// w(k) ∝ exp(−(k − 5)² / (2σ²)), normalised to sum 1; the 2-D window is w(dy)·w(dx).
inline SsimWindow ssim_window() {
  SsimWindow g;
  double sum = 0;
  for (int k = 0; k < kSsimTaps; ++k) {
    const double d = k - kSsimRadius;
    sum += g[k] = std::exp(-d * d / (2 * kSsimSigma * kSsimSigma));
  }
  for (double& v : g) v /= sum;
  return g;
}

// SSIM of one window from its moments, and its partial derivatives with respect to the moments
// of a; σ_a² = E[a²] − μ_a² and σ_ab = E[ab] − μ_a·μ_b, so d_mu_a is the total derivative
// through them as well. The moments of b are constants.
template <typename T>
struct LocalSsimT {
  T s, d_mu_a, d_e_aa, d_e_ab;
};

template <typename T>
RETIMEGS_HD inline LocalSsimT<T> local_ssim(T mu_a, T mu_b, T e_aa, T e_bb, T e_ab) {
  const T c1 = T(kSsimC1), c2 = T(kSsimC2);
  const T var_a = e_aa - mu_a * mu_a, var_b = e_bb - mu_b * mu_b;
  const T cov = e_ab - mu_a * mu_b;
  const T num_mu = 2 * mu_a * mu_b + c1, num_sigma = 2 * cov + c2;
  const T den_mu = mu_a * mu_a + mu_b * mu_b + c1, den_sigma = var_a + var_b + c2;
  const T inv_den = 1 / (den_mu * den_sigma);
  const T s = num_mu * num_sigma * inv_den;
  const T d_e_ab = 2 * num_mu * inv_den;  // = dS/dσ_ab
  const T d_e_aa = -s / den_sigma;        // = dS/dσ_a²
  const T d_mu_a =
      2 * mu_b * num_sigma * inv_den - 2 * mu_a * s / den_mu - mu_b * d_e_ab - 2 * mu_a * d_e_aa;
  return {s, d_mu_a, d_e_aa, d_e_ab};
}

// d SSIM / d a at one pixel of the render with value a (target value b): g_mu, g_aa, g_ab are the
// maps of d S/d μ_a, d S/d E[a²], d S/d E[ab] (times the upstream scale) filtered with the window,
// i.e. summed over every window that contains the pixel; a enters E[a²] as a² and E[ab] as a·b.
template <typename T>
RETIMEGS_HD inline T ssim_pixel_gradient(T g_mu, T g_aa, T g_ab, T a, T b) {
  return g_mu + T(2) * a * g_aa + b * g_ab;
}

}  // namespace retimegs
