#pragma once
// The per-pixel and per-primitive formulas of the training losses (train/losses.hpp), which the
// CPU and the CUDA losses (cuda/losses.hpp) both run.
#include <cmath>
#include <cstddef>

#include "retimegs/core/hd.hpp"
#include "retimegs/model/temporal_opacity.hpp"

namespace retimegs::train {

// d |diff| / d diff times `grad` (the loss's weight over its count): ±grad, 0 where diff is 0.
RETIMEGS_HD inline float l1_gradient(float diff, float grad) {
  return diff > 0 ? grad : diff < 0 ? -grad : 0.0f;
}

// The image loss (1 − λ)·L1 + λ·(1 − SSIM) from the mean L1 and the mean SSIM.
RETIMEGS_HD inline double mix_image_loss(double l1, double ssim, double ssim_lambda) {
  return (1 - ssim_lambda) * l1 + ssim_lambda * (1 - ssim);
}

// The regulariser's terms of one row of N primitives added to `sum`, in the CPU's order:
// opacity_weight · σ / N, then scale_weight · e^{s_a} / 3N for each axis a. No product feeds a
// sum directly (each is divided first), so no compiler contracts it: the same double on every
// device but for the last bit of exp.
RETIMEGS_HD inline double regularizer_add(double sum, double opacity_weight, double scale_weight,
                                          std::size_t n, float opacity_logit,
                                          const float* log_scale) {
  sum += opacity_weight * model::sigmoid<double>(opacity_logit) / double(n);
  for (int a = 0; a < 3; ++a) sum += scale_weight * std::exp(double(log_scale[a])) / double(3 * n);
  return sum;
}

// d regularizer / d opacity_logit and d / d log_scale [3] of one row, added into v_opacity_logit
// and v_log_scale.
RETIMEGS_HD inline void regularizer_row_backward(double opacity_weight, double scale_weight,
                                                 std::size_t n, float opacity_logit,
                                                 const float* log_scale, float& v_opacity_logit,
                                                 float* v_log_scale) {
  const double sigma = model::sigmoid<double>(opacity_logit);
  v_opacity_logit += float(opacity_weight / double(n) * sigma * (1 - sigma));
  for (int a = 0; a < 3; ++a)
    v_log_scale[a] += float(scale_weight / double(3 * n) * std::exp(double(log_scale[a])));
}

}  // namespace retimegs::train
