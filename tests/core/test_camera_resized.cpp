// resized(): the same view at another image size, so a point lands at the same place relative to
// the image (its pixel coordinates scale with the grid).
#include <gtest/gtest.h>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/error.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {

TEST(CameraResized, PointsKeepTheirPlaceInTheImage) {
  Camera cam;
  cam.name = "c";
  cam.width = 64, cam.height = 48;
  cam.fx = 50, cam.fy = 52, cam.cx = 32.5, cam.cy = 23.75;
  cam.world_to_camera = look_at({1.0, -2.0, -4.0}, {0.1, -0.5, 0.2}, {0, -1, 0});
  const Camera big = resized(cam, 160, 120);
  EXPECT_EQ(big.width, 160);
  EXPECT_EQ(big.height, 120);
  EXPECT_EQ(big.world_to_camera, cam.world_to_camera);
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.5, -0.3, 1.0)}) {
    const Eigen::Vector2d a = cam.project(x), b = big.project(x);
    EXPECT_NEAR(b.x(), a.x() * 160 / 64, 1e-9);
    EXPECT_NEAR(b.y(), a.y() * 120 / 48, 1e-9);
  }
  // The image corners stay the corners: the field of view is kept.
  const Camera small = resized(cam, 33, 25);
  EXPECT_NEAR((0 - small.cx) / small.fx, (0 - cam.cx) / cam.fx, 1e-12);
  EXPECT_NEAR((25 - small.cy) / small.fy, (48 - cam.cy) / cam.fy, 1e-12);
  test::expect_error([&] { resized(cam, 0, 10); }, {"'c'", "0x10"});
}

}  // namespace
}  // namespace retimegs
