#include "retimegs/core/image.hpp"

#include <algorithm>
#include <cmath>

#include "retimegs/core/error.hpp"

namespace retimegs {
namespace {

void check_finite(const Image& image, const char* function, const char* which) {
  const auto bad =
      std::find_if(image.data.begin(), image.data.end(), [](float v) { return !std::isfinite(v); });
  if (bad == image.data.end()) return;
  const std::size_t at = bad - image.data.begin(), pixel = at / image.channels;
  fail("{}: the {} image has a non-finite value ({}) at pixel ({}, {}) channel {}", function, which,
       *bad, pixel % image.width, pixel / image.width, at % image.channels);
}

}  // namespace

void check_image_pair(const Image& a, const Image& b, const char* function) {
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

PackedImage pack(const Image& image, const std::string& what) {
  PackedImage packed{image.width, image.height, image.channels, {}};
  packed.data.resize(image.data.size());
  for (std::size_t i = 0; i < image.data.size(); ++i) {
    const float v = image.data[i];
    if (!(v >= 0 && v <= 1))
      fail("{}: value {} at pixel ({}, {}) channel {} is outside [0, 1]", what, v,
           i / image.channels % image.width, i / image.channels / image.width, i % image.channels);
    packed.data[i] = std::uint16_t(std::lrint(double(v) * 65535.0));
  }
  return packed;
}

void unpack(const PackedImage& packed, Image& out) {
  out.width = packed.width, out.height = packed.height, out.channels = packed.channels;
  out.data.resize(packed.data.size());
  const std::ptrdiff_t n = std::ptrdiff_t(packed.data.size());
#pragma omp parallel for schedule(static) if (n >= (1 << 16))
  for (std::ptrdiff_t i = 0; i < n; ++i) out.data[i] = unpack_code(packed.data[i]);
}

float sample_bilinear(const Image& image, double u, double v, int c) {
  const double x = std::clamp(u - 0.5, 0.0, double(image.width - 1));
  const double y = std::clamp(v - 0.5, 0.0, double(image.height - 1));
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  const int x1 = std::min(x0 + 1, image.width - 1), y1 = std::min(y0 + 1, image.height - 1);
  const double fx = x - x0, fy = y - y0;
  const double top = (1 - fx) * image.at(y0, x0, c) + fx * image.at(y0, x1, c);
  const double bottom = (1 - fx) * image.at(y1, x0, c) + fx * image.at(y1, x1, c);
  return float((1 - fy) * top + fy * bottom);
}

}  // namespace retimegs
