#include <cmath>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "retimegs/core/error.hpp"
#include "retimegs/core/similarity.hpp"
#include "retimegs/io/perturb_calibration.hpp"
#include "retimegs/io/training_views.hpp"

namespace retimegs::io {
namespace {

// Eight cameras on a ring of radius 4 looking at the origin; cam02 and cam05 are test cameras.
Scene ring_scene() {
  Scene scene;
  scene.root = "ring";
  scene.num_frames = 3;
  scene.fps = 30;
  for (int i = 0; i < 8; ++i) {
    Camera cam;
    cam.name = "cam0" + std::to_string(i);
    cam.width = 80, cam.height = 60;
    cam.fx = 70 + i, cam.fy = 72, cam.cx = 40.5, cam.cy = 29.25;
    const double a = 2 * 3.14159265358979 * i / 8;
    cam.world_to_camera =
        look_at({4 * std::cos(a), i % 2 ? -1.5 : -2.2, 4 * std::sin(a)}, {0, 0, 0}, {0, -1, 0});
    cam.split = i == 2 || i == 5 ? Split::kTest : Split::kTrain;
    scene.cameras.push_back(cam);
  }
  return scene;
}

const CalibrationPerturbation kAmount{1.0, 0.02, 0.02};

TEST(PerturbCalibration, EachTrainingCameraMovesByItsDrawnAmount) {
  const Scene truth = ring_scene();
  const Scene perturbed = perturb_calibration(truth, kAmount, 7);
  EXPECT_EQ(perturbed.calibration, CalibrationSource::kUser);
  const double extent = scene_extent(truth);
  std::set<double> angles;
  int shorter = 0, longer = 0;
  for (std::size_t c = 0; c < truth.cameras.size(); ++c) {
    const Camera &t = truth.cameras[c], &p = perturbed.cameras[c];
    ASSERT_EQ(p.name, t.name);
    EXPECT_EQ(p.width, t.width);
    EXPECT_EQ(p.cx, t.cx);
    EXPECT_EQ(p.cy, t.cy);
    if (t.split == Split::kTest) {  // exact
      EXPECT_EQ(p.world_to_camera, t.world_to_camera) << t.name;
      EXPECT_EQ(p.fx, t.fx) << t.name;
      continue;
    }
    const double angle = rotation_angle_degrees(p, t);
    EXPECT_GE(angle, kLeastFactor * kAmount.rotation_degrees - 1e-9) << t.name;
    EXPECT_LE(angle, kAmount.rotation_degrees + 1e-9) << t.name;
    angles.insert(angle);
    const double moved = (p.center() - t.center()).norm() / extent;
    EXPECT_GE(moved, kLeastFactor * kAmount.translation - 1e-12) << t.name;
    EXPECT_LE(moved, kAmount.translation + 1e-12) << t.name;
    const double focal = p.fx / t.fx - 1;
    EXPECT_NEAR(p.fy / t.fy - 1, focal, 1e-12) << t.name;  // one factor for both axes
    EXPECT_GE(std::abs(focal), kLeastFactor * kAmount.focal - 1e-12) << t.name;
    EXPECT_LE(std::abs(focal), kAmount.focal + 1e-12) << t.name;
    (focal < 0 ? shorter : longer) += 1;
    EXPECT_NO_THROW(check_rigid(p.world_to_camera, t.name, 1e-12));
  }
  EXPECT_EQ(angles.size(), 6u);  // the cameras differ
  EXPECT_GT(shorter, 0);
  EXPECT_GT(longer, 0);
}

TEST(PerturbCalibration, DrawsDependOnTheSeedAndTheCameraAlone) {
  const Scene truth = ring_scene();
  const Scene a = perturb_calibration(truth, kAmount, 7);
  const Scene again = perturb_calibration(truth, kAmount, 7);
  const Scene other = perturb_calibration(truth, kAmount, 8);
  for (std::size_t c = 0; c < truth.cameras.size(); ++c) {
    EXPECT_EQ(a.cameras[c].world_to_camera, again.cameras[c].world_to_camera);
    if (truth.cameras[c].split == Split::kTrain) {
      EXPECT_NE(a.cameras[c].world_to_camera, other.cameras[c].world_to_camera);
    }
  }
  // A subset of the rig turns each of its cameras and scales its focal length as the whole rig
  // does (the translation scales with the subset's extent).
  Scene subset = truth;
  subset.cameras.erase(subset.cameras.begin() + 3);
  const Scene s = perturb_calibration(subset, kAmount, 7);
  EXPECT_EQ(s.cameras[3].name, "cam04");
  EXPECT_NEAR(rotation_angle_degrees(s.cameras[3], truth.cameras[4]),
              rotation_angle_degrees(a.cameras[4], truth.cameras[4]), 1e-12);
  EXPECT_EQ(s.cameras[3].fx, a.cameras[4].fx);
  // Zero amounts leave every camera as it was.
  const Scene none = perturb_calibration(truth, {}, 7);
  for (std::size_t c = 0; c < truth.cameras.size(); ++c) {
    EXPECT_LT((none.cameras[c].world_to_camera - truth.cameras[c].world_to_camera).norm(), 1e-12);
    EXPECT_EQ(none.cameras[c].fx, truth.cameras[c].fx);
  }
}

TEST(CalibrationErrors, ASimilarityOfTheEstimateChangesNothing) {
  const Scene truth = ring_scene();
  const Scene perturbed = perturb_calibration(truth, kAmount, 3);
  const CalibrationErrors direct = calibration_errors(truth, perturbed.cameras);
  ASSERT_EQ(direct.cameras.size(), 6u);
  EXPECT_GT(direct.mean_rotation_degrees, 0.2);
  EXPECT_GT(direct.mean_centre, 0.002);
  EXPECT_GT(direct.mean_focal, 0.01 - 1e-12);

  Similarity s;
  s.scale = 0.35;
  s.rotation = Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, 1, -2).normalized()).matrix();
  s.translation = {-7, 2, 0.5};
  std::vector<Camera> elsewhere;
  for (const Camera& cam : perturbed.cameras) elsewhere.push_back(transformed(cam, s));
  const CalibrationErrors moved = calibration_errors(truth, elsewhere);
  for (std::size_t i = 0; i < direct.cameras.size(); ++i) {
    EXPECT_EQ(moved.cameras[i].name, direct.cameras[i].name);
    EXPECT_NEAR(moved.cameras[i].rotation_degrees, direct.cameras[i].rotation_degrees, 1e-8);
    EXPECT_NEAR(moved.cameras[i].centre, direct.cameras[i].centre, 1e-10);
    EXPECT_NEAR(moved.cameras[i].focal, direct.cameras[i].focal, 1e-12);
  }
  EXPECT_NEAR(moved.alignment.scale, direct.alignment.scale / s.scale, 1e-9);

