#pragma once
// The depth pass of a render (`render --depth`): per pixel the expected camera-space depth of what
// it shows, gsplat's "ED" render mode, sum_i z_i w_i / sum_i w_i with w_i = alpha_i T_i over the
// composited Gaussians, z_i the camera z of Gaussian i's centre. Both rasterisers composite the
// numerator as their depth channel (RenderOptions::render_depth) and the denominator is the
// render's alpha, so the pass is one division on whichever device drew the image.
#include <cstddef>

#include "retimegs/core/hd.hpp"
#include "retimegs/core/image.hpp"

namespace retimegs::render {

// The depth of a pixel where no Gaussian was composited (alpha = 0): "infinitely far" as
// Blender's Z pass writes it. Finite, so that a compositor's filters (negative lobes: inf - inf)
// and depth-of-field blurs stay free of NaN, and far beyond any scene's extent in scene units.
constexpr float kNoDepth = 1e10f;

// The expected depth of a pixel from its composited depth sum_i z_i w_i and alpha sum_i w_i.
RETIMEGS_HD inline float expected_depth(float composited_depth, float alpha) {
  return alpha > 0.0f ? composited_depth / alpha : kNoDepth;
}

// The depth pass [H, W, 1] of a render from its composited depth [H, W] and alpha [H, W].
inline Image depth_pass(const float* composited_depth, const float* alpha, int width, int height) {
  Image out(width, height, 1);
  for (std::size_t i = 0; i < out.pixels(); ++i)
    out.data[i] = expected_depth(composited_depth[i], alpha[i]);
  return out;
}

}  // namespace retimegs::render
