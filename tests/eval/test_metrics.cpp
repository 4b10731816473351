#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/psnr.hpp"
#include "retimegs/core/ssim.hpp"
#include "retimegs/eval/metrics.hpp"
#include "retimegs/media/image_io.hpp"
#include "test_util.hpp"

namespace retimegs::eval {
namespace {

// data/metrics/ssim_psnr/reference_values.json (scikit-image 0.19.3 and numpy float64).
struct Reference {
  const char* a;
  const char* b;
  double psnr;           // psnr_uint8_peak255
  double ssim_3dgs;      // ssim_3dgs_zero_pad_full_mean_float64
  double ssim_gaussian;  // ssim_skimage_gauss11_sigma1.5_popcov_crop5
};
constexpr Reference kReferences[] = {
    {"camera.png", "camera_noisy_seed5_sigma20.png", 22.40935284991332, 0.3717030174440691,
     0.3579642362365845},
    {"astronaut.png", "astronaut_noisy.png", 25.148271360372135, 0.5026389481451462,
     0.4958751767370742},
};

Image random_image(int width, int height, int channels, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Image image(width, height, channels);
  for (float& v : image.data) v = u(rng);
  return image;
}

// b = a + noise, clamped to [0, 1]: a pair with SSIM well inside (0, 1).
Image noisy_copy(const Image& a, float sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, sigma);
  Image b = a;
  for (float& v : b.data) v = std::clamp(v + noise(rng), 0.0f, 1.0f);
  return b;
}

using test::message_of;

// Grey files are read as RGB with three equal channels: PSNR and the SSIM mean are unchanged.
// PSNR is exact up to the float32 images: read_image scales the 8-bit codes by float(1/255), which
// is 5.9e-8 relative below 1/255, so the MSE is 1.2e-7 relative low and the PSNR 2.9e-8 relative
// high (correctly rounded code/255 values would still leave ~2.5e-9).
constexpr double kPsnrRelative = 5e-8;

TEST(Metrics, PsnrAndSsimMatchScikitImageReferences) {
  RETIMEGS_REQUIRE_DATA("metrics/ssim_psnr");
  const auto dir = test::shared_data() / "metrics/ssim_psnr";
  for (const Reference& r : kReferences) {
    const Image a = media::read_image(dir / r.a), b = media::read_image(dir / r.b);
    EXPECT_NEAR(psnr(a, b), r.psnr, kPsnrRelative * r.psnr) << r.a;
    EXPECT_NEAR(psnr(b, a), r.psnr, kPsnrRelative * r.psnr) << r.a;
    EXPECT_NEAR(ssim_in_box(a, b), r.ssim_3dgs, 1e-6) << r.a;

    // Cropping the zero-padded map by the window radius (5 px) leaves the valid windows only.
    Image map;
    EXPECT_NEAR(ssim(a, b, &map), r.ssim_3dgs, 1e-6) << r.a;
    const PixelBox valid{5, 5, a.width - 5, a.height - 5};
    double sum = 0;
    const Image inner = crop(map, valid);
    for (const float v : inner.data) sum += v;
    EXPECT_NEAR(sum / double(inner.data.size()), r.ssim_gaussian, 1e-6) << r.a;
  }
}

TEST(Metrics, MaskedPsnrAveragesOverForegroundPixelsOnly) {
  const Image a = random_image(20, 15, 3, 1), b = noisy_copy(a, 0.1f, 2);
  Image mask(20, 15, 1);
  std::mt19937 rng(3);
  for (float& m : mask.data) m = rng() % 3 == 0 ? 1.0f : 0.0f;
  double squared = 0;
  int count = 0;
  for (int y = 0; y < 15; ++y)
    for (int x = 0; x < 20; ++x)
      if (mask.at(y, x) > 0.5f)
        for (int c = 0; c < 3; ++c) {
          const double d = double(a.at(y, x, c)) - b.at(y, x, c);
          squared += d * d, ++count;
        }
  ASSERT_GT(count, 0);
  const double expected = 10 * std::log10(count / squared);
  EXPECT_NEAR(psnr(a, b, &mask), expected, 1e-12);
  EXPECT_GT(std::abs(psnr(a, b) - expected), 1e-3);  // the mask matters

  Image changed = b;  // background differences do not count
  for (std::size_t p = 0; p < changed.pixels(); ++p)
    if (mask.data[p] <= 0.5f) changed.data[p * 3] = 1.0f - changed.data[p * 3];
  EXPECT_EQ(psnr(a, changed, &mask), psnr(a, b, &mask));
  EXPECT_TRUE(std::isinf(psnr(a, a)));
}

TEST(Metrics, SsimInBoxUsesTheMaskBoundingBoxOnly) {
  const Image a = random_image(40, 30, 3, 4), b = noisy_copy(a, 0.1f, 5);
  Image mask(40, 30, 1);  // an L shape whose bounding box is [7, 29) × [4, 21)
  for (int y = 4; y < 21; ++y) mask.at(y, 7) = 1.0f;
  for (int x = 7; x < 29; ++x) mask.at(20, x) = 1.0f;
  const PixelBox box = mask_bounding_box(mask);
  EXPECT_EQ(box.x0, 7);
  EXPECT_EQ(box.x1, 29);
  EXPECT_EQ(box.y0, 4);
  EXPECT_EQ(box.y1, 21);

  const double inside = ssim_in_box(a, b, &mask);
  EXPECT_DOUBLE_EQ(inside, ssim(crop(a, box), crop(b, box)));
  EXPECT_GT(std::abs(inside - ssim_in_box(a, b)), 1e-4);  // differs from the whole image

  // Noise outside the box does not change the value; noise inside does.
  Image outside = b, within = b;
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) {
      const bool in_box = x >= 7 && x < 29 && y >= 4 && y < 21;
      (in_box ? within : outside).at(y, x, 1) = 0.5f;
    }
  EXPECT_EQ(ssim_in_box(a, outside, &mask), inside);
  EXPECT_GT(std::abs(ssim_in_box(a, within, &mask) - inside), 1e-3);
}

