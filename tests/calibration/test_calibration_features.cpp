// The features a recovered calibration places the cameras by (ingest/calibration_features.hpp):
// what stands still and what moves, matched only within the same instant.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "ingest/calibration_features.hpp"
#include "retimegs/core/error.hpp"

namespace retimegs::ingest::detail {
namespace {

constexpr int kWidth = 192, kHeight = 128, kInstants = 5;
constexpr int kSquare = 36, kStep = 30;  // the moving square's side and its move per instant
constexpr int kShift = 6;                // camera b sees everything this far right of camera a

// Smooth random texture around `mean`: blobs a few pixels wide, which SIFT finds.
std::vector<float> texture(int w, int h, float mean, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0, 1);
  std::vector<float> noise(std::size_t(w) * h), out(noise.size(), 0);
  for (float& v : noise) v = u(rng);
  constexpr int r = 2;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float sum = 0;
      int n = 0;
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx)
          if (y + dy >= 0 && y + dy < h && x + dx >= 0 && x + dx < w)
            sum += noise[std::size_t(y + dy) * w + x + dx], ++n;
      out[std::size_t(y) * w + x] = mean + 2 * (sum / n - 0.5f);
    }
  return out;
}

int square_left(int k) {
  return 20 + kStep * k;
}
constexpr int kSquareTop = 46;

// Camera a's frame at instant k is a static background with a textured square at
// square_left(k), brighter than the background throughout (so that all of it differs from the
// median); camera b's is the same seen kShift pixels further right.
Image frame(int k, int shift) {
  static const std::vector<float> background = texture(kWidth + kShift, kHeight, 0.25f, 1);
  static const std::vector<float> square = texture(kSquare, kSquare, 0.75f, 2);
  Image out(kWidth, kHeight, 1);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const int sx = x - shift;  // scene column
      const int qx = sx - square_left(k), qy = y - kSquareTop;
      out.at(y, x) = qx >= 0 && qx < kSquare && qy >= 0 && qy < kSquare
                         ? square[std::size_t(qy) * kSquare + qx]
                         : background[std::size_t(y) * (kWidth + kShift) + sx + kShift];
    }
  return out;
}

CameraFeatures features_of(int shift) {
  return camera_features(
      kInstants, [&](int k) { return frame(k, shift); }, 2000);
}

// Moving features lie on the square of their own instant (grown by the mask's dilation and a
// SIFT neighbourhood); there are static ones too, and moving matches pair the same instant: the
// square is the same at every instant, so a match between instants would be off by kStep.
TEST(CalibrationFeatures, MovingFeaturesMatchOnlyWithinTheirInstant) {
  const CameraFeatures a = features_of(0), b = features_of(kShift);
  ASSERT_GT(a.moving, 20);
  ASSERT_GT(int(a.features.size()) - a.moving, 20);
  constexpr float kMargin = 12;
  for (const Feature& f : a.features) {
    if (f.instant == kStaticInstant) continue;
    const float left = float(square_left(f.instant));
    EXPECT_GT(f.x, left - kMargin) << "instant " << f.instant;
    EXPECT_LT(f.x, left + kSquare + kMargin) << "instant " << f.instant;
    EXPECT_GT(f.y, kSquareTop - kMargin);
    EXPECT_LT(f.y, kSquareTop + kSquare + kMargin);
  }
  const Matches moving = match_features(a, b, true, false);
  ASSERT_GT(moving.size(), 20u);
  for (const auto& [i, j] : moving) {
    const Feature &fa = a.features[i], &fb = b.features[j];
    EXPECT_NE(fa.instant, kStaticInstant);
    EXPECT_EQ(fa.instant, fb.instant);
    // Sub-pixel refinement differs near the edges; a match between instants is off by kStep.
    EXPECT_NEAR(fb.x - fa.x, kShift, 2.0);
    EXPECT_NEAR(fb.y, fa.y, 2.0);
  }
  const Matches still = match_features(a, b, false, true);
  ASSERT_GT(still.size(), 20u);
  for (const auto& [i, j] : still) {
    EXPECT_EQ(a.features[i].instant, kStaticInstant);
    EXPECT_EQ(b.features[j].instant, kStaticInstant);
  }
}

TEST(CalibrationFeatures, FewerThanThreeInstantsAreRefused) {
  EXPECT_THROW(camera_features(
                   2, [](int) { return Image(8, 8, 1); }, 10),
               Error);
}

