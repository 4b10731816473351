// Which cameras pair for dense stereo (the rule is in points_stereo.hpp).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <tuple>
#include <utility>

#include "look_region.hpp"
#include "retimegs/prepare/points_stereo.hpp"
#include "stereo_detail.hpp"

namespace retimegs::prepare {

namespace detail {

Eigen::Vector3d scene_centre(const io::Scene& scene, const std::vector<int>& cameras) {
  Eigen::Vector3d lo, hi;
  common_region(scene, cameras, lo, hi);
  return 0.5 * (lo + hi);
}

double angle_degrees(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double c = a.normalized().dot(b.normalized());
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180 / std::numbers::pi;
}

}  // namespace detail

std::vector<StereoPair> stereo_pairs(const io::Scene& scene, const std::vector<int>& cameras) {
  if (cameras.size() < 2) return {};
  const Eigen::Vector3d centre = detail::scene_centre(scene, cameras);
  auto measure = [&](int a, int b) {
    const Camera& ca = scene.cameras[a];
    const Camera& cb = scene.cameras[b];
    StereoPair p{std::min(a, b), std::max(a, b)};
    p.axis_angle =
        detail::angle_degrees(ca.rotation().row(2).transpose(), cb.rotation().row(2).transpose());
    p.triangulation_angle = detail::angle_degrees(ca.center() - centre, cb.center() - centre);
    return p;
  };
  auto usable = [&](const StereoPair& p) {
    return p.axis_angle <= kMaxStereoAxisAngle &&
           p.triangulation_angle >= kMinStereoTriangulationAngle &&
           scene.cameras[p.left].world_to_cam(centre).z() > 0 &&
           scene.cameras[p.right].world_to_cam(centre).z() > 0;
  };
  std::set<std::pair<int, int>> chosen;
  for (int a : cameras) {
    std::vector<StereoPair> partners;
    for (int b : cameras)
      if (b != a) {
        const StereoPair p = measure(a, b);
        if (usable(p)) partners.push_back(p);
      }
    // The smallest axis angles first (ties: camera order), so the choice is deterministic.
    std::sort(partners.begin(), partners.end(), [](const StereoPair& x, const StereoPair& y) {
      return std::tie(x.axis_angle, x.left, x.right) < std::tie(y.axis_angle, y.left, y.right);
    });
    for (std::size_t i = 0; i < partners.size() && int(i) < kMaxStereoPartners; ++i)
      chosen.emplace(partners[i].left, partners[i].right);
  }
  std::vector<StereoPair> pairs;
  for (const auto& [a, b] : chosen) pairs.push_back(measure(a, b));
  return pairs;
}

}  // namespace retimegs::prepare