TEST(Metrics, ApplyMaskBlacksOutTheBackground) {
  const Image image = random_image(6, 5, 3, 6);
  Image mask(6, 5, 1);
  mask.at(2, 3) = 1.0f, mask.at(4, 0) = 0.7f, mask.at(1, 1) = 0.3f;
  const Image masked = apply_mask(image, mask);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 6; ++x)
      for (int c = 0; c < 3; ++c)
        EXPECT_EQ(masked.at(y, x, c), mask.at(y, x) > 0.5f ? image.at(y, x, c) : 0.0f);
}

TEST(Metrics, BadInputsThrowNamingTheProblem) {
  const Image a = random_image(8, 6, 3, 7);
  Image nan = a;
  nan.at(4, 5, 2) = std::nanf("");
  EXPECT_NE(message_of([&] { psnr(a, nan); }).find("pixel (5, 4) channel 2"), std::string::npos)
      << message_of([&] { psnr(a, nan); });
  EXPECT_NE(message_of([&] { ssim_in_box(a, Image(8, 5, 3)); }).find("8x6x3 vs 8x5x3"),
            std::string::npos);
  const Image empty_mask(8, 6, 1);
  EXPECT_NE(message_of([&] { psnr(a, a, &empty_mask); }).find("no foreground"), std::string::npos);
  EXPECT_NE(message_of([&] { ssim_in_box(a, a, &empty_mask); }).find("no foreground"),
            std::string::npos);
  const Image small_mask(4, 6, 1);
  EXPECT_NE(message_of([&] { apply_mask(a, small_mask); }).find("mask is 4x6x1"),
            std::string::npos);
  EXPECT_THROW(crop(a, PixelBox{2, 2, 9, 4}), Error);
}

}  // namespace
}  // namespace retimegs::eval
