#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/io/coverage.hpp"
#include "test_util.hpp"

namespace retimegs::io {
namespace {

// A camera at `centre` looking along +z (facing +z) or -z (facing back), f = 100, 200x200.
Camera camera(const std::string& name, const Eigen::Vector3d& centre, bool facing_back,
              Split split) {
  Camera cam;
  cam.name = name;
  cam.width = cam.height = 200;
  cam.fx = cam.fy = 100, cam.cx = cam.cy = 100;
  const Eigen::Matrix3d r = facing_back ? Eigen::Vector3d(-1, 1, -1).asDiagonal().toDenseMatrix()
                                        : Eigen::Matrix3d::Identity();
  cam.world_to_camera.topLeftCorner<3, 3>() = r;
  cam.world_to_camera.topRightCorner<3, 1>() = -r * centre;
  cam.split = split;
  return cam;
}

// Dense points (0.04 apart: one pixel of a camera 4 away) on the square x in [-4, 0],
// y in [-4, 4] at height z.
void add_plane(PointCloud& cloud, double z) {
  for (double x = -4; x <= 0; x += 0.04)
    for (double y = -4; y <= 4; y += 0.04)
      cloud.xyz.insert(cloud.xyz.end(), {float(x), float(y), float(z)});
}

// Two training cameras at z = -5 looking +z see the plane z = -1 on their left half; the plane
// z = +1 lies behind it, hidden from them. Test camera "front" stands beside them; test camera
// "back", at z = +5 looking -z, sees the hidden plane.
struct Rig {
  Scene scene;
  PointCloud points;
  Rig() {
    scene.root = "rig";
    scene.num_frames = 1;
    scene.fps = 10;
    scene.cameras = {camera("a", {0, 0, -5}, false, Split::kTrain),
                     camera("b", {0.2, 0, -5}, false, Split::kTrain),
                     camera("front", {0.1, 0, -5}, false, Split::kTest),
                     camera("back", {0, 0, 5}, true, Split::kTest)};
    add_plane(points, -1);
    add_plane(points, 1);
  }
};

TEST(Coverage, SharesOfPixelsAndOfWhatNoTrainingCameraSees) {
  const Rig rig;
  CoverageCounter counter(rig.scene);
  counter.add(rig.points, {});
  const Coverage c = counter.result();
  ASSERT_EQ(c.cameras.size(), 4u);
  // Camera a: the plane z = -1 fills columns [0, 100) of its 200 (its edge grows by the points'
  // reach of 2 px); camera b, 0.2 to the right, sees it 5 px further left.
  EXPECT_NEAR(c.cameras[0].covered, 0.5, 0.02);
  EXPECT_NEAR(c.cameras[1].covered, 0.475, 0.02);
  EXPECT_NEAR(c.training_covered, (0.5 + 0.475) / 2, 0.02);
  EXPECT_FALSE(c.masked);
  EXPECT_FALSE(c.cameras[0].unseen.has_value());
  ASSERT_TRUE(c.cameras[2].unseen && c.cameras[3].unseen);
  EXPECT_LT(*c.cameras[2].unseen, 0.02);  // beside the training cameras: what they see
  EXPECT_GT(*c.cameras[3].unseen, 0.95);  // the hidden plane
  EXPECT_NEAR(c.cameras[3].covered, 0.5, 0.02);

  const std::vector<std::string> warnings = coverage_warnings(rig.scene, c);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("test camera back"), std::string::npos) << warnings[0];
  EXPECT_NE(describe_coverage(rig.scene, c).find("front 0 %"), std::string::npos);
}

TEST(Coverage, CountsInsideMasksAndWarnsWhenLow) {
  const Rig rig;
  // Masks on the right half of the training images, where no point falls.
  Image right(200, 200, 1, 0.0f);
  for (int y = 0; y < 200; ++y)
    for (int x = 110; x < 200; ++x) right.at(y, x) = 1;
  CoverageCounter counter(rig.scene);
  counter.add(rig.points, {&right, &right, nullptr, nullptr});
  counter.add(rig.points, {&right, &right, nullptr, nullptr});  // frames add up, weighted alike
  const Coverage c = counter.result();
  EXPECT_TRUE(c.masked);
  EXPECT_LT(c.training_covered, 0.01);
  const std::vector<std::string> warnings = coverage_warnings(rig.scene, c);
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_NE(warnings[0].find("inside their masks"), std::string::npos) << warnings[0];

  Image small(100, 100, 1, 1.0f);
  test::expect_error(
      [&] {
        counter.add(rig.points, {&small, nullptr, nullptr, nullptr});
      },
      {"camera a", "100x100", "200x200"});
  Scene no_training = rig.scene;
  for (Camera& cam : no_training.cameras) cam.split = Split::kTest;
  test::expect_error([&] { CoverageCounter{no_training}; }, {"no training camera"});
}

TEST(Coverage, MeasuresAtMostThreeFramesSpreadOverTheClip) {
  EXPECT_EQ(coverage_frames(0), std::vector<std::size_t>{});
  EXPECT_EQ(coverage_frames(2), (std::vector<std::size_t>{0, 1}));
  EXPECT_EQ(coverage_frames(3), (std::vector<std::size_t>{0, 1, 2}));
  EXPECT_EQ(coverage_frames(9), (std::vector<std::size_t>{0, 4, 8}));
  EXPECT_EQ(coverage_frames(150), (std::vector<std::size_t>{0, 74, 149}));
}

}  // namespace
}  // namespace retimegs::io
