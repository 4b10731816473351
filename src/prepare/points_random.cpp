// The random last resort for per-frame points.
#include <random>

#include "retimegs/core/error.hpp"
#include "retimegs/prepare/points.hpp"

namespace retimegs::prepare {

io::PointCloud random_points(const io::Scene& scene, const std::vector<int>& cameras, int frame,
                             std::size_t count, std::uint64_t seed) {
  const io::Box box = io::cameras_look_box(scene, cameras);
  const Eigen::Vector3d lo = box.lo(), hi = box.hi();
  std::mt19937_64 rng(seed ^ (0x9e3779b97f4a7c15ull * std::uint64_t(frame + 1)));
  std::uniform_real_distribution<double> unit(0, 1);
  io::PointCloud cloud;
  cloud.xyz.reserve(3 * count);
  cloud.rgb.reserve(3 * count);
  for (std::size_t k = 0; k < count; ++k) {
    for (int a = 0; a < 3; ++a) cloud.xyz.push_back(float(lo[a] + (hi[a] - lo[a]) * unit(rng)));
    for (int a = 0; a < 3; ++a) cloud.rgb.push_back(float(unit(rng)));
  }
  return cloud;
}

}  // namespace retimegs::prepare
