#pragma once
// PSNR, the one definition that evaluation reports and the training log shows.
#include "retimegs/core/image.hpp"

namespace retimegs {

// PSNR in dB of images with values in [0, 1]: 10·log10(1 / MSE), the MSE over every channel of
// every pixel; with a mask only the pixels where mask > 0.5 count. A perfect match (MSE 0) is
// +infinity, the limit of the formula: a finite stand-in would pass for a real score. Throws
// Error on a size or channel mismatch, empty images, a non-finite value, a mask that does not fit
// the images or one without foreground.
double psnr(const Image& a, const Image& b, const Image* mask = nullptr);

}  // namespace retimegs
