// A refinement's model tightened (ingest/calibration.hpp: tighten) on a synthetic COLMAP model:
// a rig whose lenses are not centred, a share of whose observations lie 1.5-3.5 px off their
// point, as features on what moves do.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "ingest/calibration.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/camera.hpp"
#include "retimegs/io/colmap.hpp"
#include "test_util.hpp"

namespace retimegs::ingest::detail {
namespace {
namespace fs = std::filesystem;

constexpr int kCameras = 24, kWidth = 640, kHeight = 360;
constexpr double kFocal = 500, kCx = 332, kCy = 171;  // the lenses: 12 px and -9 px off centre

struct Observation {
  std::size_t point = 0;
  Eigen::Vector2d pixel;
  bool off = false;  // moved 1.5-3.5 px off its point's projection
};

// kCameras on a ring of radius 4 at three heights around 400 points in a 3 m cube and 1500 on a
// sphere of radius 7 (a dome's walls), looking at the middle: exact projections with 0.2 px of
// noise, 15 % of them moved 1.5 to 3.5 px outward from the principal point in the even cameras
// and inward in the odd ones (pulling each such camera's focal length one way). Written to dir
// as COLMAP's text model with its tracks (the points two or more cameras see) as a mapper would
// start it: the true poses and focal length, the principal point at the image centre, the
// observations of image c in observations[c]'s order.
std::vector<std::vector<Observation>> write_rig_model(const fs::path& dir) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> cube(-1.5, 1.5), shift(1.5, 3.5), unit(0, 1);
  std::normal_distribution<double> noise(0, 0.2), gauss(0, 1);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 400; ++i) points.emplace_back(cube(rng), cube(rng), cube(rng));
  for (int i = 0; i < 1500; ++i)
    points.push_back(7 * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized());

  std::vector<Camera> cameras(kCameras);
  std::vector<std::vector<Observation>> observations(kCameras);
  std::vector<int> seen(points.size(), 0);
  for (int c = 0; c < kCameras; ++c) {
    const double a = 2 * M_PI * c / kCameras;
    const Eigen::Vector3d centre(4 * std::cos(a), 1.5 * (c % 3) - 1, 4 * std::sin(a));
    const Eigen::Vector3d z = -centre.normalized();
    const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
    Eigen::Matrix3d rotation;  // world to camera: rows are the camera's axes
    rotation << x.transpose(), z.cross(x).transpose(), z.transpose();
    Camera& camera = cameras[c];
    camera.fx = camera.fy = kFocal, camera.cx = kCx, camera.cy = kCy;
    camera.world_to_camera.topLeftCorner<3, 3>() = rotation;
    camera.world_to_camera.topRightCorner<3, 1>() = -rotation * centre;
    for (std::size_t p = 0; p < points.size(); ++p) {
      if (camera.world_to_cam(points[p]).z() < 0.1) continue;
      Observation o{p, camera.project(points[p])};
      if (o.pixel.x() < 0 || o.pixel.y() < 0 || o.pixel.x() > kWidth || o.pixel.y() > kHeight)
        continue;
      if (unit(rng) < 0.15) {
        o.off = true;
        const Eigen::Vector2d outward = (o.pixel - Eigen::Vector2d(kCx, kCy)).normalized();
        o.pixel += (c % 2 == 0 ? 1 : -1) * shift(rng) * outward;
      }
      o.pixel += Eigen::Vector2d(noise(rng), noise(rng));
      observations[c].push_back(o);
      ++seen[p];
    }
  }

