#pragma once
// The per-pixel formulas of the training losses (train/losses.hpp), which the CPU and the CUDA
// losses (cuda/losses.hpp) both run.
#include "retimegs/core/hd.hpp"

namespace retimegs::train {

// d |diff| / d diff times `grad` (the loss's weight over its count): ±grad, 0 where diff is 0.
RETIMEGS_HD inline float l1_gradient(float diff, float grad) {
  return diff > 0 ? grad : diff < 0 ? -grad : 0.0f;
}

// The image loss (1 − λ)·L1 + λ·(1 − SSIM) from the mean L1 and the mean SSIM.
RETIMEGS_HD inline double mix_image_loss(double l1, double ssim, double ssim_lambda) {
  return (1 - ssim_lambda) * l1 + ssim_lambda * (1 - ssim);
}

}  // namespace retimegs::train
