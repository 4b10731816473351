#include <filesystem>

#include <gtest/gtest.h>

#include "io/small_scene.hpp"
#include "retimegs/eval/contact_sheet.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "test_util.hpp"

namespace retimegs::eval {
namespace {
namespace fs = std::filesystem;

// Ground truth vs renders: each frame's image, then each render folder's image of it.
TEST(ContactSheet, RendersFollowTheirGroundTruth) {
  test::TempDir dir;
  const io::Scene scene = test::write_small_scene(dir / "s");
  const fs::path renders = dir / "renders";
  Image red(12, 8, 3);
  for (std::size_t p = 0; p < red.pixels(); ++p) red.data[3 * p] = 1;
  media::write_png(renders / "7" / "00001.png", red);
  SheetOptions options;
  options.cameras = {1};
  options.frames = {1};
  options.tile_width = 12;
  options.gap = 2;
  options.renders = {renders};
  options.labels = false;
  const Image sheet = contact_sheet(scene, options);
  EXPECT_EQ(sheet.width, 2 + 2 * (12 + 2));  // ground truth, render; no mask / flow column
  EXPECT_EQ(sheet.height, 2 + 8 + 2);
  const Image truth = media::load_image(scene, 1, 1);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(sheet.at(2 + 3, 2 + 5, c), truth.at(3, 5, c), 1e-6);
    EXPECT_NEAR(sheet.at(2 + 3, 16 + 5, c), c == 0 ? 1.0f : 0.0f, 1e-6);
  }
  options.frames = {2};  // no render of frame 2
  test::expect_error([&] { contact_sheet(scene, options); }, {"7/00002.png"});
}

// A caption strip above every tile: white with dark text, the tile's pixels below it unchanged;
// the sheet grows by the strip's height only.
TEST(ContactSheet, CaptionsAboveEveryTile) {
  test::TempDir dir;
  const io::Scene scene = test::write_small_scene(dir / "s");
  SheetOptions options;
  options.cameras = {1};
  options.frames = {1};
  options.tile_width = 200;
  options.gap = 2;
  const Image plain = [&] {
    SheetOptions o = options;
    o.labels = false;
    return contact_sheet(scene, o);
  }();
  const Image sheet = contact_sheet(scene, options);
  EXPECT_EQ(sheet.width, plain.width);
  const int strip = sheet.height - plain.height;
  ASSERT_GT(strip, 8);
  ASSERT_LT(strip, 40);
  int dark = 0;
  for (int y = 2; y < 2 + strip; ++y)
    for (int x = 2; x < 2 + 200; ++x) {
      EXPECT_NEAR(sheet.at(y, x, 0), sheet.at(y, x, 2), 1e-6) << "grey text on white";
      dark += sheet.at(y, x, 0) < 0.5f;
    }
  EXPECT_GT(dark, 20) << "the caption has text";
  for (int y = 2; y < plain.height - 2; ++y)
    for (int x = 0; x < plain.width; ++x)
      for (int c = 0; c < 3; ++c) ASSERT_EQ(sheet.at(y + strip, x, c), plain.at(y, x, c));
}

}  // namespace
}  // namespace retimegs::eval
