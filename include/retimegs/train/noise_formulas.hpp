#pragma once
// The per-row formulas of the 3DGS-MCMC noise (train/relocation.hpp inject_noise), which the CPU
// and the CUDA noise (cuda/strategy.hpp) both run. The noise of a row is a function of (key, row)
// alone: counter-based normal draws (splitmix64, Box–Muller in double), then
// μ += k · R diag(e^{2s}) Rᵀ ε in float.
//
// Every float step is spelled out: which products are fused into a multiply-add (fma) and which
// are rounded on their own (unfused_product). That is what the CPU computed before with Eigen 3.4
// (Quaternionf::normalized().toRotationMatrix(), Matrix3f products) as g++ 12 -O3 -march=native
// contracted it — g++ contracts C++ by default, -std=c++20 included — so training results stay
// byte-identical; and a compiler may contract nothing further here, so the CUDA build rounds every
// step the same way. What may still differ between the devices are the library functions exp,
// log, sin and cos, whose last bit each device rounds its own way (see noise_exp).
#include <cmath>
#include <cstdint>
#include <numbers>

#include "retimegs/core/hd.hpp"
#include "retimegs/core/splitmix64.hpp"
#include "retimegs/model/temporal_opacity.hpp"

namespace retimegs::train {

constexpr double kNoiseScale = 5e5;        // 3DGS-MCMC noise_lr
constexpr double kNoiseSharpness = 100.0;  // sigmoid(-k (σ - x0)): noise only on faint splats
constexpr double kNoiseThreshold = 0.005;
constexpr double kNoiseMinGate = 1e-12;  // rows gated below this are left alone

// Uniform k (0 to 3) of row `row` under `key`: 53 bits of splitmix64 of (key, row, k), in (0, 1],
// never 0 (Box–Muller takes its log). Integer arithmetic and an exact conversion: the same double
// on every device.
RETIMEGS_HD inline double noise_uniform(std::uint64_t key, std::uint64_t row, int k) {
  const std::uint64_t base = splitmix64(key ^ splitmix64(row)) * 4;
  return (double(splitmix64(base + std::uint64_t(k)) >> 11) + 1.0) * 0x1.0p-53;
}

// Three standard normal values for row `row` under `key`: four uniforms, two Box–Muller pairs, the
// fourth value unused.
RETIMEGS_HD inline void normal3(std::uint64_t key, std::uint64_t row, float (&eps)[3]) {
  constexpr double kTwoPi = 2 * std::numbers::pi;
  double u[4];
  for (int k = 0; k < 4; ++k) u[k] = noise_uniform(key, row, k);
  const double r0 = std::sqrt(-2 * std::log(u[0])), r1 = std::sqrt(-2 * std::log(u[2]));
  eps[0] = float(r0 * std::cos(kTwoPi * u[1]));
  eps[1] = float(r0 * std::sin(kTwoPi * u[1]));
  eps[2] = float(r1 * std::cos(kTwoPi * u[3]));
}

// e^x in float. The host's std::exp (glibc's expf, within 0.502 ulp); the device's expf is off by
// up to 2 ulps, so there it is rounded from the double exp instead: the same float in all but rare
// near-ties.
RETIMEGS_HD inline float noise_exp(float x) {
#if defined(__CUDA_ARCH__)
  return float(exp(double(x)));
#else
  return std::exp(x);
#endif
}

// a·b rounded to float on its own, never fused into the sum it feeds (where the CPU code this
// reproduces did not fuse it).
RETIMEGS_HD inline float unfused_product(float a, float b) {
#if defined(__CUDA_ARCH__)
  return __fmul_rn(a, b);  // never contracted by nvcc
#else
  float p = a * b;
  asm("" : "+m"(p));  // hides where p comes from: the compiler cannot fuse it into the sum
  return p;
#endif
}

// a·b + c rounded once.
RETIMEGS_HD inline float fused(float a, float b, float c) {
#if defined(__CUDA_ARCH__)
  return fmaf(a, b, c);
#else
  return std::fma(a, b, c);
#endif
}

// The rotation matrix r [3, 3] (row-major) of the quaternion q = (w, x, y, z) normalised, as
// Eigen's Quaternionf(w, x, y, z).normalized().toRotationMatrix() computes it: the squared norm
// summed as its SSE reduction of the coefficients (x, y, z, w) adds them, (x² + z²) + (y² + w²),
// with no fused product; a zero quaternion stays zero (Eigen leaves it unnormalised).
RETIMEGS_HD inline void noise_rotation(const float* q, float (&r)[9]) {
  float w = q[0], x = q[1], y = q[2], z = q[3];
  const float xx = unfused_product(x, x), yy = unfused_product(y, y);
  const float zz = unfused_product(z, z), ww = unfused_product(w, w);
  const float norm2 = (xx + zz) + (yy + ww);
  if (norm2 > 0.0f) {
    const float norm = std::sqrt(norm2);
    x = x / norm, y = y / norm, z = z / norm, w = w / norm;
  }
  const float tx = 2.0f * x, ty = 2.0f * y, tz = 2.0f * z;
  const float txy = ty * x, txz = tz * x, tyz = tz * y;  // feed fused sums only
  const float tyy = unfused_product(ty, y), tzz = unfused_product(tz, z);
  r[0] = 1.0f - (tyy + tzz), r[1] = fused(-tz, w, txy), r[2] = fused(ty, w, txz);
  r[3] = fused(tz, w, txy), r[4] = 1.0f - fused(tx, x, tzz), r[5] = fused(-tx, w, tyz);
  r[6] = fused(-ty, w, txz), r[7] = fused(tx, w, tyz), r[8] = 1.0f - fused(tx, x, tyy);
}

// a · b of 3-vectors as the CPU's Eigen product was contracted: a0·b0 + (a1·b1 + a2·b2) with both
// sums fused, a1·b1 rounded on its own.
RETIMEGS_HD inline float noise_dot(float a0, float a1, float a2, float b0, float b1, float b2) {
  return fused(a0, b0, fused(a2, b2, a1 * b1));
}

// The covariance-shaped step R diag(s2) Rᵀ ε of a row.
RETIMEGS_HD inline void noise_direction(const float (&r)[9], const float (&s2)[3],
                                        const float (&eps)[3], float (&delta)[3]) {
  float w[3];
  for (int i = 0; i < 3; ++i)  // (Rᵀ ε)_i = Σ_k r(k, i) ε_k, then scaled by s2_i
    w[i] = s2[i] * noise_dot(r[i], r[3 + i], r[6 + i], eps[0], eps[1], eps[2]);
  for (int i = 0; i < 3; ++i)
    delta[i] = noise_dot(r[3 * i], r[3 * i + 1], r[3 * i + 2], w[0], w[1], w[2]);
}

// The noise of one row: its mean mu [3] moves by gate · lr_means · kNoiseScale · R diag(e^{2s}) Rᵀ
// ε with gate = sigmoid(-kNoiseSharpness (σ - kNoiseThreshold)) of its opacity σ; rows gated below
// kNoiseMinGate are left as they are. q0 [4] (w, x, y, z), log_scale [3].
RETIMEGS_HD inline void noise_row(std::uint64_t key, std::uint64_t row, double lr_means,
                                  float opacity_logit, const float* q0, const float* log_scale,
                                  float* mu) {
  const double sigma = model::sigmoid<double>(opacity_logit);
  const double gate = model::sigmoid(-kNoiseSharpness * (sigma - kNoiseThreshold));
  if (gate < kNoiseMinGate) return;
  float eps[3];
  normal3(key, row, eps);
  float r[9];
  noise_rotation(q0, r);
  const float s2[3] = {noise_exp(2 * log_scale[0]), noise_exp(2 * log_scale[1]),
                       noise_exp(2 * log_scale[2])};
  float delta[3];
  noise_direction(r, s2, eps, delta);
  const float k = float(gate * lr_means * kNoiseScale);
  for (int a = 0; a < 3; ++a) mu[a] = fused(k, delta[a], mu[a]);
}

}  // namespace retimegs::train
