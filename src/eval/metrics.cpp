#include "retimegs/eval/metrics.hpp"

#include <algorithm>

#include "retimegs/core/error.hpp"
#include "retimegs/core/ssim.hpp"

namespace retimegs::eval {

PixelBox mask_bounding_box(const Image& mask) {
  if (mask.channels != 1) fail("mask_bounding_box: the mask has {} channels, not 1", mask.channels);
  PixelBox box{mask.width, mask.height, 0, 0};
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x)
      if (is_foreground(mask, std::size_t(y) * mask.width + x)) {
        box.x0 = std::min(box.x0, x), box.x1 = std::max(box.x1, x + 1);
        box.y0 = std::min(box.y0, y), box.y1 = std::max(box.y1, y + 1);
      }
  if (box.x1 <= box.x0)
    fail("mask_bounding_box: the {}x{} mask has no foreground pixel (> {})", mask.width,
         mask.height, kMaskThreshold);
  return box;
}

Image crop(const Image& image, const PixelBox& box) {
  if (box.x0 < 0 || box.y0 < 0 || box.x1 > image.width || box.y1 > image.height ||
      box.width() <= 0 || box.height() <= 0)
    fail("crop: box [{}, {}) x [{}, {}) is empty or outside the {}x{} image", box.x0, box.x1,
         box.y0, box.y1, image.width, image.height);
  Image out(box.width(), box.height(), image.channels);
  const std::size_t row = std::size_t(box.width()) * image.channels;
  for (int y = 0; y < box.height(); ++y)
    std::copy_n(image.pixel(box.y0 + y, box.x0), row, out.pixel(y, 0));
  return out;
}

double ssim_in_box(const Image& a, const Image& b, const Image* mask) {
  check_image_pair(a, b, "ssim_in_box");
  if (!mask) return ssim(a, b);
  check_mask(*mask, a, "ssim_in_box");
  const PixelBox box = mask_bounding_box(*mask);
  return ssim(crop(a, box), crop(b, box));
}

Image apply_mask(const Image& image, const Image& mask) {
  check_mask(mask, image, "apply_mask");
  Image out = image;
  for (std::size_t p = 0; p < image.pixels(); ++p)
    if (!is_foreground(mask, p))
      std::fill_n(out.data.begin() + p * image.channels, image.channels, 0.0f);
  return out;
}

}  // namespace retimegs::eval
