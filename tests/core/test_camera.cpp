#include <random>

#include <gtest/gtest.h>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/error.hpp"

namespace retimegs {
namespace {

Camera test_camera() {
  Camera cam;
  cam.name = "c";
  cam.width = 64, cam.height = 48;
  cam.fx = 50, cam.fy = 52, cam.cx = 32.5, cam.cy = 23.75;
  cam.world_to_camera = look_at({1.0, -2.0, -4.0}, {0.1, -0.5, 0.2}, {0, -1, 0});
  return cam;
}

TEST(Camera, ProjectUnprojectRoundTrip) {
  const Camera cam = test_camera();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uv(0, 64), depth(0.5, 20);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector2d pixel(uv(rng), uv(rng) * 0.75);
    const double z = depth(rng);
    const Eigen::Vector3d world = cam.unproject(pixel, z);
    EXPECT_NEAR(cam.world_to_cam(world).z(), z, 1e-9);
    EXPECT_LT((cam.project(world) - pixel).norm(), 1e-9);
    // The ray through the pixel passes through the point.
    const Eigen::Vector3d d = cam.ray_direction(pixel);
    const Eigen::Vector3d to_point = (world - cam.center()).normalized();
    EXPECT_GT(d.dot(to_point), 1 - 1e-12);
  }
}

TEST(Camera, PrincipalPointIsImageCentreConvention) {
  // A point on the optical axis lands on (cx, cy); with cx = W/2 that is the boundary between the
  // two central pixel columns (pixel centres at +0.5).
  Camera cam = test_camera();
  cam.world_to_camera.setIdentity();
  const Eigen::Vector2d p = cam.project({0, 0, 3});
  EXPECT_DOUBLE_EQ(p.x(), 32.5);
  EXPECT_DOUBLE_EQ(p.y(), 23.75);
  EXPECT_TRUE(cam.in_image({0.0, 0.0}));
  EXPECT_FALSE(cam.in_image({64.0, 10.0}));
}

TEST(Camera, LookAtIsRigidAndLooksAtTarget) {
  const Eigen::Vector3d eye(3, -1, 2), target(0, -1, 0), up(0, -1, 0);
  const Eigen::Matrix4d m = look_at(eye, target, up);
  EXPECT_NO_THROW(check_rigid(m, "look_at"));
  Camera cam = test_camera();
  cam.world_to_camera = m;
  EXPECT_LT((cam.center() - eye).norm(), 1e-12);
  const Eigen::Vector3d t_cam = cam.world_to_cam(target);
  EXPECT_NEAR(t_cam.x(), 0, 1e-12);
  EXPECT_NEAR(t_cam.y(), 0, 1e-12);
  EXPECT_GT(t_cam.z(), 0);
  // World up (-y) maps to camera -y (image up).
  EXPECT_LT(cam.rotation().row(1).dot(up), -0.9);
}

TEST(Camera, CheckRigidRejectsBadMatrices) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m(0, 0) = 2;
  EXPECT_THROW(check_rigid(m, "x"), Error);
  m.setIdentity();
  m(0, 0) = -1;  // reflection: det = -1
  try {
    check_rigid(m, "scene.json: 'cameras[0].world_to_camera'");
    FAIL() << "reflection accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cameras[0].world_to_camera"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("determinant"), std::string::npos);
  }
  m.setIdentity();
  m(1, 3) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(check_rigid(m, "x"), Error);
  m.setIdentity();
  m(3, 0) = 0.5;
  EXPECT_THROW(check_rigid(m, "x"), Error);
}

}  // namespace
}  // namespace retimegs
