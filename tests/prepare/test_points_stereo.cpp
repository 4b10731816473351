// Dense pair stereo for `prepare --points stereo`: which pairs are matched, and the fused points
// against a synthetic scene's exact surface points.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

#include <gtest/gtest.h>
#include "points_fixtures.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/prepare/points_stereo.hpp"
#include "retimegs/synth/synth.hpp"
#include "test_util.hpp"

namespace retimegs::prepare {
namespace {
namespace fs = std::filesystem;

bool has_pair(const std::vector<StereoPair>& pairs, int a, int b) {
  return std::any_of(pairs.begin(), pairs.end(), [&](const StereoPair& p) {
    return p.left == std::min(a, b) && p.right == std::max(a, b);
  });
}

// 12 cameras on a ring, 30 degrees apart: each camera pairs with its two neighbours, never with
// the camera across the ring (optical axes 180 degrees apart) or two steps away when the
// neighbours are better.
TEST(StereoPairs, NeighboursOnARingAndNotOppositeCameras) {
  test::TempDir dir;
  const io::Scene scene =
      test::minimal_scene(dir / "scene", /*cameras=*/12, /*width=*/32, /*height=*/24);
  const std::vector<StereoPair> pairs = stereo_pairs(scene, io::training_cameras(scene));
  ASSERT_EQ(pairs.size(), 12u);
  for (int c = 0; c < 12; ++c) {
    EXPECT_TRUE(has_pair(pairs, c, (c + 1) % 12)) << c;
    EXPECT_FALSE(has_pair(pairs, c, (c + 6) % 12)) << c;
  }
  for (const StereoPair& p : pairs) {
    EXPECT_LE(p.axis_angle, kMaxStereoAxisAngle);
    EXPECT_GE(p.triangulation_angle, kMinStereoTriangulationAngle);
    EXPECT_NEAR(p.triangulation_angle, 30, 8) << p.left << " " << p.right;
  }
}

// Three cameras 120 degrees apart: no pair is usable, and stereo_points says so.
TEST(StereoPairs, ThreeCamerasAroundTheSceneHaveNone) {
  test::TempDir dir;
  const io::Scene scene =
      test::minimal_scene(dir / "scene", /*cameras=*/3, /*width=*/32, /*height=*/24);
  EXPECT_TRUE(stereo_pairs(scene, io::training_cameras(scene)).empty());
  try {
    stereo_points(scene, io::training_cameras(scene), 0);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no usable pair"), std::string::npos) << e.what();
  }
}

// The fused points of the 12-camera ring lie on the objects' surfaces (the scene has masks, so
// only foreground pixels are matched): the median distance to the nearest exact surface point is
// a small fraction of the camera distance, and few points are far off.
TEST(StereoPoints, LieOnTheSyntheticSceneSurface) {
  test::TempDir dir;
  const io::Scene scene =
      test::minimal_scene(dir / "scene", /*cameras=*/12, /*width=*/160, /*height=*/120);
  const std::vector<int> cameras = io::training_cameras(scene);
  StereoOptions options;
  options.max_points = 20000;
  const double distance = (scene.cameras[0].center()).norm();  // the ring's radius
  for (int frame : {0, 2}) {
    const io::PointCloud cloud = stereo_points(scene, cameras, frame, options);
    const io::PointCloud exact = *io::load_points(scene, frame);
    ASSERT_GT(cloud.size(), 1000u) << frame;  // measured 4666, 4758 (foreground only)
    ASSERT_LE(cloud.size(), options.max_points);
    ASSERT_EQ(cloud.rgb.size(), cloud.xyz.size());
    const test::Nearest to_exact(exact.xyz);
    std::vector<double> d(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) d[i] = to_exact.distance(&cloud.xyz[3 * i]);
    std::sort(d.begin(), d.end());
    const double median = d[d.size() / 2] / distance;
    const double far =
        double(d.end() - std::lower_bound(d.begin(), d.end(), 0.05 * distance)) / double(d.size());
    std::printf(
        "  frame %d: %zu points, median distance %.4f x camera distance, %.3f beyond 0.05\n", frame,
        cloud.size(), median, far);
    EXPECT_LT(median, 0.01) << frame;  // measured 0.0042, 0.0040
    EXPECT_LT(far, 0.1) << frame;      // measured 0, 0
  }
  // Deterministic.
  const io::PointCloud a = stereo_points(scene, cameras, 0, options);
  const io::PointCloud b = stereo_points(scene, cameras, 0, options);
  EXPECT_EQ(a.xyz, b.xyz);
  EXPECT_EQ(a.rgb, b.rgb);
}

}  // namespace
}  // namespace retimegs::prepare
