// Training over a random background (train/background.hpp): the step's colour, the default by
// capture, a masked target's background, and the matte it gives (`render --alpha`).
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <set>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "retimegs/media/scene_images.hpp"
#include "retimegs/playback/model_renderer.hpp"
#include "retimegs/train/background.hpp"
#include "retimegs/train/cpu_step.hpp"
#include "retimegs/train_run/load_training_set.hpp"
#include "retimegs/train_run/run.hpp"
#include "synth_scene.hpp"
#include "test_util.hpp"

namespace retimegs::train {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

// Each channel in [0, 1), spread over it; the same colour for the same (seed, step) and another
// for every other step or seed.
TEST(StepBackground, IsAFunctionOfSeedAndStepSpreadOverTheUnitRange) {
  std::set<Rgb> colours;
  constexpr int kSteps = 1000;
  for (const std::uint64_t seed : {std::uint64_t(0), std::uint64_t(1), ~std::uint64_t(0)}) {
    Rgb low{1, 1, 1}, high{0, 0, 0}, mean{};
    for (int step = 1; step <= kSteps; ++step) {
      const Rgb rgb = step_background(seed, step);
      EXPECT_EQ(rgb, step_background(seed, step));
      for (int k = 0; k < 3; ++k) {
        ASSERT_GE(rgb[k], 0.0f);
        ASSERT_LT(rgb[k], 1.0f);
        low[k] = std::min(low[k], rgb[k]), high[k] = std::max(high[k], rgb[k]);
        mean[k] += rgb[k] / kSteps;
      }
      colours.insert(rgb);
    }
    for (int k = 0; k < 3; ++k) {
      EXPECT_LT(low[k], 0.01f) << "seed " << seed;
      EXPECT_GT(high[k], 0.99f) << "seed " << seed;
      EXPECT_NEAR(mean[k], 0.5, 0.05) << "seed " << seed;  // 4.5 standard errors
    }
  }
  EXPECT_EQ(colours.size(), 3u * kSteps);
}

// Unset, random_background is on for a capture without masks and off for one with them; set, it
// is what it says. Masks that prepare --masks estimated do not count: the loader leaves them out.
TEST(RandomBackground, DefaultsToOnWithoutMasksAndEstimatedMasksDoNotCount) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 2, 32, 24);
  TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);
  ASSERT_TRUE(set.masks[0][0]);
  TrainConfig config;
  EXPECT_FALSE(random_background(config, set));
  config.random_background = true;
  EXPECT_TRUE(random_background(config, set));

  test::write_text(scene.estimated_masks_marker(), "{}\n");
  set = load_training_set(scene, io::FrameSelection::kEven);
  for (const auto& camera : set.masks)
    for (const auto& mask : camera) EXPECT_FALSE(mask);
  config.random_background.reset();
  EXPECT_TRUE(random_background(config, set));
  config.random_background = false;
  EXPECT_FALSE(random_background(config, set));
}

// A view whose mask is all background: its target is the step's colour as the camera sees it,
// which a model that draws nothing (every opacity ~0) renders exactly over that colour. Over
// black, or without the mask, the same model misses the image.
TEST(RandomBackground, AMaskedStepReplacesTheTargetsBackgroundWithTheStepsColour) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 2, 32, 24);
  TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);
  TrainConfig config;
  config.iters = 10;
  config.cap = 500;
  CpuStep first(set, config);
  first.initialize();
  model::Primitives invisible = first.model().primitives;
  std::fill(invisible.opacity_logit.begin(), invisible.opacity_logit.end(), -40.0f);
  const auto first_step = [&](const TrainingSet& view_set, bool random) {
    TrainConfig c = config;
    c.random_background = random;
    CpuStep step(view_set, c);
    step.initialize(invisible);
    return step.step_view(0, 0);
  };
  set.masks[0][0] = Image(32, 24, 1, 0.0f);  // all background
  const StepStats matched = first_step(set, true);
  EXPECT_LT(matched.image_loss, 1e-6);
  EXPECT_TRUE(std::isinf(matched.psnr)) << matched.psnr;
  const StepStats black = first_step(set, false);
  EXPECT_GT(black.image_loss, 0.05);
  set.masks[0][0].reset();
  const StepStats unmasked = first_step(set, true);
  EXPECT_GT(unmasked.image_loss, 0.05);
  EXPECT_LT(unmasked.psnr, 20);
}

