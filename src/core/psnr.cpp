#include "retimegs/core/psnr.hpp"

#include "retimegs/core/error.hpp"

namespace retimegs {

double psnr(const Image& a, const Image& b, const Image* mask) {
  check_image_pair(a, b, "psnr");
  if (mask) check_mask(*mask, a, "psnr");
  const int c = a.channels;
  double squared_error = 0;
  std::size_t count = 0;
  for (std::size_t p = 0; p < a.pixels(); ++p) {
    if (mask && !is_foreground(*mask, p)) continue;
    for (int ch = 0; ch < c; ++ch) {
      const double d = double(a.data[p * c + ch]) - double(b.data[p * c + ch]);
      squared_error += d * d;
    }
    count += c;
  }
  if (count == 0) fail("psnr: the mask has no foreground pixel (> {})", kMaskThreshold);
  return psnr_from_squared_error(squared_error, count);
}

}  // namespace retimegs
