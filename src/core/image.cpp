#include "retimegs/core/image.hpp"

#include <algorithm>
#include <cmath>

namespace retimegs {

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
