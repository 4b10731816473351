// render's --size / --scale: the camera renders at the new size with its intrinsics scaled; a size
// of another aspect ratio, a bad scale or a huge frame is refused naming the option.
#include <cmath>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/playback/output_size.hpp"
#include "test_util.hpp"

namespace retimegs::playback {
namespace {
using test::expect_error;

Camera camera(int width, int height) {
  Camera cam;
  cam.name = "cam00";
  cam.width = width, cam.height = height;
  cam.fx = cam.fy = width, cam.cx = width / 2.0, cam.cy = height / 2.0;
  return cam;
}

TEST(OutputSize, ParsesWidthByHeight) {
  const OutputSize size = parse_output_size("1920x1080");
  EXPECT_EQ(size.width, 1920);
  EXPECT_EQ(size.height, 1080);
  EXPECT_FALSE(size.scale);
  for (const char* bad :
       {"1920", "0x10", "10x", "x10", "-4x3", "4.5x3", "4X3", "20000x100", "7x8", ""})
    expect_error([&] { parse_output_size(bad); }, {"--size", std::string("'") + bad + "'"});
}

TEST(OutputSize, SizeKeepsTheAspectRatioUpToWholePixels) {
  const Camera hd = camera(640, 360);
  const Camera full = at_output_size(hd, {1920, 1080, {}});
  EXPECT_EQ(full.width, 1920);
  EXPECT_EQ(full.height, 1080);
  EXPECT_DOUBLE_EQ(full.fx, 3 * hd.fx);
  EXPECT_DOUBLE_EQ(full.cy, 3 * hd.cy);
  // 255x191 is 4:3 only up to rounding: 128x96 is its half.
  EXPECT_EQ(at_output_size(camera(255, 191), {128, 96, {}}).height, 96);
  expect_error(
      [&] {
        at_output_size(hd, {1000, 1000, {}});
      },
      {"--size", "1000x1000", "cam00", "640x360", "1000x563"});
  EXPECT_EQ(at_output_size(hd, {}).width, 640);  // neither: the camera's own
}

TEST(OutputSize, ScaleMultipliesBothSides) {
  const Camera hd = camera(640, 360);
  const Camera half = at_output_size(hd, {0, 0, 0.5});
  EXPECT_EQ(half.width, 320);
  EXPECT_EQ(half.height, 180);
  EXPECT_DOUBLE_EQ(half.fy, hd.fy / 2);
  for (const double bad : {0.0, -1.0, std::nan(""), double(INFINITY)})
    expect_error([&] { at_output_size(hd, {0, 0, bad}); }, {"--scale"});
  expect_error([&] { at_output_size(hd, {0, 0, 100.0}); }, {"--scale", "64000x36000", "16384"});
  // An image too small to show anything (a 1x1 PNG at 1e-9).
  expect_error([&] { at_output_size(hd, {0, 0, 1e-9}); }, {"--scale", "0x0", "[8, 16384]"});
  expect_error([&] { at_output_size(hd, {0, 0, 0.02}); }, {"--scale", "13x7", "[8, 16384]"});
}

}  // namespace
}  // namespace retimegs::playback
