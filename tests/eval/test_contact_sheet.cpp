#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "io/small_scene.hpp"
#include "retimegs/eval/contact_sheet.hpp"
#include "retimegs/io/flow_io.hpp"
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

// The flow column shows the flow training reads: by default stride 2, that of the default
// --train-frames even, where it exists (synth writes strides 1 and 2, prepare with even frames 2
// only), else the shortest stride there is (prepare --train-frames all: 1); or --stride K's.
TEST(ContactSheet, FlowColumnShowsTheStrideTrainingReads) {
  test::TempDir dir;
  const io::Scene scene = test::write_small_scene(dir / "s");  // cam00: masks, flow 0 to 1
  Flow right(12, 8), down(12, 8);
  for (std::size_t p = 0; p < right.pixels(); ++p)
    right.uv[2 * p] = 1.0f, down.uv[2 * p + 1] = 1.0f + float(p % 3);
  io::write_flo(scene.flow_path(0, 0, 1), right);
  SheetOptions options;
  options.cameras = {0};
  options.frames = {0};
  options.tile_width = 12;
  options.gap = 2;
  options.labels = false;
  // The third tile (frame, mask, flow) against the colour coding of `flow`.
  const auto expect_flow_column = [&](const Flow& flow, const std::string& what) {
    const Image sheet = contact_sheet(scene, options);
    ASSERT_EQ(sheet.width, 2 + 3 * (12 + 2)) << what;
    const Image expected = flow_to_color(flow);
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 12; ++x)
        for (int c = 0; c < 3; ++c)
          ASSERT_NEAR(sheet.at(2 + y, 2 + 2 * 14 + x, c), expected.at(y, x, c), 1e-6)
              << what << " " << x << "," << y << "," << c;
  };
  expect_flow_column(right, "stride 1 where only it exists");
  io::write_flo(scene.flow_path(0, 0, 2), down);
  expect_flow_column(down, "stride 2 where both exist");
  options.flow_stride = 1;
  expect_flow_column(right, "--stride 1");
  fs::remove(scene.flow_path(0, 0, 1));  // as prepare leaves it with even training frames
  EXPECT_EQ(contact_sheet(scene, options).width, 2 + 2 * (12 + 2)) << "no stride-1 flow";
  options.flow_stride = 0;
  expect_flow_column(down, "stride 2 where only it exists");
  options.flow_stride = -1;
  test::expect_error([&] { contact_sheet(scene, options); }, {"--stride", "-1"});
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
