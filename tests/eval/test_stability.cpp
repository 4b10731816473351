#include <cmath>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "retimegs/eval/protocol.hpp"
#include "retimegs/io/flow_io.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "test_util.hpp"

namespace retimegs::eval {
namespace {

constexpr int kSize = 40;

// Whether pixel (x, y) is inside the 6x6 square that moves 4 px right per frame.
bool in_square(int x, int y, int frame) {
  return x >= 2 + 4 * frame && x < 8 + 4 * frame && y >= 10 && y < 16;
}

// A scene of `frames` frames and `cameras` cameras c0, c1, ... of kSize x kSize, without files.
io::Scene blank_scene(const std::filesystem::path& root, int frames, int cameras) {
  io::Scene scene;
  scene.root = root;
  scene.num_frames = frames;
  scene.fps = 10;
  for (int c = 0; c < cameras; ++c) {
    Camera cam;
    cam.name = "c" + std::to_string(c);
    cam.width = cam.height = kSize;
    cam.fx = cam.fy = 30, cam.cx = cam.cy = kSize / 2.0;
    scene.cameras.push_back(cam);
  }
  return scene;
}

// 5 frames, 40x40: a still grey background (0.4) with the moving square (white). Camera 0 has
// masks of the square; camera 1 has none, and its pixel (30, 30) drifts by one 8-bit level over
// the clip while (32, 30) drifts by two.
io::Scene square_scene(const std::filesystem::path& root) {
  io::Scene scene = blank_scene(root, 5, 2);
  for (int c = 0; c < 2; ++c) {
    for (int k = 0; k < 5; ++k) {
      Image image(kSize, kSize, 3, 100 / 255.0f);
      Image mask(kSize, kSize, 1, 0.0f);
      for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x)
          if (in_square(x, y, k)) {
            mask.at(y, x) = 1;
            for (int ch = 0; ch < 3; ++ch) image.at(y, x, ch) = 1;
          }
      if (c == 1) {
        image.at(30, 30, 1) = (100 + (k == 4)) / 255.0f;
        image.at(30, 32, 1) = (100 + 2 * (k == 4)) / 255.0f;
      }
      media::write_png(scene.image_path(c, k), image);
      if (c == 0) media::write_png(scene.mask_path(c, k), mask);
    }
  }
  io::write_scene_json(scene);
  return media::read_scene(root);
}

TEST(Stability, StaticPixelsFromMasksOrValues) {
  test::TempDir dir;
  const io::Scene scene = square_scene(dir / "s");
  EXPECT_EQ(stability_dilation_radius(kSize, kSize), 1);
  EXPECT_EQ(stability_dilation_radius(640, 360), 13);
  const StaticPixels masked = static_pixels(scene, 0);
  EXPECT_TRUE(masked.from_masks);
  const auto at = [](const StaticPixels& s, int x, int y) { return s.is_static[y * kSize + x]; };
  EXPECT_EQ(at(masked, 3, 12), 0);   // under the square at frame 0
  EXPECT_EQ(at(masked, 24, 12), 0);  // ... at frame 4
  EXPECT_EQ(at(masked, 12, 9), 0);   // one pixel above its path: inside the dilation
  EXPECT_EQ(at(masked, 12, 8), 1);   // two pixels above: static
  EXPECT_EQ(at(masked, 30, 30), 1);
  const StaticPixels values = static_pixels(scene, 1);
  EXPECT_FALSE(values.from_masks);
  EXPECT_EQ(at(values, 3, 12), 0);
  EXPECT_EQ(at(values, 12, 9), 1);   // no dilation without masks
  EXPECT_EQ(at(values, 30, 30), 1);  // one level of drift is still static
  EXPECT_EQ(at(values, 32, 30), 0);  // two is not
}

// A 3x3 square that jumps 8 px right per frame: its masks leave 5-px gaps along its path, which
// the frames' masks call static; the scene's flows (here from frame k to k + 1) say the square
// crosses them between frames.
TEST(Stability, TheMasksPathsAlongTheFlowsAreNotStatic) {
  test::TempDir dir;
  const io::Scene scene = blank_scene(dir / "s", 4, 1);
  auto inside = [](int x, int y, int k) {
    return x >= 2 + 8 * k && x < 5 + 8 * k && y >= 10 && y < 13;
  };
  for (int k = 0; k < 4; ++k) {
    Image image(kSize, kSize, 3, 0.4f), mask(kSize, kSize, 1, 0.0f);
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x)
        if (inside(x, y, k)) mask.at(y, x) = 1, image.at(y, x, 0) = 1;
    media::write_png(scene.image_path(0, k), image);
    media::write_png(scene.mask_path(0, k), mask);
  }
  io::write_scene_json(scene);
  const auto at = [](const StaticPixels& s, int x, int y) { return s.is_static[y * kSize + x]; };
  const StaticPixels masks_only = static_pixels(media::read_scene(scene.root), 0);
  EXPECT_FALSE(masks_only.swept);
  EXPECT_EQ(at(masks_only, 7, 11), 1);  // in the gap between frames 0 and 1
  for (int k = 0; k < 3; ++k) {
    Flow flow(kSize, kSize);
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x)
        if (inside(x, y, k)) flow.uv[2 * (y * kSize + x)] = 8;
    io::write_flo(scene.flow_path(0, k, k + 1), flow);
  }
  const StaticPixels swept = static_pixels(media::read_scene(scene.root), 0);
  EXPECT_TRUE(swept.swept);
  for (const int x : {7, 15, 23}) EXPECT_EQ(at(swept, x, 11), 0) << x;  // the gaps
  EXPECT_EQ(at(swept, 7, 8), 1);    // two pixels above the path: static
  EXPECT_EQ(at(swept, 33, 11), 1);  // beyond the last frame
}

