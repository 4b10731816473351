// The per-camera colour correction: its values, and its backward against central differences of
// a linear loss Σ w · out summed in double (steps of 2^-7 on m, c and the image; the map is
// linear in c and the image and smooth in m, so only float rounding of `out` limits the match).
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "retimegs/model/camera_color.hpp"
#include "retimegs/model/slice.hpp"
#include "test_util.hpp"

namespace retimegs::model {
namespace {

constexpr float kStep = 1.0f / 128;

Image random_image(int width, int height, int channels, float lo, float hi, std::mt19937& rng) {
  Image image(width, height, channels);
  std::uniform_real_distribution<float> value(lo, hi);
  for (float& v : image.data) v = value(rng);
  return image;
}

CameraColor some_color() {
  CameraColor color;
  color.m = {0.3f, -0.2f, 0.05f};
  color.c = {-0.04f, 0.1f, 0.02f};
  return color;
}

TEST(CameraColor, AppliesGainAndOffsetPerChannel) {
  std::mt19937 rng(1);
  const Image rgb = random_image(5, 4, 3, 0, 1, rng);
  const CameraColor color = some_color();
  Image out;
  apply_camera_color(rgb, color, out);
  ASSERT_EQ(out.data.size(), rgb.data.size());
  for (std::size_t i = 0; i < rgb.data.size(); ++i)
    EXPECT_FLOAT_EQ(out.data[i], std::exp(color.m[i % 3]) * rgb.data[i] + color.c[i % 3]) << i;
  // The zero correction is the identity; the output may be the input.
  Image same;
  apply_camera_color(rgb, CameraColor{}, same);
  EXPECT_EQ(same.data, rgb.data);
  Image in_place = rgb;
  apply_camera_color(in_place, color, in_place);
  EXPECT_EQ(in_place.data, out.data);
  test::expect_error([&] { apply_camera_color(Image(2, 2, 5), color, out); }, {"5 channels"});
}

TEST(CameraColor, BackwardMatchesCentralDifferences) {
  std::mt19937 rng(2);
  Image rgb = random_image(9, 7, 3, 0, 1, rng);
  const Image weights = random_image(9, 7, 3, -1, 1, rng);
  CameraColor color = some_color();
  Image out;
  const auto loss = [&] {
    apply_camera_color(rgb, color, out);
    double sum = 0;
    for (std::size_t i = 0; i < out.data.size(); ++i) sum += double(weights.data[i]) * out.data[i];
    return sum;
  };
  const auto central_difference = [&](float& value) {
    return test::central_difference(value, kStep, loss);
  };
  // d loss / d out = weights, in the RGB channels of a render that also has flow channels.
  Image v_render = random_image(9, 7, 3 + kFlowChannels, -1, 1, rng);
  for (std::size_t p = 0; p < rgb.pixels(); ++p)
    for (int k = 0; k < 3; ++k) v_render.data[v_render.channels * p + k] = weights.data[3 * p + k];
  const Image upstream = v_render;
  CameraColor v_color;
  v_color.m = {1, 2, 3};  // the backward adds to it
  apply_camera_color_backward(rgb, color, v_render, v_color);
  for (int k = 0; k < 3; ++k) {
    const double v_m = central_difference(color.m[k]), v_c = central_difference(color.c[k]);
    EXPECT_NEAR(v_color.m[k] - (k + 1), v_m, 1e-4 * std::abs(v_m) + 1e-5) << "m" << k;
    EXPECT_NEAR(v_color.c[k], v_c, 1e-4 * std::abs(v_c) + 1e-5) << "c" << k;
  }
  for (std::size_t p = 0; p < rgb.pixels(); ++p) {
    for (int k = 0; k < 3; ++k) {
      const double numeric = central_difference(rgb.data[3 * p + k]);
      EXPECT_NEAR(v_render.data[v_render.channels * p + k], numeric,
                  1e-4 * std::abs(numeric) + 1e-5)
          << "pixel " << p << " channel " << k;
    }
    for (int k = 3; k < v_render.channels; ++k)
      ASSERT_EQ(v_render.data[v_render.channels * p + k], upstream.data[v_render.channels * p + k])
          << "flow channel " << k << " of pixel " << p;
  }
  Image wrong_size(4, 7, 3);
  test::expect_error([&] { apply_camera_color_backward(rgb, color, wrong_size, v_color); },
                     {"gradient 4x7x3"});
}

}  // namespace
}  // namespace retimegs::model
