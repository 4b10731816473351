// Reconstructions of one rig combined (ingest/calibration.hpp: combine_reconstructions): each
// camera keeps the placement nearest the other reconstructions', in the first's frame.
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "ingest/calibration.hpp"
#include "retimegs/io/colmap.hpp"

namespace retimegs::ingest::detail {
namespace {

constexpr int kCameras = 12;
constexpr double kRadius = 4, kFocal = 500;

// Camera c of a ring of radius kRadius at two heights, looking at the middle (world to camera).
Eigen::Matrix4d ring_camera(int c) {
  const double a = 2 * M_PI * c / kCameras;
  const Eigen::Vector3d centre(kRadius * std::cos(a), c % 2 - 0.5, kRadius * std::sin(a));
  const Eigen::Vector3d z = -centre.normalized();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
  Eigen::Matrix3d rotation;
  rotation << x.transpose(), z.cross(x).transpose(), z.transpose();
  Eigen::Matrix4d w2c = Eigen::Matrix4d::Identity();
  w2c.topLeftCorner<3, 3>() = rotation;
  w2c.topRightCorner<3, 1>() = -rotation * centre;
  return w2c;
}

Eigen::Vector3d centre_of(const Eigen::Matrix4d& w2c) {
  return -w2c.topLeftCorner<3, 3>().transpose() * w2c.topRightCorner<3, 1>();
}

struct Moved {
  int camera;
  double along_view;  // the centre moved along the viewing direction by this share of kRadius
  double focal;       // and its focal length scaled by this
};

// The ring as a reconstruction would place it: in the frame x' = scale * rotation * x + shift,
// each camera of its own (SIMPLE_RADIAL) with ids from `first_id`, in the order of `order`,
// `moved` cameras placed apart, the `absent` one left out (-1: none).
io::ColmapModel reconstruction(double scale, const Eigen::Matrix3d& rotation,
                               const Eigen::Vector3d& shift, const std::vector<int>& order,
                               std::uint32_t first_id, const std::vector<Moved>& moved,
                               int absent = -1) {
  io::ColmapModel model;
  std::uint32_t id = first_id;
  for (int c : order) {
    if (c == absent) continue;
    Eigen::Matrix4d w2c = ring_camera(c);
    double focal = kFocal + c;
    for (const Moved& m : moved)
      if (m.camera == c) {
        w2c.topRightCorner<3, 1>() -= Eigen::Vector3d::UnitZ() * m.along_view * kRadius;
        focal *= m.focal;
      }
    const Eigen::Matrix3d r = w2c.topLeftCorner<3, 3>() * rotation.transpose();
    const Eigen::Vector3d centre = scale * rotation * centre_of(w2c) + shift;
    Eigen::Matrix4d placed = Eigen::Matrix4d::Identity();
    placed.topLeftCorner<3, 3>() = r;
    placed.topRightCorner<3, 1>() = -r * centre;
    model.cameras.push_back({id, "SIMPLE_RADIAL", 640, 360, {focal, 320 + c, 180 - c, 0.01 * c}});
    model.images.push_back(
        io::ColmapImage::from_world_to_camera(id, id, std::to_string(c) + ".png", placed));
    ++id;
  }
  return model;
}

std::vector<int> in_order(bool reversed) {
  std::vector<int> order;
  for (int c = 0; c < kCameras; ++c) order.push_back(reversed ? kCameras - 1 - c : c);
  return order;
}

// The first places camera 3 10 % of the ring's radius forward with a focal length 5 % short (the
// trade a weakly seen camera makes), the second camera 7 so and lacks camera 11, the third agrees
// with the ring; the second and third in other frames, orders and ids. Combined in the first's
// frame (the identity here), every camera is where the ring has it, with the intrinsics of a
// reconstruction that placed it so; the spread of cameras 3 and 7 is about the 10 % one moved them.
TEST(CombineReconstructions, EachCameraTakesThePlacementNearestTheOthers) {
  const Eigen::Matrix3d turn_b =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Matrix3d turn_c =
      Eigen::AngleAxisd(-2.1, Eigen::Vector3d(-3, 1, 1).normalized()).toRotationMatrix();
  const std::vector<io::ColmapModel> models = {
      reconstruction(1, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), in_order(false), 1,
                     {{3, 0.1, 0.95}}),
      reconstruction(0.3, turn_b, {5, -2, 1}, in_order(false), 1, {{7, 0.1, 0.95}}, 11),
      reconstruction(2.5, turn_c, {-1, 0, 8}, in_order(true), 40, {})};
  const CombinedReconstructions combined = combine_reconstructions(models);

  ASSERT_EQ(combined.model.images.size(), std::size_t(kCameras));
  ASSERT_EQ(combined.model.cameras.size(), std::size_t(kCameras));
  EXPECT_TRUE(combined.model.points.empty());
  ASSERT_EQ(combined.spread.size(), std::size_t(kCameras));
  for (int c = 0; c < kCameras; ++c) {
    const io::ColmapImage& image = combined.model.images[c];
    EXPECT_EQ(image.id, models[0].images[c].id);
    EXPECT_EQ(image.name, models[0].images[c].name);
    EXPECT_EQ(image.camera_id, models[0].images[c].camera_id);
    // The similarities come from every shared camera, the moved ones included: within 2 %.
    const Eigen::Matrix4d truth = ring_camera(c), w2c = image.world_to_camera();
    EXPECT_LT((centre_of(w2c) - centre_of(truth)).norm(), 0.02 * kRadius) << image.name;
    EXPECT_LT((w2c.topLeftCorner<3, 3>() - truth.topLeftCorner<3, 3>()).norm(), 0.02) << image.name;
    const io::ColmapCamera& camera = combined.model.camera(image.camera_id);
    EXPECT_EQ(camera.params, (std::vector<double>{kFocal + c, 320.0 + c, 180.0 - c, 0.01 * c}))
        << image.name;
    EXPECT_EQ(camera.id, image.camera_id);
    // The 10 % of the radius one reconstruction moved it (less what the similarity, fit to every
    // camera, takes up), over the ring's extent (its centres' largest distance from the middle).
    if (c == 3 || c == 7)
      EXPECT_NEAR(combined.spread[c], 0.1 * kRadius / std::hypot(kRadius, 0.5), 0.025);
    else
      EXPECT_LT(combined.spread[c], 0.02) << image.name;
  }
}

// A reconstruction that shares fewer than three cameras with the first cannot be aligned to it
// and is left out, however it places them; one reconstruction alone is itself.
TEST(CombineReconstructions, OneSharingFewerThanThreeCamerasIsLeftOut) {
  const io::ColmapModel first =
      reconstruction(1, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), in_order(false), 1,
                     {{3, 0.1, 0.95}});
  const io::ColmapModel apart =
      reconstruction(1, Eigen::Matrix3d::Identity(), {9, 9, 9}, {3, 5}, 1, {});
  const CombinedReconstructions alone = combine_reconstructions({first});
  const CombinedReconstructions with_apart = combine_reconstructions({first, apart, apart});
  for (const CombinedReconstructions& combined : {alone, with_apart}) {
    ASSERT_EQ(combined.model.images.size(), first.images.size());
    for (std::size_t i = 0; i < first.images.size(); ++i) {
      EXPECT_TRUE(combined.model.images[i].world_to_camera().isApprox(
          first.images[i].world_to_camera(), 1e-12));
      EXPECT_EQ(combined.model.cameras[i].params, first.cameras[i].params);
      EXPECT_EQ(combined.spread[i], 0);
    }
  }
}

}  // namespace
}  // namespace retimegs::ingest::detail
