// load_training_set with --downscale: cameras, images, masks and flows at 1/F of the scene's size,
// scaled together so that a pixel, its mask and its motion still agree.
#include <gtest/gtest.h>

#include "retimegs/train_run/load_training_set.hpp"
#include "synth_scene.hpp"
#include "test_util.hpp"

namespace retimegs::train {
namespace {

double mean(const std::vector<float>& values) {
  double sum = 0;
  for (float v : values) sum += v;
  return sum / double(values.size());
}

TEST(LoadTrainingSet, DownscaleScalesCamerasImagesMasksAndFlowsTogether) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 2, 64, 48);
  const TrainingSet full = load_training_set(scene, io::FrameSelection::kEven);
  const TrainingSet half = load_training_set(scene, io::FrameSelection::kEven, {}, 2.0);
  const Camera &a = full.scene.cameras[0], &b = half.scene.cameras[0];
  EXPECT_EQ(b.width, 32);
  EXPECT_EQ(b.height, 24);
  EXPECT_DOUBLE_EQ(b.fx, a.fx / 2);
  EXPECT_DOUBLE_EQ(b.cy, a.cy / 2);
  Image full_image, half_image;
  unpack(full.images[0][1], full_image);
  unpack(half.images[0][1], half_image);
  ASSERT_EQ(half_image.width, 32);
  ASSERT_EQ(half_image.height, 24);
  EXPECT_NEAR(mean(half_image.data), mean(full_image.data), 1e-3);  // area averaging
  ASSERT_TRUE(half.masks[0][1]);
  EXPECT_EQ(half.masks[0][1]->width, 32);
  EXPECT_NEAR(mean(half.masks[0][1]->data), mean(full.masks[0][1]->data), 1e-6);
  // A known flow pixel is the mean of its 2x2 known source pixels, in half-size pixels.
  const Flow &f = *full.forward[0][1], &h = *half.forward[0][1];
  ASSERT_EQ(h.width, 32);
  int compared = 0;
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 32; ++x) {
      double u = 0, v = 0;
      bool known = true;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const std::size_t i = std::size_t(2 * y + dy) * 64 + 2 * x + dx;
          known = known && f.valid[i];
          u += f.uv[2 * i] / 4, v += f.uv[2 * i + 1] / 4;
        }
      const std::size_t j = std::size_t(y) * 32 + x;
      if (!known) continue;
      ASSERT_TRUE(h.valid[j]) << x << "," << y;
      EXPECT_NEAR(h.uv[2 * j], u / 2, 1e-4) << x << "," << y;
      EXPECT_NEAR(h.uv[2 * j + 1], v / 2, 1e-4) << x << "," << y;
      compared += std::abs(u) > 0.5;
    }
  EXPECT_GT(compared, 10);  // the ball moves: not a field of zeros
  test::expect_error([&] { load_training_set(scene, io::FrameSelection::kEven, {}, 0.5); },
                     {"--downscale", "0.5"});
}

}  // namespace
}  // namespace retimegs::train
