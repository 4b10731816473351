// The camera pose correction (model/camera_pose.hpp): its gradient through the rasteriser against
// central finite differences of the double-precision reference render, and the float sums
// against the double ones.
#include <gtest/gtest.h>

#include <cmath>

#include "../render/render_test_util.hpp"
#include "retimegs/model/camera_pose.hpp"
#include "retimegs/render/reference.hpp"

namespace retimegs::test {
namespace {

double dot(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

// One tile (16 x 12), seen by a camera away from the world origin so that every term of the
// gradient (the camera's own translation included) is exercised.
struct PoseScene {
  Camera camera = test_camera(16, 12);
  GaussiansT<double> g;
  std::vector<double> background = {0.3, 0.6, 0.1};
  std::vector<double> v_image, v_alpha, v_depth;

  explicit PoseScene(unsigned seed) {
    camera.world_to_camera = look_at({1.5, -0.4, -2.0}, {0.3, 0.2, 1.5}, {0, -1, 0});
    g = random_gaussians<double>(camera, 8, 3, seed, /*max_sigma_px=*/3.0, /*max_opacity=*/0.9);
    const std::size_t pixels = std::size_t(camera.width) * camera.height;
    v_image = random_values(pixels * 3, seed + 100);
    v_alpha = random_values(pixels, seed + 200);
    v_depth = random_values(pixels, seed + 300);
  }
  double loss(const model::CameraPose& pose) const {
    const render::ReferenceOutput out = render::reference_forward(
        g, model::corrected(camera, pose), background.data(), smooth_options());
    return dot(out.image, v_image) + dot(out.alpha, v_alpha) + dot(out.depth, v_depth);
  }
  GaussianGradsT<double> grads(const model::CameraPose& pose) const {
    return render::reference_backward(g, model::corrected(camera, pose), background.data(),
                                      smooth_options(), v_image.data(), v_alpha.data(),
                                      v_depth.data());
  }
};

model::CameraPose some_pose() {
  model::CameraPose pose;
  pose.rotation = {0.021, -0.013, 0.017};    // about 1.6 degrees
  pose.translation = {0.015, -0.02, 0.012};  // about 1 % of the scene's depth
  return pose;
}

TEST(CameraPose, GradientMatchesFiniteDifferences) {
  for (const unsigned seed : {1u, 2u, 3u}) {
    const PoseScene scene(seed);
    for (const model::CameraPose& pose : {model::CameraPose{}, some_pose()}) {
      const std::array<double, 6> analytic = model::camera_pose_vjp(
          scene.g, scene.grads(pose), model::corrected(scene.camera, pose), pose);
      constexpr double kStep = 1e-6;
      std::array<double, 6> numeric{};
      double scale = 0;
      for (int k = 0; k < 6; ++k) {
        model::CameraPose plus = pose, minus = pose;
        (k < 3 ? plus.rotation[k] : plus.translation[k - 3]) += kStep;
        (k < 3 ? minus.rotation[k] : minus.translation[k - 3]) -= kStep;
        numeric[k] = (scene.loss(plus) - scene.loss(minus)) / (2 * kStep);
        scale = std::max(scale, std::abs(numeric[k]));
      }
      ASSERT_GT(scale, 1e-2) << "the scene does not exercise the camera's gradient";
      for (int k = 0; k < 6; ++k)
        EXPECT_NEAR(analytic[k], numeric[k], 1e-6 * scale + 1e-5 * std::abs(numeric[k]))
            << "seed " << seed << ", parameter " << k << (pose.is_identity() ? " at 0" : "");
    }
  }
}

TEST(CameraPose, FloatSumsMatchDouble) {
  const PoseScene scene(4);
  const model::CameraPose pose = some_pose();
  const Camera seen = model::corrected(scene.camera, pose);
  const GaussianGradsT<double> grads = scene.grads(pose);
  GaussianGradsT<float> grads_f(grads.size(), grads.channels);
  for (std::size_t k = 0; k < grads.v_means.size(); ++k)
    grads_f.v_means[k] = float(grads.v_means[k]);
  for (std::size_t k = 0; k < grads.v_quats.size(); ++k)
    grads_f.v_quats[k] = float(grads.v_quats[k]);
  const auto exact = model::camera_pose_vjp(scene.g, grads, seen, pose);
  const auto fast = model::camera_pose_vjp(cast_gaussians<float>(scene.g), grads_f, seen, pose);
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(fast[k], exact[k], 1e-5 * max_abs(exact)) << k;
}

TEST(CameraPose, CorrectionActsInTheCameraFrame) {
  Camera camera = test_camera(64, 48);
  camera.world_to_camera = look_at({2, 1, -3}, {0, 0, 0}, {0, -1, 0});
  model::CameraPose pose;
  EXPECT_EQ(model::corrected(camera, pose).world_to_camera, camera.world_to_camera);
  // A shift along the camera's own z axis moves a point on the axis by exactly that depth.
  pose.translation = {0, 0, 0.25};
  const Eigen::Vector3d x = camera.cam_to_world({0, 0, 2});
  EXPECT_NEAR(model::corrected(camera, pose).world_to_cam(x).z(), 2.25, 1e-12);
  // A turn about the camera's own y axis keeps its centre and turns its view by that angle.
  pose = {};
  pose.rotation = {0, 0.01, 0};
  const Camera turned = model::corrected(camera, pose);
  EXPECT_LT((turned.center() - camera.center()).norm(), 1e-12);
  const Eigen::Vector3d a = camera.ray_direction({camera.cx, camera.cy});
  const Eigen::Vector3d b = turned.ray_direction({turned.cx, turned.cy});
  EXPECT_NEAR(std::acos(a.dot(b)), 0.01, 1e-9);
}

}  // namespace
}  // namespace retimegs::test
