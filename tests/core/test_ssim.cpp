#include <algorithm>
#include <cmath>
#include <random>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/core/ssim.hpp"

namespace retimegs {
namespace {

// A random pair in [0, 1] whose second image is correlated with the first (SSIM well away from 0
// and 1). Values are multiples of 2^-12 so that a ± 2^-10 is exact in float.
std::pair<Image, Image> random_pair(int width, int height, int channels, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Image a(width, height, channels), b(width, height, channels);
  const auto quantise = [](float v) { return std::round(v * 4096.0f) / 4096.0f; };
  for (std::size_t i = 0; i < a.data.size(); ++i) {
    a.data[i] = quantise(u(rng));
    b.data[i] = quantise(0.7f * a.data[i] + 0.3f * u(rng));
  }
  return {a, b};
}

float max_abs(const Image& image) {
  float m = 0;
  for (const float v : image.data) m = std::max(m, std::abs(v));
  return m;
}

TEST(Ssim, IdenticalImagesGiveOneAndZeroGradient) {
  const auto [a, b] = random_pair(23, 17, 3, 1);
  Image v_a;
  EXPECT_NEAR(ssim_backward(a, a, 1.0, v_a), 1.0, 1e-12);
  EXPECT_LT(max_abs(v_a), 1e-9f);  // SSIM = 1 is the maximum
}

// Away from the border a window over constant images has σ = 0, so SSIM is the luminance term
// (2αβ + C1) / (α² + β² + C1) with C1 = 1e-4; zero padding lowers it near the border.
TEST(Ssim, ConstantImagesGiveTheLuminanceTermInside) {
  const double alpha = 0.25, beta = 0.75;
  const Image a(30, 20, 2, float(alpha)), b(30, 20, 2, float(beta));
  Image map;
  const double mean = ssim(a, b, &map);
  const double expected = (2 * alpha * beta + 1e-4) / (alpha * alpha + beta * beta + 1e-4);
  for (int y = 5; y < 15; ++y)
    for (int x = 5; x < 25; ++x)
      for (int c = 0; c < 2; ++c) EXPECT_NEAR(map.at(y, x, c), expected, 1e-6) << y << " " << x;
  EXPECT_NE(map.at(0, 0, 0), map.at(10, 10, 0));
  EXPECT_LT(std::abs(mean - expected), 0.2);
}

// 40×37 runs as one band; 97×61 (above the parallel threshold) as three bands of ~20 rows, each
// recomputing its neighbours' edge rows.
TEST(Ssim, FastMatchesReference) {
  const int threads = max_threads();
  set_threads(3);
  for (const auto& [width, height] : {std::pair{40, 37}, std::pair{97, 61}}) {
    const auto [a, b] = random_pair(width, height, 3, 2);
    Image map, map_ref, v_a, v_a_ref;
    const double value = ssim(a, b, &map);
    const double value_ref = ssim_reference(a, b, &map_ref);
    EXPECT_NEAR(value, value_ref, 1e-12) << width;
    EXPECT_GT(value, 0.2);
    EXPECT_LT(value, 0.9);
    for (std::size_t i = 0; i < map.data.size(); ++i)
      ASSERT_NEAR(map.data[i], map_ref.data[i], 1e-6) << width << ": map value " << i;

    const double v_ssim = -0.2;  // the training loss 0.2 · (1 − SSIM)
    EXPECT_NEAR(ssim_backward(a, b, v_ssim, v_a), value_ref, 1e-12) << width;
    EXPECT_NEAR(ssim_backward_reference(a, b, v_ssim, v_a_ref), value_ref, 1e-12) << width;
    ASSERT_EQ(v_a.data.size(), a.data.size());
    const float scale = max_abs(v_a_ref);
    EXPECT_GT(scale, 0.0f);
    for (std::size_t i = 0; i < v_a.data.size(); ++i)
      ASSERT_NEAR(v_a.data[i], v_a_ref.data[i], 1e-6 * scale) << width << ": gradient value " << i;
  }
  set_threads(threads);
}

// Bands recompute their edges with the same arithmetic and the map is summed in row order, so the
// thread count changes nothing.
TEST(Ssim, SameBitsForAnyThreadCount) {
  const int threads = max_threads();
  const auto [a, b] = random_pair(130, 90, 3, 4);
  Image v_1, v_3;
  set_threads(1);
  const double s_1 = ssim_backward(a, b, 1.0, v_1);
  set_threads(3);
  const double s_3 = ssim_backward(a, b, 1.0, v_3);
  set_threads(threads);
  EXPECT_EQ(s_1, s_3);
  EXPECT_EQ(v_1.data, v_3.data);
}

TEST(Ssim, BackwardMatchesFiniteDifferences) {
  auto [a, b] = random_pair(16, 13, 3, 3);
  const double v_ssim = 1.0;
  Image v_a;
  ssim_backward(a, b, v_ssim, v_a);
  const float h = 1.0f / 1024;  // exact in float on the 2^-12 grid of the pair
  double worst = 0;
  for (std::size_t i = 0; i < a.data.size(); ++i) {
    const float saved = a.data[i];
    a.data[i] = saved + h;
    const double plus = ssim(a, b);
    a.data[i] = saved - h;
    const double minus = ssim(a, b);
    a.data[i] = saved;
    const double numeric = v_ssim * (plus - minus) / (2.0 * h);
    worst = std::max(worst, std::abs(numeric - v_a.data[i]));
    ASSERT_NEAR(v_a.data[i], numeric, 1e-7 + 1e-4 * std::abs(numeric)) << "value " << i;
  }
  RecordProperty("worst_abs_error", fmt::format("{:.3e}", worst));
}

// A prepared target serves several renders: ssim_backward_add returns ssim_backward's value and
// adds its gradient, bit for bit, into the first channels of a wider gradient image; the other
// channels keep their values. An unprepared target or a mismatched gradient is an error.
TEST(Ssim, PreparedTargetAddsTheSameGradient) {
  const int threads_before = max_threads();
  for (const int threads : {1, 2})
    for (const auto& [channels, wide_channels] :
         {std::pair{3, 5}, std::pair{3, 3}, std::pair{1, 2}}) {
      set_threads(threads);
      const auto [b, unused] = random_pair(150, 130, channels, 5);
      SsimTarget target;
      target.assign(b);
      for (const unsigned seed : {6u, 7u}) {
        const auto [a, also_unused] = random_pair(150, 130, channels, seed);
        Image v_a;
        const double s = ssim_backward(a, b, -0.3, v_a);
        Image wide(150, 130, wide_channels, 0.5f);
        EXPECT_EQ(ssim_backward_add(a, target, -0.3, wide), s);
        for (std::size_t p = 0; p < a.pixels(); ++p)
          for (int c = 0; c < wide_channels; ++c)
            ASSERT_EQ(wide.data[wide_channels * p + c],
                      c < channels ? 0.5f + v_a.data[channels * p + c] : 0.5f)
                << p << " " << channels << " in " << wide_channels;
      }
    }
  set_threads(threads_before);
  const Image a(8, 8, 3);
  Image narrow(8, 8, 2);
  SsimTarget unprepared;
  EXPECT_THROW(ssim_backward_add(a, unprepared, 1.0, narrow), Error);
  SsimTarget target;
  target.assign(a);
  EXPECT_THROW(ssim_backward_add(a, target, 1.0, narrow), Error);
}

TEST(Ssim, SizeMismatchThrows) {
  const Image a(8, 8, 3), b(8, 8, 1), c(8, 7, 3);
  EXPECT_THROW(ssim(a, b), Error);
  Image v_a;
  EXPECT_THROW(ssim_backward(a, c, 1.0, v_a), Error);
  try {
    ssim(a, c);
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("8x8x3 vs 8x7x3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace retimegs
