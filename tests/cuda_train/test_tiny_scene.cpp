// The tiny in-memory training set (tiny_scene.hpp) that the training step's device tests share,
// checked on the CPU step: it needs no GPU, so it runs in every build with CUDA, the lean one
// included.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cuda_train/tiny_scene.hpp"
#include "retimegs/train/cpu_step.hpp"

namespace retimegs::train {
namespace {

// Its images show the ball (not a blank frame) and its points seed the initialisation.
TEST(TinyScene, ImagesShowTheBallAndPointsSeedTheModel) {
  const TrainingSet set = test::tiny_training_set();
  ASSERT_EQ(set.cameras.size(), 2u);
  ASSERT_EQ(set.frames.size(), 3u);
  for (const auto& per_camera : set.images)
    for (const PackedImage& image : per_camera) {
      const int lit = int(std::count_if(image.data.begin(), image.data.end(),
                                        [](std::uint16_t code) { return code > 0; }));
      EXPECT_GT(lit, int(image.data.size() / 20));
      EXPECT_LT(lit, int(image.data.size() / 2));
    }
  TrainConfig config;
  config.iters = 20;
  CpuStep step(set, config);
  const std::string note = step.initialize();
  EXPECT_EQ(note.find("random"), std::string::npos) << note;
  EXPECT_GT(step.primitive_count(), 0u);
}

// 20 steps over the 6 views in a fixed order: the second visit of every view has a lower loss
// than the first (the loss of the views' first visits summed against their last visits').
TEST(TinyScene, CpuStepLossFallsOverTwentySteps) {
  const TrainingSet set = test::tiny_training_set();
  TrainConfig config;
  config.iters = 20;
  CpuStep step(set, config);
  step.initialize();
  const int cameras = int(set.cameras.size()), frames = int(set.frames.size());
  const int views = cameras * frames;
  std::vector<double> loss;
  for (int s = 0; s < 20; ++s) {
    const StepStats stats = step.step_view(s % cameras, (s / cameras) % frames);
    ASSERT_TRUE(std::isfinite(stats.loss)) << "step " << s;
    loss.push_back(stats.loss);
  }
  EXPECT_EQ(step.iteration(), 20);
  const double first = std::accumulate(loss.begin(), loss.begin() + views, 0.0);
  const double last = std::accumulate(loss.end() - views, loss.end(), 0.0);
  EXPECT_LT(last, 0.8 * first) << "first visits " << first << ", last visits " << last;
}

}  // namespace
}  // namespace retimegs::train
