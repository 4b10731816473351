#pragma once
// Training losses (docs/method.md). On rendered images: the image loss (1 − λ)·L1 + λ·(1 − SSIM)
// and the per-pixel L1 flow loss that skips unknown flow pixels; each returns its value and adds
// weight · d loss / d render into v_render (same layout as the render: [H, W, C], RGB first). On
// the primitives: the 3DGS-MCMC regulariser, as a forward / backward pair.
#include <cstdint>
#include <vector>

#include "retimegs/core/image.hpp"
#include "retimegs/core/ssim.hpp"
#include "retimegs/model/primitives.hpp"

namespace retimegs::train {

// The render's RGB, its first 3 channels, as an image of its own: `render` itself when it has 3
// channels, else a copy written into `buffer` (its allocation reused across calls).
const Image& rgb_of(const Image& render, Image& buffer);

// The render's RGB `rgb` [H, W, 3] (rgb_of) against the target [H, W, 3], prepared for SSIM once
// per view (its moments serve every render of a step); the gradient goes into the first 3
// channels of v_render.
double image_loss(const Image& rgb, const SsimTarget& target, double ssim_lambda, double weight,
                  Image& v_render);

// Mean over known pixels of |u - u*| + |v - v*|, the render's flow in channels
// (channel, channel + 1). Returns 0 (and no gradient) when no pixel is known.
double flow_loss(const Image& render, int channel, const Flow& target, double weight,
                 Image& v_render);

// The 3DGS-MCMC regulariser opacity_weight · mean σ + scale_weight · mean exp(s) over the N
// primitives (and their 3 axes for the scale), summed over the ascending `rows` only: faint
// primitives drift towards death, where relocation reuses them, and splats stay small. A training
// step passes the rows visible at its time, so a primitive is regularised at the steps whose image
// loss sees it, with the gradient the mean over all N gives it. 0 when there is no row.
double regularizer(const model::Primitives& primitives, const std::vector<std::int32_t>& rows,
                   double opacity_weight, double scale_weight);
// Adds d regularizer / d opacity_logit and d regularizer / d log_scale of `rows` into `grads`.
void regularizer_backward(const model::Primitives& primitives,
                          const std::vector<std::int32_t>& rows, double opacity_weight,
                          double scale_weight, model::PrimitiveGrads& grads);

}  // namespace retimegs::train