  // The truth in another frame has no error; the test cameras are not compared.
  std::vector<Camera> truth_elsewhere;
  for (const Camera& cam : truth.cameras)
    if (cam.split == Split::kTrain) truth_elsewhere.push_back(transformed(cam, s));
  const CalibrationErrors none = calibration_errors(truth, truth_elsewhere);
  EXPECT_LT(none.mean_rotation_degrees, 1e-7);
  EXPECT_LT(none.mean_centre, 1e-10);
  EXPECT_EQ(none.mean_focal, 0.0);
}

TEST(CalibrationErrors, MissingCamerasAndTooFewAreNamed) {
  const Scene truth = ring_scene();
  std::vector<Camera> estimated = truth.cameras;
  estimated.erase(estimated.begin() + 4);
  try {
    calibration_errors(truth, estimated);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'cam04'"), std::string::npos) << e.what();
  }
  Scene two = truth;
  two.cameras.resize(3);  // cam00, cam01 train, cam02 test
  try {
    calibration_errors(two, two.cameras);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("2 training cameras"), std::string::npos) << e.what();
  }
}

TEST(PerturbCalibration, AmountsAreParsedAndChecked) {
  const CalibrationPerturbation a = parse_calibration_perturbation("1,0.02,0.015", "--perturb");
  EXPECT_EQ(a.rotation_degrees, 1.0);
  EXPECT_EQ(a.translation, 0.02);
  EXPECT_EQ(a.focal, 0.015);
  for (const std::string bad :
       {"1,0.02", "1,0.02,0.02,4", "a,0,0", "1,,0", "", "-1,0,0", "1,2,0", "1,0,0.5", "nan,0,0"}) {
    try {
      parse_calibration_perturbation(bad, "--perturb");
      ADD_FAILURE() << "no error for '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("--perturb"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace retimegs::io
