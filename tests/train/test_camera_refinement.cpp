// Camera refinement in training (model/camera_pose.hpp, train config refine_cameras): a camera
// whose calibration is off by a known motion is corrected toward its true pose; the default
// follows the scene's calibration source; the run records the corrections.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "retimegs/model/camera_pose.hpp"
#include "retimegs/train/cpu_step.hpp"
#include "retimegs/train/step_state.hpp"
#include "retimegs/train_run/load_training_set.hpp"
#include "synth_scene.hpp"
#include "test_util.hpp"

namespace retimegs::train {
namespace {

// The angle (degrees) between two cameras' rotations and the distance between their centres.
std::pair<double, double> pose_error(const Camera& a, const Camera& b) {
  const Eigen::AngleAxisd turn(a.rotation() * b.rotation().transpose());
  return {turn.angle() * 180 / std::numbers::pi, (a.center() - b.center()).norm()};
}

TEST(CameraRefinement, MovesAMiscalibratedCameraTowardItsTruePose) {
  test::TempDir dir;
  io::Scene scene = minimal_scene(dir / "scene", 4, 80, 60);
  const TrainingSet exact = load_training_set(scene, io::FrameSelection::kEven);
  // Camera 1's calibration turned by 0.8° about a tilted axis and moved by 1 % of the extent: its
  // images are the true camera's.
  constexpr int kMoved = 1;
  const Camera truth = scene.cameras[kMoved];
  model::CameraPose error;
  const Eigen::Vector3d axis =
      Eigen::Vector3d(0.3, 1.0, 0.2).normalized() * 0.8 * std::numbers::pi / 180;
  const Eigen::Vector3d shift =
      Eigen::Vector3d(1.0, -0.5, 0.3).normalized() * 0.01 * exact.scene_extent;
  for (int k = 0; k < 3; ++k) error.rotation[k] = axis[k], error.translation[k] = shift[k];
  scene.cameras[kMoved] = model::corrected(truth, error);
  scene.calibration = io::CalibrationSource::kUser;
  const TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);

  TrainConfig config;
  config.iters = 500;
  config.cap = 3000;
  config.max_sh_degree = 0;
  CpuStep trainer(set, config);  // refine_cameras unset: on, as the calibration is the user's
  trainer.initialize();
  while (trainer.iteration() < config.iters) trainer.step();
  const auto& poses = trainer.model().camera_poses;
  ASSERT_EQ(poses.size(), scene.cameras.size());
  const Camera refined = model::corrected(scene.cameras[kMoved], poses.at(truth.name));
  const auto [turn_before, shift_before] = pose_error(scene.cameras[kMoved], truth);
  const auto [turn_after, shift_after] = pose_error(refined, truth);
  std::printf("camera %s: %.3f° and %.4f before, %.3f° and %.4f after\n", truth.name.c_str(),
              turn_before, shift_before, turn_after, shift_after);
  EXPECT_LT(turn_after, 0.5 * turn_before);
  // The others, calibrated exactly, keep their poses within a fraction of the error.
  for (int c = 0; c < int(scene.cameras.size()); ++c) {
    if (c == kMoved) continue;
    const Camera other = model::corrected(scene.cameras[c], poses.at(scene.cameras[c].name));
    EXPECT_LT(pose_error(other, scene.cameras[c]).first, 0.5 * turn_before) << c;
  }
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

}  // namespace
}  // namespace retimegs::train
