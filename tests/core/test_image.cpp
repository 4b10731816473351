#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "retimegs/core/image.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {

// The values media::read_image gives (OpenCV's convertTo: code × (1 / 255) or × (1 / 65535) in
// double, rounded to float) survive packing exactly, for every 8-bit and 16-bit code.
TEST(PackedImage, EveryEightAndSixteenBitValueRoundTripsExactly) {
  Image eight(256, 1, 1), sixteen(65536, 1, 1);
  for (int k = 0; k < 256; ++k) eight.data[k] = float(double(k) * (1.0 / 255.0));
  for (int k = 0; k < 65536; ++k) sixteen.data[k] = float(double(k) * (1.0 / 65535.0));
  for (const Image* image : {&eight, &sixteen}) {
    const PackedImage packed = pack(*image, "test");
    EXPECT_EQ(packed.bytes(), image->data.size() * 2);
    Image back(3, 3, 3, 0.5f);  // a used buffer: unpack resizes it
    unpack(packed, back);
    EXPECT_EQ(back.width, image->width);
    EXPECT_EQ(back.height, image->height);
    EXPECT_EQ(back.channels, 1);
    EXPECT_EQ(back.data, image->data);
  }
  EXPECT_EQ(pack(eight, "test").data[255], 65535);
  EXPECT_EQ(pack(eight, "test").data[1], 257);
}

TEST(PackedImage, OutOfRangeAndNonFiniteValuesNameTheImageAndPixel) {
  Image image(4, 3, 3, 0.25f);
  image.at(2, 1, 2) = 1.5f;
  test::expect_error([&] { pack(image, "cam/00002.png"); },
                     {"cam/00002.png", "pixel (1, 2) channel 2", "outside [0, 1]"});
  image.at(2, 1, 2) = std::numeric_limits<float>::quiet_NaN();
  test::expect_error([&] { pack(image, "x.png"); }, {"x.png", "nan"});
  image.at(2, 1, 2) = -0.0f;
  EXPECT_EQ(pack(image, "x.png").data[(2 * 4 + 1) * 3 + 2], 0);
}

}  // namespace
}  // namespace retimegs