// A point's two projections lie on each other's epipolar line; one moved 3 px across the line is
// 3 px from it.
TEST(CalibrationFeatures, EpipolarDistanceOfTwoPinholeCameras) {
  Eigen::Matrix3d k;
  k << 400, 0, 160, 0, 400, 120, 0, 0, 1;
  Eigen::Matrix4d pose_a = Eigen::Matrix4d::Identity(), pose_b = Eigen::Matrix4d::Identity();
  pose_b.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).matrix();
  pose_b.topRightCorner<3, 1>() = Eigen::Vector3d(-1, 0.1, 0.2);
  const Eigen::Matrix3d f = fundamental_matrix(k, pose_a, k, pose_b);
  auto project = [&](const Eigen::Matrix4d& pose, const Eigen::Vector3d& x) {
    const Eigen::Vector3d p = k * (pose * x.homogeneous()).head<3>();
    return Feature{float(p.x() / p.z()), float(p.y() / p.z())};
  };
  const Eigen::Vector3d x(0.3, -0.2, 5);
  const Feature fa = project(pose_a, x), fb = project(pose_b, x);
  EXPECT_NEAR(epipolar_distance(f, fa, fb), 0, 1e-3);
  const Eigen::Vector3d line = f * Eigen::Vector3d(fa.x, fa.y, 1);
  const Eigen::Vector2d normal = line.head<2>().normalized();
  const Feature moved{fb.x + float(3 * normal.x()), fb.y + float(3 * normal.y())};
  EXPECT_NEAR(epipolar_distance(f, fa, moved), 3, 1e-3);
}

// A refinement keeps a placed pair's matches within the tolerance of their epipolar lines, and
// none of a camera the previous placement has not: its moving matches were in the guide already,
// and a registration from them alone was wrong on the Panoptic clip.
TEST(CalibrationFeatures, RefinementsKeepAgreeingMatchesOfPlacedCamerasOnly) {
  Placement a, b;
  a.k << 400, 0, 160, 0, 400, 120, 0, 0, 1;
  b.k = a.k;
  a.world_to_camera = b.world_to_camera = Eigen::Matrix4d::Identity();
  b.world_to_camera.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).matrix();
  b.world_to_camera.topRightCorner<3, 1>() = Eigen::Vector3d(-1, 0.1, 0.2);
  a.larger_side = b.larger_side = 320;
  auto project = [](const Placement& p, const Eigen::Vector3d& x) {
    const Eigen::Vector3d q = p.k * (p.world_to_camera * x.homogeneous()).head<3>();
    return Feature{float(q.x() / q.z()), float(q.y() / q.z())};
  };
  // Feature 0 of each placed camera is one point's projection; feature 1 of camera b lies 6 px
  // across the epipolar line of camera a's feature 1.
  std::vector<CameraFeatures> features(3);
  const Eigen::Vector3d x(0.3, -0.2, 5), y(-0.4, 0.1, 6);
  features[0].features = {project(a, x), project(a, y)};
  const Feature by = project(b, y);
  const Eigen::Vector3d line =
      fundamental_matrix(a.k, a.world_to_camera, b.k, b.world_to_camera) *
      Eigen::Vector3d(features[0].features[1].x, features[0].features[1].y, 1);
  const Eigen::Vector2d normal = line.head<2>().normalized();
  features[1].features = {project(b, x),
                          Feature{by.x + float(6 * normal.x()), by.y + float(6 * normal.y())}};
  features[2].features = {Feature{50, 60}, Feature{70, 80}};
  // Pairs (0, 1), (0, 2), (1, 2); camera 2 is not placed.
  const std::vector<Matches> candidates = {{{0, 0}, {1, 1}}, {{0, 0}, {1, 1}}, {{0, 0}, {1, 1}}};
  const std::vector<Matches> kept =
      agreeing_matches({a, b, std::nullopt}, features, candidates, 4.0 / 320);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_EQ(kept[0], (Matches{{0, 0}}));
  EXPECT_TRUE(kept[1].empty());
  EXPECT_TRUE(kept[2].empty());
  // 6 px is within a tolerance of 8 px.
  EXPECT_EQ(agreeing_matches({a, b, std::nullopt}, features, candidates, 8.0 / 320)[0].size(), 2u);
}

}  // namespace
}  // namespace retimegs::ingest::detail
