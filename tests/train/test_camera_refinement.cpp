// Camera refinement in training (model/camera_pose.hpp, train config refine_cameras): a camera
// whose calibration is off by a known motion is corrected toward its true pose; the default
// follows the scene's calibration source; the run records the corrections.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "retimegs/eval/protocol.hpp"
#include "retimegs/io/perturb_calibration.hpp"
#include "retimegs/model/camera_pose.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/playback/render_model.hpp"
#include "retimegs/train/cpu_step.hpp"
#include "retimegs/train/step_state.hpp"
#include "retimegs/train_run/load_training_set.hpp"
#include "retimegs/train_run/run.hpp"
#include "synth_scene.hpp"
#include "test_util.hpp"

namespace retimegs::train {
namespace {
namespace fs = std::filesystem;

// Held-out PSNR (frames 1 and 3 of every camera, in the masks) of a model trained on `set`, each
// camera drawn as the model saw it (model::seen_camera: through its correction, if refined).
double held_out_psnr(const io::Scene& scene, const TrainingSet& set, TrainConfig config) {
  CpuStep trainer(set, config);
  trainer.initialize();
  while (trainer.iteration() < config.iters) trainer.step();
  const model::Model& m = trainer.model();
  eval::EvalOptions options;
  options.frames = {1, 3};
  for (int c = 0; c < int(scene.cameras.size()); ++c) options.cameras.push_back(c);
  options.progress = false;
  const float black[3] = {0, 0, 0};
  return eval::evaluate_views(
             scene,
             [&](int c, int k) {
               return playback::render_model(m, model::seen_camera(m, set.scene.cameras[c]), k,
                                             black);
             },
             options)
      .psnr;
}

// One camera's calibration turned by 1.5° about a tilted axis and moved by 1.5 % of the extent
// (its images are the true camera's): refinement wins back most of what the error costs on
// held-out frames.
TEST(CameraRefinement, WinsBackAMiscalibratedCamera) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 4, 120, 90);
  const TrainingSet exact = load_training_set(scene, io::FrameSelection::kEven);
  constexpr int kMoved = 1;
  const Eigen::Vector3d axis =
      Eigen::Vector3d(0.3, 1.0, 0.2).normalized() * 1.5 * std::numbers::pi / 180;
  const Eigen::Vector3d shift =
      Eigen::Vector3d(1.0, -0.5, 0.3).normalized() * 0.015 * exact.scene_extent;
  model::CameraPose error;
  for (int k = 0; k < 3; ++k) error.rotation[k] = axis[k], error.translation[k] = shift[k];
  io::Scene user = scene;
  user.cameras[kMoved] = model::corrected(scene.cameras[kMoved], error);
  user.calibration = io::CalibrationSource::kUser;
  const TrainingSet perturbed = load_training_set(user, io::FrameSelection::kEven);

  TrainConfig config;
  config.iters = 500;
  config.cap = 3000;
  config.max_sh_degree = 0;
  const double truth = held_out_psnr(scene, exact, config);
  config.refine_cameras = false;
  const double ignored = held_out_psnr(scene, perturbed, config);
  config.refine_cameras = true;
  const double refined = held_out_psnr(scene, perturbed, config);
  std::printf("held-out PSNR: %.2f dB calibrated, %.2f perturbed, %.2f perturbed and refined\n",
              truth, ignored, refined);
  EXPECT_GT(refined, ignored + 0.5 * (truth - ignored));
}

TEST(CameraRefinement, DefaultFollowsTheCalibrationSource) {
  test::TempDir dir;
  io::Scene scene = minimal_scene(dir / "scene", 2, 32, 24);
  const TrainingSet lab = load_training_set(scene, io::FrameSelection::kEven);
  TrainConfig config;
  EXPECT_FALSE(refine_cameras(config, lab));
  scene.calibration = io::CalibrationSource::kUser;
  const TrainingSet user = load_training_set(scene, io::FrameSelection::kEven);
  EXPECT_TRUE(refine_cameras(config, user));
  config.refine_cameras = false;
  EXPECT_FALSE(refine_cameras(config, user));
  config.refine_cameras = true;
  EXPECT_TRUE(refine_cameras(config, lab));

  // Off: the model carries no corrections and the step draws the scene's cameras.
  config.refine_cameras = false;
  config.iters = 3;
  config.cap = 300;
  CpuStep off(lab, config);
  off.initialize();
  off.step();
  EXPECT_TRUE(off.model().camera_poses.empty());
}

// The corrections (poses, and the clock of a camera off the scene's clock) are in the model and
// their Adam state in the checkpoint: a run resumed from a checkpoint ends with the uninterrupted
// run's model, corrections included.
TEST(CameraRefinement, ResumeEqualsUninterrupted) {
  test::TempDir dir;
  io::Scene scene = minimal_scene(dir / "scene", 3, 48, 36);
  scene.clocks.resize(scene.cameras.size());
  scene.clocks[1].time_offset = 0.3;
  scene.clock_source = io::ClockSource::kEstimated;
  TrainRun run;
  run.config.iters = 30;
  run.config.cap = 1500;
  run.config.checkpoint_every = 15;
  run.config.checkpoint_keep = 0;
  run.config.refine_cameras = true;
  run.config.camera_refine_start = 0;
  run.config.clock_refine_start = 0;
  run.progress = false;
  run.out = dir / "full";
  const model::Model full = train(scene, run);
  ASSERT_EQ(full.camera_poses.size(), 3u);
  EXPECT_FALSE(full.camera_poses.begin()->second.is_identity());
  ASSERT_EQ(full.camera_clocks.size(), 1u);  // cameras 0 and 2 anchor the scene's clock
  EXPECT_NE(full.camera_clocks.begin()->second, 0.0);
  for (const char* adam : {"camera_pose_v.npy", "camera_clock_v.npy"})
    EXPECT_TRUE(fs::exists(dir / "full" / "checkpoints" / "iter_000015" / "adam" / adam)) << adam;
  fs::copy(dir / "full", dir / "resumed", fs::copy_options::recursive);
  fs::remove(dir / "resumed" / "model.rgs");
  fs::remove_all(dir / "resumed" / "checkpoints" / "iter_000030");
  run.out = dir / "resumed";
  run.resume = true;
  train(scene, run);
  EXPECT_EQ(test::read_text(dir / "full" / "model.rgs"),
            test::read_text(dir / "resumed" / "model.rgs"));
}

}  // namespace
}  // namespace retimegs::train