// The run settles the default into RUN/config.json (and the model's training config); a run
// resumed from a config.json written before the key existed goes on over black, as it began.
TEST(RandomBackground, TheRunRecordsItsBackgroundAndAnOlderRunResumesOverBlack) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 2, 32, 24);
  TrainRun run;
  run.config.iters = 2;
  run.config.cap = 300;
  run.config.checkpoint_every = 1;
  run.progress = false;
  run.out = dir / "masked";
  const auto recorded = [](const fs::path& config_json) {
    return json::parse(test::read_text(config_json)).at("random_background");
  };
  const model::Model masked = train(scene, run);
  EXPECT_EQ(recorded(run.out / "config.json"), false);
  EXPECT_EQ(json::parse(masked.training_config).at("random_background"), false);

  fs::remove_all(scene.root / "masks");
  run.out = dir / "unmasked";
  train(scene, run);
  EXPECT_EQ(recorded(run.out / "config.json"), true);

  json older = json::parse(test::read_text(run.out / "config.json"));
  older.erase("random_background");
  test::write_text(run.out / "config.json", older.dump(2));
  fs::remove_all(run.out / "checkpoints" / "iter_000002");
  run.resume = true;
  run.iters = 3;  // config.json is written back
  train(scene, run);
  EXPECT_EQ(recorded(run.out / "config.json"), false);
}

// Where the synthetic scene's staged ground lies: the plane y = 0 within this radius of the origin
// (synth.cpp's kGroundPointRadius, where its point clouds sample the ground densely).
constexpr double kStageRadius = 4.0;

// The alpha of `model`'s RGBA renders (render --alpha) on the opaque staged ground, at every camera
// and frame: the pixels whose ray meets it, less those its mask marks (the moving objects in front
// of it). The mean and the smallest value.
std::pair<double, double> ground_alpha(const model::Model& model, const io::Scene& scene) {
  const playback::ModelRenderer renderer(model);
  double sum = 0, least = 1;
  std::size_t count = 0;
  for (int c = 0; c < int(scene.cameras.size()); ++c) {
    const Camera& camera = scene.cameras[c];
    const Eigen::Vector3d o = camera.center();
    for (int k = 0; k < scene.num_frames; ++k) {
      const Image rgba = renderer.render_rgba(camera, k);
      const std::optional<Image> mask = media::load_mask(scene, c, k);
      for (int y = 0; y < camera.height; ++y)
        for (int x = 0; x < camera.width; ++x) {
          const std::size_t p = std::size_t(y) * camera.width + x;
          const Eigen::Vector3d d = camera.ray_direction({x + 0.5, y + 0.5});
          const double s = -o.y() / d.y();  // where the ray meets y = 0
          if (!(s > 0) || (o + s * d).norm() > kStageRadius || (mask && is_foreground(*mask, p)))
            continue;
          const double alpha = rgba.data[4 * p + 3];
          sum += alpha, least = std::min(least, alpha), ++count;
        }
    }
  }
  EXPECT_GT(count, scene.cameras.size() * scene.num_frames * 100);
  return {sum / double(count), least};
}

// The matte: a short training of the synthetic scene without masks over random backgrounds leaves
// alpha >= 0.99 on its opaque staged ground (0.995 measured); over black, the model lets the black
// show through (0.84).
TEST(RandomBackground, AlphaIsAMatteOfTheOpaqueGround) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 3, 64, 48);
  TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);
  for (auto& camera : set.masks) std::fill(camera.begin(), camera.end(), std::nullopt);
  std::array<std::pair<double, double>, 2> alpha;
  for (const bool random : {false, true}) {
    TrainConfig config;
    config.iters = 3000;  // about 12 s on one core
    config.cap = 3000;
    ASSERT_EQ(random_background(config, set), true);
    config.random_background = random;
    CpuStep step(set, config);
    step.initialize();
    while (step.iteration() < config.iters) step.step();
    step.finish();
    alpha[random] = ground_alpha(step.model(), scene);
    std::printf("random_background %d: ground alpha mean %.4f, least %.4f\n", int(random),
                alpha[random].first, alpha[random].second);
  }
  EXPECT_GE(alpha[true].first, 0.99);
  EXPECT_LT(alpha[false].first, 0.95);
}

}  // namespace
}  // namespace retimegs::train
