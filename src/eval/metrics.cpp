#include "retimegs/eval/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "retimegs/core/error.hpp"
#include "retimegs/core/ssim.hpp"

namespace retimegs::eval {
namespace {

// Masks are 0 / 1 (io::read_mask); a soft mask is split at one half.
constexpr float kMaskThreshold = 0.5f;

bool foreground(const Image& mask, std::size_t pixel) {
  return mask.data[pixel] > kMaskThreshold;
}

void check_finite(const Image& image, const char* function, const char* which) {
  const auto bad =
      std::find_if(image.data.begin(), image.data.end(), [](float v) { return !std::isfinite(v); });
  if (bad == image.data.end()) return;
  const std::size_t at = bad - image.data.begin(), pixel = at / image.channels;
  fail("{}: the {} image has a non-finite value ({}) at pixel ({}, {}) channel {}", function, which,
       *bad, pixel % image.width, pixel / image.width, at % image.channels);
}

void check_pair(const Image& a, const Image& b, const char* function) {
  if (a.width != b.width || a.height != b.height || a.channels != b.channels)
    fail("{}: images differ in size ({}x{}x{} vs {}x{}x{})", function, a.width, a.height,
         a.channels, b.width, b.height, b.channels);
  if (a.empty()) fail("{}: images are empty", function);
  check_finite(a, function, "first");
  check_finite(b, function, "second");
}

void check_mask(const Image& mask, const Image& image, const char* function) {
  if (mask.channels != 1 || mask.width != image.width || mask.height != image.height)
    fail("{}: the mask is {}x{}x{} but a {}x{}x1 mask is needed for a {}x{} image", function,
         mask.width, mask.height, mask.channels, image.width, image.height, image.width,
         image.height);
}

}  // namespace

double psnr(const Image& a, const Image& b, const Image* mask) {
  check_pair(a, b, "psnr");
  if (mask) check_mask(*mask, a, "psnr");
  const int c = a.channels;
  double squared_error = 0;
  std::size_t count = 0;
  for (std::size_t p = 0; p < a.pixels(); ++p) {
    if (mask && !foreground(*mask, p)) continue;
    for (int ch = 0; ch < c; ++ch) {
      const double d = double(a.data[p * c + ch]) - double(b.data[p * c + ch]);
      squared_error += d * d;
    }
    count += c;
  }
  if (count == 0) fail("psnr: the mask has no foreground pixel (> {})", kMaskThreshold);
  if (squared_error == 0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(double(count) / squared_error);  // peak 1: 10·log10(1 / MSE)
}

PixelBox mask_bounding_box(const Image& mask) {
  if (mask.channels != 1) fail("mask_bounding_box: the mask has {} channels, not 1", mask.channels);
  PixelBox box{mask.width, mask.height, 0, 0};
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x)
      if (foreground(mask, std::size_t(y) * mask.width + x)) {
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
  check_pair(a, b, "ssim_in_box");
  if (!mask) return ssim(a, b);
  check_mask(*mask, a, "ssim_in_box");
  const PixelBox box = mask_bounding_box(*mask);
  return ssim(crop(a, box), crop(b, box));
}

Image apply_mask(const Image& image, const Image& mask) {
  check_mask(mask, image, "apply_mask");
  Image out = image;
  for (std::size_t p = 0; p < image.pixels(); ++p)
    if (!foreground(mask, p))
      std::fill_n(out.data.begin() + p * image.channels, image.channels, 0.0f);
  return out;
}

}  // namespace retimegs::eval