  std::string cameras_txt, images_txt, points_txt;
  std::vector<std::string> tracks(points.size());
  for (int c = 0; c < kCameras; ++c) {
    cameras_txt += fmt::format("{} SIMPLE_RADIAL {} {} {} {} {} 0\n", c + 1, kWidth, kHeight,
                               kFocal, kWidth / 2.0, kHeight / 2.0);
    const Eigen::Quaterniond q(cameras[c].rotation());
    const Eigen::Vector3d t = cameras[c].translation();
    images_txt += fmt::format("{} {} {} {} {} {} {} {} {} cam{}.png\n", c + 1, q.w(), q.x(), q.y(),
                              q.z(), t.x(), t.y(), t.z(), c + 1, c);
    for (std::size_t i = 0; i < observations[c].size(); ++i) {
      const std::size_t p = observations[c][i].point;
      const bool tracked = seen[p] >= 2;
      images_txt += fmt::format("{}{} {} {}", i == 0 ? "" : " ", observations[c][i].pixel.x(),
                                observations[c][i].pixel.y(), tracked ? int(p) + 1 : -1);
      if (tracked) tracks[p] += fmt::format(" {} {}", c + 1, i);
    }
    images_txt += '\n';
  }
  for (std::size_t p = 0; p < points.size(); ++p)
    if (seen[p] >= 2)
      points_txt += fmt::format("{} {} {} {} 128 128 128 0{}\n", p + 1, points[p].x(),
                                points[p].y(), points[p].z(), tracks[p]);
  fs::create_directories(dir);
  write_text_file(dir / "cameras.txt", cameras_txt);
  write_text_file(dir / "images.txt", images_txt);
  write_text_file(dir / "points3D.txt", points_txt);
  return observations;
}

// Whether each observation of each image (by image id, in the model's order) still belongs to a
// point in COLMAP's model dir, read as text (model_converter).
std::vector<std::vector<bool>> kept_observations(const fs::path& exe, const fs::path& dir,
                                                 const fs::path& scratch) {
  fs::create_directories(scratch);
  colmap::run_colmap(
      exe, "model_converter",
      {"--input_path", dir.string(), "--output_path", scratch.string(), "--output_type", "TXT"},
      scratch, false);
  std::ifstream in(scratch / "images.txt");
  std::vector<std::vector<bool>> kept(kCameras);
  std::string header, points2d;
  while (std::getline(in, header)) {
    if (header.empty() || header[0] == '#') continue;
    std::getline(in, points2d);
    const int image = std::stoi(header.substr(0, header.find(' ')));
    std::istringstream fields(points2d);
    double x, y;
    long long point;
    while (fields >> x >> y >> point) kept.at(image - 1).push_back(point != -1);
  }
  return kept;
}

// Nine in ten off observations go (those 1.5 px off that noise brings nearer stay) and nearly
// all the others stay; every camera's principal point is
// adjusted (the mapper leaves them at the centre). The model is first adjusted by COLMAP's bundle
// adjuster, as the mapper ends.
TEST(Tighten, DropsTheOffObservationsAndAdjustsThePrincipalPoints) {
  if (!test::have_colmap()) GTEST_SKIP() << "colmap not installed (scripts/setup.sh installs it)";
  test::TempDir dir;
  const std::vector<std::vector<Observation>> observations = write_rig_model(dir / "model");
  const colmap::ColmapOptions options;
  const fs::path exe = colmap::find_colmap(options);
  fs::create_directories(dir / "mapped");
  colmap::run_colmap(
      exe, "bundle_adjuster",
      {"--input_path", (dir / "model").string(), "--output_path", (dir / "mapped").string()},
      dir / "logs", false);

  const fs::path tightened = tighten(exe, dir / "mapped", dir / "work", dir / "logs", options);
  const std::vector<std::vector<bool>> kept = kept_observations(exe, tightened, dir / "text");
  int off = 0, off_kept = 0, precise = 0, precise_kept = 0;
  for (int c = 0; c < kCameras; ++c) {
    ASSERT_EQ(kept[c].size(), observations[c].size()) << "camera " << c;
    for (std::size_t i = 0; i < kept[c].size(); ++i) {
      if (observations[c][i].off) {
        ++off;
        off_kept += kept[c][i];
      } else {
        ++precise;
        precise_kept += kept[c][i];
      }
    }
  }
  std::printf("kept %d of %d off observations, %d of %d precise ones\n", off_kept, off,
              precise_kept, precise);
  EXPECT_LT(off_kept, off / 10);
  EXPECT_GT(precise_kept, precise * 95 / 100);

  for (const io::ColmapCamera& camera : io::read_colmap_model(tightened).cameras)
    EXPECT_TRUE(camera.params[1] != kWidth / 2.0 && camera.params[2] != kHeight / 2.0)
        << "camera " << camera.id;
  EXPECT_TRUE(fs::is_regular_file(dir / "logs" / "tighten1" / "point_filtering.log"));
  EXPECT_TRUE(fs::is_regular_file(dir / "logs" / "tighten6" / "bundle_adjuster.log"));
}

}  // namespace
}  // namespace retimegs::ingest::detail
