#pragma once
// Adam's update of one value (train/adam.hpp), which the CPU optimiser and the CUDA one
// (cuda/adam.hpp) both run: the constants of a step are computed once on the host, in double, the
// update of a value in float by the same expression on both devices. The compilers may contract
// its products and sums into fused multiply-adds where they differ (g++ does at -march=native
// with FMA, nvcc by default), so the two agree to a few roundings of each term, not bit for bit.
#include <cmath>
#include <cstdint>

#include "retimegs/core/hd.hpp"

namespace retimegs::train {

struct AdamSettings {
  double beta1 = 0.9, beta2 = 0.999;
  double epsilon = 1e-15;  // gsplat's default for Gaussian splats (torch's 1e-8 is too large)
};

// What every value of one step shares: p -= lr / c1 · m / (sqrt(v) / sqrt(c2) + ε), with the bias
// corrections c_k = 1 − β_k^step.
struct AdamStepConstants {
  float b1, b2, eps;
  float one_minus_b1, one_minus_b2;  // 1 − β1, 1 − β2 in float
  float step_size;                   // lr / c1
  float inv_sqrt_c2;                 // 1 / sqrt(c2)
};

// The constants of the group's step number `step` (1 for its first step) at learning rate lr.
inline AdamStepConstants adam_step_constants(const AdamSettings& s, double lr, std::int64_t step) {
  const double correction1 = 1.0 - std::pow(s.beta1, double(step));
  const double correction2 = 1.0 - std::pow(s.beta2, double(step));
  const float b1 = float(s.beta1), b2 = float(s.beta2);
  const float step_size = float(lr / correction1);
  const float inv_sqrt_c2 = float(1.0 / std::sqrt(correction2));
  return {b1, b2, float(s.epsilon), 1 - b1, 1 - b2, step_size, inv_sqrt_c2};
}

// One value with gradient g: its moments m, v decay and take g; param moves by the step at the
// column's learning-rate scale.
RETIMEGS_HD inline void adam_update(AdamStepConstants k, float scale, float g, float& param,
                                    float& m, float& v) {
  m = k.b1 * m + k.one_minus_b1 * g;
  v = k.b2 * v + k.one_minus_b2 * g * g;
  param -= k.step_size * scale * m / (std::sqrt(v) * k.inv_sqrt_c2 + k.eps);
}

}  // namespace retimegs::train
