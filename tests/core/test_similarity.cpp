#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "retimegs/core/error.hpp"
#include "retimegs/core/similarity.hpp"

namespace retimegs {
namespace {

// Cameras on a ring looking at the origin, at two heights (not on one line).
std::vector<Camera> ring(int count) {
  std::vector<Camera> cameras;
  for (int i = 0; i < count; ++i) {
    Camera cam;
    cam.name = "c" + std::to_string(i);
    cam.width = 64, cam.height = 48;
    cam.fx = cam.fy = 60, cam.cx = 32, cam.cy = 24;
    const double a = 2 * 3.14159265358979 * i / count;
    cam.world_to_camera =
        look_at({4 * std::cos(a), i % 2 ? -1.5 : -2.2, 4 * std::sin(a)}, {0, 0, 0}, {0, -1, 0});
    cameras.push_back(cam);
  }
  return cameras;
}

Similarity known_similarity() {
  Similarity s;
  s.scale = 2.7;
  s.rotation = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.8, 0.5).normalized()).matrix();
  s.translation = {5, -3, 12};
  return s;
}

TEST(Similarity, AKnownSimilarityIsRecoveredAndRemovedExactly) {
  const std::vector<Camera> truth = ring(6);
  const Similarity s = known_similarity();
  // The truth seen in another frame: each camera mapped by the inverse similarity.
  std::vector<Eigen::Vector3d> from, to;
  std::vector<Camera> moved;
  for (const Camera& cam : truth) {
    moved.push_back(transformed(cam, s.inverse()));
    from.push_back(moved.back().center());
    to.push_back(cam.center());
  }
  // The moved cameras are rigid and see the moved world as the true ones see the world.
  const Eigen::Vector3d x(0.3, -0.4, 0.2);
  EXPECT_LT((moved[2].project(s.inverse().apply(x)) - truth[2].project(x)).norm(), 1e-9);
  EXPECT_GT(rotation_angle_degrees(moved[2], truth[2]), 10.0);

  const Similarity fit = fit_similarity(from, to);
  EXPECT_NEAR(fit.scale, s.scale, 1e-9);
  EXPECT_LT((fit.rotation - s.rotation).norm(), 1e-9);
  EXPECT_LT((fit.translation - s.translation).norm(), 1e-9);
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const Camera aligned = transformed(moved[i], fit);
    EXPECT_LT((aligned.center() - truth[i].center()).norm(), 1e-9);
    EXPECT_LT(rotation_angle_degrees(aligned, truth[i]), 1e-7);
    EXPECT_LT((aligned.world_to_camera - truth[i].world_to_camera).norm(), 1e-9);
  }
}

TEST(Similarity, RotationAngleIsTheAngleBetweenOrientations) {
  Camera a = ring(1)[0], b = a;
  const double degrees = 0.37;
  b.world_to_camera.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(degrees * 3.14159265358979323846 / 180,
                        Eigen::Vector3d(1, 2, 3).normalized())
          .matrix() *
      a.rotation();
  EXPECT_NEAR(rotation_angle_degrees(a, b), degrees, 1e-10);
  EXPECT_NEAR(rotation_angle_degrees(b, a), degrees, 1e-10);
  EXPECT_LT(rotation_angle_degrees(a, a), 1e-12);
}

TEST(Similarity, UndeterminedSimilaritiesAreRefused) {
  const std::vector<Eigen::Vector3d> two = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_THROW(fit_similarity(two, two), Error);
  const std::vector<Eigen::Vector3d> line = {{0, 0, 0}, {1, 1, 0}, {2, 2, 0}, {5, 5, 0}};
  try {
    fit_similarity(line, line);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("line"), std::string::npos) << e.what();
  }
  const std::vector<Eigen::Vector3d> three = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_THROW(fit_similarity(three, two), Error);
  EXPECT_NO_THROW(fit_similarity(three, three));
}

}  // namespace
}  // namespace retimegs
