#include "retimegs/model/camera_color.hpp"

#include <cmath>
#include <vector>

#include "retimegs/core/error.hpp"

namespace retimegs::model {

namespace {
// Images below this many pixels are not worth waking the other threads for.
constexpr std::ptrdiff_t kParallelPixels = 1 << 14;

std::array<float, 3> gains(const CameraColor& color) {
  return {std::exp(color.m[0]), std::exp(color.m[1]), std::exp(color.m[2])};
}
}  // namespace

void apply_camera_color(const Image& rgb, const CameraColor& color, Image& out) {
  if (rgb.channels != 3)
    fail("camera colour: the image has {} channels, expected 3 (RGB)", rgb.channels);
  out.width = rgb.width, out.height = rgb.height, out.channels = 3;
  out.data.resize(rgb.data.size());
  const std::array<float, 3> gain = gains(color);
  const std::ptrdiff_t pixels = std::ptrdiff_t(rgb.pixels());
#pragma omp parallel for schedule(static) if (pixels >= kParallelPixels)
  for (std::ptrdiff_t p = 0; p < pixels; ++p)
    for (int k = 0; k < 3; ++k)
      out.data[3 * p + k] = camera_color_value(gain[k], rgb.data[3 * p + k], color.c[k]);
}

void apply_camera_color_backward(const Image& rgb, const CameraColor& color, Image& v_render,
                                 CameraColor& v_color) {
  if (rgb.channels != 3 || v_render.width != rgb.width || v_render.height != rgb.height ||
      v_render.channels < 3)
    fail("camera colour backward: image {}x{}x{}, gradient {}x{}x{}", rgb.width, rgb.height,
         rgb.channels, v_render.width, v_render.height, v_render.channels);
  const std::array<float, 3> gain = gains(color);
  const int channels = v_render.channels;
  // Per-row sums in double, added up in row order afterwards: the same (m, c) gradient for any
  // thread count, which bit-identical training runs need.
  std::vector<double> row_sums(std::size_t(rgb.height) * 6, 0.0);
#pragma omp parallel for schedule(static) if (std::ptrdiff_t(rgb.pixels()) >= kParallelPixels)
  for (int y = 0; y < rgb.height; ++y) {
    double* sums = &row_sums[std::size_t(y) * 6];
    for (int x = 0; x < rgb.width; ++x) {
      const std::size_t p = std::size_t(y) * rgb.width + x;
      for (int k = 0; k < 3; ++k) {
        float& v = v_render.data[channels * p + k];
        sums[k] += double(v) * gain[k] * rgb.data[3 * p + k];  // d out / d m = exp(m) rgb
        sums[3 + k] += v;                                      // d out / d c = 1
        v *= gain[k];
      }
    }
  }
  double total[6] = {};
  for (int y = 0; y < rgb.height; ++y)
    for (int k = 0; k < 6; ++k) total[k] += row_sums[std::size_t(y) * 6 + k];
  for (int k = 0; k < 3; ++k) {
    v_color.m[k] += float(total[k]);
    v_color.c[k] += float(total[3 + k]);
  }
}

}  // namespace retimegs::model
