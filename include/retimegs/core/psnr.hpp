#pragma once
// PSNR, the one definition that evaluation reports and the training log shows.
#include <cmath>
#include <cstddef>
#include <limits>

#include "retimegs/core/image.hpp"

namespace retimegs {

// PSNR in dB of images with values in [0, 1]: 10·log10(1 / MSE), the MSE over every channel of
// every pixel; with a mask only the pixels where mask > 0.5 count. A perfect match (MSE 0) is
// +infinity, the limit of the formula: a finite stand-in would pass for a real score. Throws
// Error on a size or channel mismatch, empty images, a non-finite value, a mask that does not fit
// the images or one without foreground.
double psnr(const Image& a, const Image& b, const Image* mask = nullptr);

// psnr()'s rule from its sums: `count` values (count > 0) whose squared differences, each taken
// in double, add up to squared_error. For callers that sum elsewhere (the CUDA step's
// cuda::squared_error).
inline double psnr_from_squared_error(double squared_error, std::size_t count) {
  if (squared_error == 0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(double(count) / squared_error);  // peak 1: 10·log10(1 / MSE)
}

}  // namespace retimegs
