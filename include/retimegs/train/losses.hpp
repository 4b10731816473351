#pragma once
// Training losses on rendered images (DESIGN.md §2): the image loss (1 − λ)·L1 + λ·(1 − SSIM) and
// the per-pixel L1 flow loss that skips unknown flow pixels. Each returns its value and adds
// weight · d loss / d render into v_render (same layout as the render: [H, W, C], RGB first).
#include "retimegs/core/image.hpp"

namespace retimegs::train {

// RGB = the render's first 3 channels against target [H, W, 3].
double image_loss(const Image& render, const Image& target, double ssim_lambda, double weight,
                  Image& v_render);

// Mean over known pixels of |u - u*| + |v - v*|, the render's flow in channels
// (channel, channel + 1). Returns 0 (and no gradient) when no pixel is known.
double flow_loss(const Image& render, int channel, const Flow& target, double weight,
                 Image& v_render);

// PSNR of the render's RGB against the target, [0, 1] values.
double psnr(const Image& render, const Image& target);

}  // namespace retimegs::train
