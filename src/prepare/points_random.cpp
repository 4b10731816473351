// The random last resort for per-frame points, and the box it draws from.
#include <random>

#include "retimegs/core/error.hpp"
#include "retimegs/prepare/points.hpp"

namespace retimegs::prepare {

// Mirrors the random fallback of src/train/initialize.cpp (and its scene extent,
// src/train/dataset.cpp); the two should move to this one function when train is next touched.
Box cameras_look_box(const io::Scene& scene, const std::vector<int>& cameras) {
  if (cameras.empty()) fail("{}: no cameras to bound the scene", scene.json_path().string());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int c : cameras) mean += scene.cameras[c].center();
  mean /= double(cameras.size());
  double radius = 0;
  for (int c : cameras) radius = std::max(radius, (scene.cameras[c].center() - mean).norm());
  const double extent = radius > 0 ? 1.1 * radius : 1.0;  // gsplat's scene scale
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int c : cameras) {
    const Camera& cam = scene.cameras[c];
    centre += cam.center() + cam.rotation().row(2).transpose() * extent;
  }
  centre /= double(cameras.size());
  const Eigen::Vector3d half = Eigen::Vector3d::Constant(0.5 * extent);
  return {centre - half, centre + half};
}

io::PointCloud random_points(const io::Scene& scene, const std::vector<int>& cameras, int frame,
                             std::size_t count, std::uint64_t seed) {
  const Box box = cameras_look_box(scene, cameras);
  std::mt19937_64 rng(seed ^ (0x9e3779b97f4a7c15ull * std::uint64_t(frame + 1)));
  std::uniform_real_distribution<double> unit(0, 1);
  io::PointCloud cloud;
  cloud.xyz.reserve(3 * count);
  cloud.rgb.reserve(3 * count);
  for (std::size_t k = 0; k < count; ++k) {
    for (int a = 0; a < 3; ++a)
      cloud.xyz.push_back(float(box.lo[a] + (box.hi[a] - box.lo[a]) * unit(rng)));
    for (int a = 0; a < 3; ++a) cloud.rgb.push_back(float(unit(rng)));
  }
  return cloud;
}

}  // namespace retimegs::prepare
