#include <cmath>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/eval/protocol.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "test_util.hpp"

namespace retimegs::eval {
namespace {

// 5 frames of 32x32 grey images whose value ramps linearly in time (0.1 per frame); camera 0 has
// masks covering the left half.
io::Scene ramp_scene(const std::filesystem::path& root, Split camera1_split = Split::kTrain) {
  io::Scene scene;
  scene.root = root;
  scene.num_frames = 5;
  scene.fps = 10;
  for (int c = 0; c < 2; ++c) {
    Camera cam;
    cam.name = "c" + std::to_string(c);
    cam.width = cam.height = 32;
    cam.fx = cam.fy = 30, cam.cx = cam.cy = 16;
    if (c == 1) cam.split = camera1_split;
    scene.cameras.push_back(cam);
    for (int k = 0; k < 5; ++k) {
      Image image(32, 32, 3, 0.2f + 0.1f * k);
      media::write_png(scene.image_path(c, k), image);
      if (c == 0) {
        Image mask(32, 32, 1, 0.0f);
        for (int y = 0; y < 32; ++y)
          for (int x = 0; x < 16; ++x) mask.at(y, x) = 1;
        media::write_png(scene.mask_path(c, k), mask);
      }
    }
  }
  io::write_scene_json(scene);
  return media::read_scene(root);
}

TEST(Protocol, BaselinesOnALinearRamp) {
  test::TempDir dir;
  const io::Scene scene = ramp_scene(dir / "s");
  EvalOptions options;
  options.frames = parse_frames("odd", scene.num_frames, "--frames");
  options.cameras = {0, 1};
  options.progress = false;
  // Nearest copies a neighbour: off by 0.1 everywhere -> 20 dB (8-bit rounding aside).
  const EvalResult nearest =
      evaluate_views(scene, baseline_renderer(scene, {0, 2, 4}, Baseline::kNearest), options);
  EXPECT_NEAR(nearest.psnr, 20.0, 0.1);
  EXPECT_EQ(nearest.per_view.size(), 4u);
  EXPECT_FALSE(nearest.masked);  // camera 1 has no masks
  EXPECT_TRUE(nearest.per_view[0].masked);
  EXPECT_FALSE(nearest.lpips.has_value());
  // Crossfade of a linear ramp is exact up to 8-bit rounding: far better than nearest.
  const EvalResult crossfade =
      evaluate_views(scene, baseline_renderer(scene, {0, 2, 4}, Baseline::kCrossfade), options);
  EXPECT_GT(crossfade.psnr, 45.0);
  // So is the flow baseline (flat images: zero flow), at in-between and training times alike.
  const FrameRenderer flow = baseline_renderer(scene, {0, 2, 4}, Baseline::kFlow);
  EXPECT_GT(evaluate_views(scene, flow, options).psnr, 45.0);
  EXPECT_EQ(flow(1, 2.0).data, media::load_image(scene, 1, 2).data);
  const auto j = nlohmann::json::parse(to_json(nearest));
  for (const char* key : {"psnr", "ssim", "lpips", "masked", "near", "frames", "per_view"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_TRUE(j["lpips"].is_null());
  EXPECT_TRUE(j["near"].is_null()) << "a baseline renders no Gaussians";
  EXPECT_EQ(j["frames"], nlohmann::json({1, 3}));
  EXPECT_EQ(j["per_view"][1]["camera"], "c0");
  EXPECT_EQ(j["per_view"][1]["frame"], 3);
}

// Off by 0.01 inside camera 0's mask (left half) and 0.1 outside: 40 dB masked, and over the
// whole image 10 log10(1 / ((0.01^2 + 0.1^2) / 2)) = 22.97 dB. Camera 1 has no mask, so its two
// figures agree.
TEST(Protocol, MaskedAndWholeImageSideBySide) {
  test::TempDir dir;
  const io::Scene scene = ramp_scene(dir / "s");
  EvalOptions options;
  options.frames = {1, 3};
  options.cameras = {0, 1};
  options.progress = false;
  const FrameRenderer off = [&scene](int camera, double time) {
    Image image = media::load_image(scene, camera, int(time));
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x)
        for (int c = 0; c < 3; ++c) image.at(y, x, c) += x < 16 ? 0.01f : 0.1f;
    return image;
  };
  const EvalResult r = evaluate_views(scene, off, options);
  const ViewScore& masked = r.per_view[0];
  EXPECT_TRUE(masked.masked);
  EXPECT_NEAR(masked.psnr, 40.0, 0.01);
  EXPECT_NEAR(masked.whole.psnr, 22.97, 0.01);
  EXPECT_GT(masked.ssim, masked.whole.ssim);
  const ViewScore& plain = r.per_view[2];
  EXPECT_FALSE(plain.masked);
  EXPECT_EQ(plain.psnr, plain.whole.psnr);
  EXPECT_EQ(plain.ssim, plain.whole.ssim);
  EXPECT_NEAR(r.whole.psnr, 22.97, 0.01);
  EXPECT_NEAR(r.psnr, (40.0 + 22.97) / 2, 0.01);
  const auto j = nlohmann::json::parse(to_json(r));
  for (const char* key : {"psnr", "ssim", "lpips"}) {
    EXPECT_TRUE(j["whole"].contains(key)) << key;
    EXPECT_TRUE(j["per_view"][0]["whole"].contains(key)) << key;
  }
  EXPECT_NEAR(j["whole"]["psnr"].get<double>(), r.whole.psnr, 1e-9);
  EXPECT_FALSE(j.contains("stability"));
}

// A training camera's held-out frames and a test camera answer two questions; they are scored
// apart as well as together. Camera 0 (training, masked on its left half) is off by 0.01 (40 dB),
// the test camera 1 by 0.1 (20 dB).
TEST(Protocol, TrainingAndTestCamerasApart) {
  test::TempDir dir;
  const io::Scene scene = ramp_scene(dir / "s", Split::kTest);
  EvalOptions options;
  options.frames = {1, 3};
  options.cameras = {0, 1};
  options.progress = false;
  const FrameRenderer off = [&scene](int camera, double time) {
    Image image = media::load_image(scene, camera, int(time));
    for (float& v : image.data) v += camera == 0 ? 0.01f : 0.1f;
    return image;
  };
  const EvalResult r = evaluate_views(scene, off, options);
  ASSERT_TRUE(r.train_views && r.test_views);
  EXPECT_EQ(r.train_views->views, 2u);
  EXPECT_EQ(r.test_views->views, 2u);
  EXPECT_NEAR(r.train_views->psnr, 40.0, 0.01);
  EXPECT_TRUE(r.train_views->masked);
  EXPECT_NEAR(r.test_views->psnr, 20.0, 0.01);
  EXPECT_NEAR(r.test_views->whole.psnr, 20.0, 0.01);
  EXPECT_FALSE(r.test_views->masked);
  EXPECT_NEAR(r.psnr, 30.0, 0.01);
  const auto j = nlohmann::json::parse(to_json(r));
  EXPECT_NEAR(j["train_views"]["psnr"].get<double>(), 40.0, 0.01);
  EXPECT_EQ(j["test_views"]["views"], 2);
  EXPECT_NEAR(j["test_views"]["whole"]["psnr"].get<double>(), 20.0, 0.01);
  EXPECT_EQ(j["per_view"][0]["split"], "train");
  EXPECT_EQ(j["per_view"][2]["split"], "test");

  // Training cameras alone: no test figure.
  options.cameras = {0};
  const EvalResult train_only = evaluate_views(scene, off, options);
  EXPECT_TRUE(train_only.train_views.has_value());
  EXPECT_FALSE(train_only.test_views.has_value());
  EXPECT_TRUE(nlohmann::json::parse(to_json(train_only))["test_views"].is_null());

  // A baseline blends a camera's own training frames: none for a test camera.
  EXPECT_NO_THROW(check_baseline_cameras(scene, {0}, "--cameras"));
  test::expect_error(
      [&] {
        check_baseline_cameras(scene, {0, 1}, "--cameras");
      },
      {"--cameras", "c1", "test camera"});
}

TEST(Protocol, SavesRendersAndParsesFrameLists) {
  test::TempDir dir;
  const io::Scene scene = ramp_scene(dir / "s");
  EvalOptions options;
  options.frames = parse_frames("1,2", scene.num_frames, "--frames");
  options.cameras = {1};
  options.progress = false;
  options.save_renders = dir / "renders";
  evaluate_views(scene, baseline_renderer(scene, {0, 2, 4}, Baseline::kNearest), options);
  EXPECT_TRUE(std::filesystem::exists(dir / "renders" / "c1" / "00001.png"));
  EXPECT_TRUE(std::filesystem::exists(dir / "renders" / "c1" / "00002.png"));
  EXPECT_EQ(parse_frames("all", 3, "f"), std::vector<int>({0, 1, 2}));
  EXPECT_THROW(parse_frames("1,x", 5, "--frames"), Error);
  EXPECT_THROW(parse_frames("7", 5, "--frames"), Error);
  EXPECT_THROW(parse_frames("", 5, "--frames"), Error);
}

}  // namespace
}  // namespace retimegs::eval
