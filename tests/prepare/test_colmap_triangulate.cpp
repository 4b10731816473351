#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/prepare/colmap_triangulate.hpp"
#include "retimegs/synth/synth.hpp"
#include "test_util.hpp"

namespace retimegs::prepare {
namespace {
namespace fs = std::filesystem;

io::Scene minimal_scene(const fs::path& root) {
  synth::SynthOptions options;
  options.preset = "minimal";
  options.cameras = 24;  // 15 degrees apart: enough points seen by three cameras
  options.supersample = 1;
  options.frames = 2;
  options.width = 400, options.height = 300;
  options.progress = false;
  synth::synthesize_scene(options, root);
  return media::read_scene(root);
}

// Median distance of `points` to the renderer's own surface samples of frame 0, and the mean
// camera distance from the origin, where the objects are.
std::pair<double, double> median_distance(const io::Scene& scene, const io::PointCloud& points,
                                          double* colour_error = nullptr) {
  const auto truth = io::load_points(scene, 0);
  EXPECT_TRUE(truth.has_value());
  double extent = 0;
  for (const Camera& cam : scene.cameras) extent += cam.center().norm() / scene.cameras.size();
  std::vector<double> distances;
  double colours = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f p(points.xyz[3 * i], points.xyz[3 * i + 1], points.xyz[3 * i + 2]);
    float best = 1e30f;
    std::size_t best_j = 0;
    for (std::size_t j = 0; j < truth->size(); ++j) {
      const float d =
          (Eigen::Vector3f(truth->xyz[3 * j], truth->xyz[3 * j + 1], truth->xyz[3 * j + 2]) - p)
              .squaredNorm();
      if (d < best) best = d, best_j = j;
    }
    distances.push_back(std::sqrt(best));
    if (!truth->rgb.empty())
      for (int c = 0; c < 3; ++c)
        colours +=
            std::abs(points.rgb[3 * i + c] - truth->rgb[3 * best_j + c]) / (3.0 * points.size());
  }
  if (colour_error) *colour_error = truth->rgb.empty() ? 0.0 : colours;
  std::nth_element(distances.begin(), distances.begin() + distances.size() / 2, distances.end());
  return {distances[distances.size() / 2], extent};
}

// COLMAP with the synthetic scene's known poses must put its points on the scene's surfaces:
// the median distance to the renderer's own surface samples (points/00000.ply) is a small
// fraction of the camera distance.
TEST(ColmapTriangulate, PointsLieOnTheSyntheticSurfaces) {
  if (!test::have_colmap()) GTEST_SKIP() << "colmap not installed (scripts/setup.sh installs it)";
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene");
  ColmapOptions options;
  options.threads = 2;
  const auto start = std::chrono::steady_clock::now();
  const io::PointCloud points =
      triangulate_with_colmap(scene, 0, dir / "work", dir / "logs", options);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("colmap triangulation: %zu points in %.1f s\n", points.size(), seconds);
  ASSERT_GE(points.size(), 30u);
  ASSERT_EQ(points.rgb.size(), points.xyz.size());
  double colour_error = 0;
  const auto [median, extent] = median_distance(scene, points, &colour_error);
  std::printf("median distance %.4f (extent %.2f), mean colour error %.3f\n", median, extent,
              colour_error);
  EXPECT_LT(median, 0.02 * extent);
  // Colours come from the images (shaded), the reference from the albedo: loosely close.
  EXPECT_LT(colour_error, 0.35);
}

// Two training cameras 15 degrees apart: every track is a two-view one. The rig keeps them
// (keeps_two_view_tracks), and they lie on the surfaces as the multi-view points do.
TEST(ColmapTriangulate, TwoCameraRigKeepsTwoViewPoints) {
  if (!test::have_colmap()) GTEST_SKIP() << "colmap not installed (scripts/setup.sh installs it)";
  test::TempDir dir;
  io::Scene scene = minimal_scene(dir / "scene");
  for (std::size_t c = 2; c < scene.cameras.size(); ++c) scene.cameras[c].split = Split::kTest;
  io::write_scene_json(scene);
  scene = media::read_scene(dir / "scene");
  ASSERT_EQ(io::training_cameras(scene).size(), 2u);
  ColmapOptions options;
  options.threads = 2;
  const io::PointCloud points =
      triangulate_with_colmap(scene, 0, dir / "work", dir / "logs", options);
  const auto [median, extent] = median_distance(scene, points);
  std::printf("two cameras: %zu points, median distance %.4f (extent %.2f)\n", points.size(),
              median, extent);
  EXPECT_GE(points.size(), 10u);  // 20 to 23 on this pair (COLMAP varies)
  EXPECT_LT(median, 0.02 * extent);
}

// The rule for one point: tracks of three or more always; two-view tracks only where the rig
// keeps them, at 5 degrees or wider and within half the reprojection bound.
TEST(ColmapTriangulate, TwoViewPointsNeedAnAngleAndASmallReprojectionError) {
  const Eigen::Vector3d x(0, 0, 10);
  auto pair_at = [&](double degrees) {  // two centres seeing x at `degrees` apart
    const double half = std::tan(0.5 * degrees * std::numbers::pi / 180) * 10;
    return std::vector<Eigen::Vector3d>{{-half, 0, 0}, {half, 0, 0}};
  };
  EXPECT_NEAR(triangulation_angle_degrees(x, pair_at(30)), 30, 1e-9);
  EXPECT_NEAR(triangulation_angle_degrees(x, {{0, 0, 0}, {10, 0, 10}, {1, 0, 0}}), 90, 1e-9);
  EXPECT_EQ(triangulation_angle_degrees(x, {{0, 0, 0}}), 0);

  ColmapOptions options;  // max_reprojection_error 4, min_track_length 3
  io::ColmapPoint p;
  p.xyz = x;
  p.error = 1.0;
  EXPECT_TRUE(keep_triangulated_point(p, pair_at(10), true, options));
  EXPECT_FALSE(keep_triangulated_point(p, pair_at(10), false, options));  // a rig of many
  EXPECT_FALSE(keep_triangulated_point(p, pair_at(4.9), true, options));  // near-degenerate
  EXPECT_TRUE(keep_triangulated_point(p, pair_at(5.1), true, options));
  p.error = 2.5;  // over half of 4 px: off its epipolar line
  EXPECT_FALSE(keep_triangulated_point(p, pair_at(10), true, options));
  // Three views: COLMAP's own checks stand, whatever the angle or the rig.
  std::vector<Eigen::Vector3d> three = pair_at(1);
  three.push_back({0, 0.1, 0});
  EXPECT_TRUE(keep_triangulated_point(p, three, false, options));
  EXPECT_TRUE(keep_triangulated_point(p, three, true, options));
  EXPECT_FALSE(keep_triangulated_point(p, {{0, 0, 0}}, true, options));
}

TEST(ColmapTriangulate, ClearErrorWhenColmapIsMissing) {
  test::TempDir dir;
  io::Scene scene;
  scene.num_frames = 1;
  ColmapOptions options;
  options.executable = "retimegs-no-such-colmap";
  test::expect_error(
      [&] { triangulate_with_colmap(scene, 0, dir / "work", dir / "logs", options); },
      {"COLMAP not found", "install the Debian package colmap"});
}

// A failing command reports its step and its last error line.
TEST(ColmapTriangulate, FailingCommandShowsItsErrorLine) {
  test::TempDir dir;
  const io::Scene scene = [&] {
    synth::SynthOptions o;
    o.preset = "minimal";
    o.cameras = 2, o.frames = 2, o.width = 32, o.height = 24, o.supersample = 1;
    o.progress = false;
    synth::synthesize_scene(o, dir / "scene");
    return media::read_scene(dir / "scene");
  }();
  const fs::path fake = dir / "fake-colmap";
  test::write_text(
      fake,
      "#!/bin/sh\necho \"starting $1\"\necho \"E0101 error: no disk in drive $1\" >&2\n"
      "echo '*** Check failure stack trace: ***' >&2\nexit 3\n");
  fs::permissions(fake, fs::perms::owner_all);
  ColmapOptions options;
  options.executable = fake.string();
  test::expect_error(
      [&] { triangulate_with_colmap(scene, 0, dir / "work", dir / "logs", options); },
      {"colmap feature_extractor failed", "exit status 3", "no disk in drive feature_extractor"});
  test::expect_error(
      [&] { triangulate_with_colmap(scene, 5, dir / "work", dir / "logs", options); },
      {"frame 5", "0:1"});
}

}  // namespace
}  // namespace retimegs::prepare