// A render that is the still background plus a pulse of `pulse` levels at the training frames
// (even times), with the moving square drawn anywhere in its path flickering between black and
// white: the flicker is on moving pixels and must not count.
FrameRenderer pulsing_renderer(double pulse) {
  return [pulse](int, double t) {
    const bool at_training_frame = std::fmod(t, 2.0) == 0.0;
    Image image(kSize, kSize, 3, float((100 + (at_training_frame ? pulse : 0)) / 255.0));
    const float flicker = std::fmod(t * 8, 2.0) < 1 ? 0.0f : 1.0f;
    for (int y = 10; y < 16; ++y)
      for (int x = 2 + int(4 * t); x < 8 + int(4 * t); ++x)
        for (int c = 0; c < 3; ++c) image.at(y, x, c) = flicker;
    return image;
  };
}

TEST(Stability, MeasuresThePulseAtTrainingFramesOnStaticPixels) {
  test::TempDir dir;
  const io::Scene scene = square_scene(dir / "s");
  const Stability s = temporal_stability(scene, pulsing_renderer(3.0), {0, 1}, {4, 0, 2}, {}, 8,
                                         /*progress=*/false);
  EXPECT_EQ(s.steps, 8);
  ASSERT_EQ(s.per_camera.size(), 2u);
  for (const CameraStability& c : s.per_camera) {
    ASSERT_TRUE(c.max_change.has_value()) << c.camera;
    EXPECT_NEAR(*c.max_change, 3.0, 1e-3) << c.camera;
    // The first pulse: from training frame 0 to the next slow-motion time.
    EXPECT_EQ(c.max_between, std::make_pair(0.0, 0.25)) << c.camera;
    EXPECT_GT(c.static_fraction, 0.8) << c.camera;
  }
  EXPECT_TRUE(s.per_camera[0].masked);
  EXPECT_FALSE(s.per_camera[1].masked);
  EXPECT_NEAR(*s.max, 3.0, 1e-3);
  EXPECT_NEAR(*s.mean, 3.0, 1e-3);
  const Stability steady =
      temporal_stability(scene, pulsing_renderer(0.0), {0}, {0, 2, 4}, {}, 8, /*progress=*/false);
  EXPECT_NEAR(*steady.max, 0.0, 1e-9);
  EXPECT_THROW(temporal_stability(scene, pulsing_renderer(0.0), {0}, {2}, {}, 8, false), Error);
}

// A merged model's seams are reported apart: a jump at the seam (time 2) against a smaller pulse
// at the other training frames (0 and 4).
TEST(Stability, SeamsAreReportedApartFromTheOtherTrainingFrames) {
  test::TempDir dir;
  const io::Scene scene = square_scene(dir / "s");
  const FrameRenderer pulse = pulsing_renderer(1.0);
  const FrameRenderer render = [&pulse](int c, double t) {
    Image image = pulse(c, t);
    if (t == 2.0)
      for (float& v : image.data) v += 4.0f / 255.0f;
    return image;
  };
  const Stability s = temporal_stability(scene, render, {0}, {0, 2, 4}, {2.0}, 8, false);
  ASSERT_EQ(s.per_camera.size(), 1u);
  const CameraStability& c = s.per_camera[0];
  ASSERT_TRUE(c.at_seams && c.at_training_frames);
  EXPECT_NEAR(*c.at_seams, 5.0, 1e-3);
  EXPECT_NEAR(*c.at_training_frames, 1.0, 1e-3);
  EXPECT_NEAR(*s.max_at_seams, 5.0, 1e-3);
  EXPECT_NEAR(*s.max_at_training_frames, 1.0, 1e-3);
  EXPECT_EQ(s.seams, std::vector<double>{2.0});
  // Without seams every training frame counts as one, and a seam must be a training frame.
  const Stability plain = temporal_stability(scene, render, {0}, {0, 2, 4}, {}, 8, false);
  EXPECT_FALSE(plain.per_camera[0].at_seams);
  EXPECT_NEAR(*plain.per_camera[0].at_training_frames, 5.0, 1e-3);
  EXPECT_THROW(temporal_stability(scene, render, {0}, {0, 2, 4}, {3.0}, 8, false), Error);
}

TEST(Stability, ReportedInTheEvalJson) {
  test::TempDir dir;
  const io::Scene scene = square_scene(dir / "s");
  EvalOptions options;
  options.frames = {1, 3};
  options.cameras = {0, 1};
  options.stability_frames = {0, 2, 4};
  options.progress = false;
  const EvalResult result =
      evaluate_views(scene, baseline_renderer(scene, {0, 2, 4}, Baseline::kCrossfade), options);
  ASSERT_TRUE(result.stability.has_value());
  // The cross-fade keeps the still background still.
  EXPECT_NEAR(*result.stability->max, 0.0, 1e-3);  // float rounding of the blend
  const auto j = nlohmann::json::parse(to_json(result));
  EXPECT_EQ(j["stability"]["steps"], 8);
  EXPECT_EQ(j["stability"]["per_camera"].size(), 2u);
  EXPECT_EQ(j["stability"]["per_camera"][1]["camera"], "c1");
  EXPECT_FALSE(j["stability"]["per_camera"][1]["masked"].get<bool>());
}

}  // namespace
}  // namespace retimegs::eval
