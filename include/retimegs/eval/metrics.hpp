#pragma once
// Image-quality metrics of the evaluation protocol (docs/method.md, evaluation), on images with
// values in [0, 1], besides PSNR (core/psnr.hpp, which training shares). `a` is the render and `b`
// the ground truth; masks are [H, W, 1] with foreground where > 0.5 (media::read_mask gives 0 / 1).
// Every function throws Error naming the problem on a size or channel mismatch, a non-finite value,
// or a mask without foreground.
#include "retimegs/core/image.hpp"

namespace retimegs::eval {

// Half-open pixel rectangle [x0, x1) × [y0, y1).
struct PixelBox {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  int width() const { return x1 - x0; }
  int height() const { return y1 - y0; }
};

// The bounding box of the pixels where mask > 0.5.
PixelBox mask_bounding_box(const Image& mask);

// The pixels of `image` inside `box` (which must lie inside the image).
Image crop(const Image& image, const PixelBox& box);

// The 3DGS SSIM (core/ssim.hpp) of a and b cropped to the bounding box of the mask, or of the
// whole images without a mask. Values outside the box do not matter.
double ssim_in_box(const Image& a, const Image& b, const Image* mask = nullptr);

// The image with every pixel where mask ≤ 0.5 set to black (what LPIPS compares when masks exist).
Image apply_mask(const Image& image, const Image& mask);

}  // namespace retimegs::eval
