#pragma once
// Cameras recovered up to a similarity (structure from motion) against the true ones: the
// tests of `import videos` without a calibration.
#include <algorithm>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "retimegs/core/camera.hpp"

namespace retimegs::test {

// Distances between recovered camera centres and the true ones after the similarity
// (Eigen::umeyama, with scale) that best maps the recovered centres onto the true ones, as
// fractions of the true rig's extent (the largest distance of a true centre from their mean).
struct CentreErrors {
  double worst = 1e30;   // of the worst-placed camera
  double median = 1e30;  // of the middle one (the upper of two): the rig as a whole
};

// Cameras are matched by name; true cameras missing from `recovered` are skipped. Needs three
// matched cameras (a similarity from fewer is not determined).
inline CentreErrors centre_error_after_alignment(const std::vector<Camera>& truth,
                                                 const std::vector<Camera>& recovered) {
  std::vector<Eigen::Vector3d> from, to;
  for (const Camera& r : recovered)
    for (const Camera& t : truth)
      if (t.name == r.name) from.push_back(r.center()), to.push_back(t.center());
  if (from.size() < 3) return {};
  Eigen::Matrix3Xd a(3, from.size()), b(3, to.size());
  for (std::size_t i = 0; i < from.size(); ++i) a.col(i) = from[i], b.col(i) = to[i];
  const Eigen::Matrix4d similarity = Eigen::umeyama(a, b, /*with_scaling=*/true);
  const Eigen::Vector3d mean = b.rowwise().mean();
  double extent = 0;
  std::vector<double> distances;
  for (std::size_t i = 0; i < from.size(); ++i) {
    extent = std::max(extent, (b.col(i) - mean).norm());
    const Eigen::Vector3d mapped = (similarity * a.col(i).homogeneous()).head<3>();
    distances.push_back((mapped - b.col(i)).norm());
  }
  std::sort(distances.begin(), distances.end());
  return {distances.back() / extent, distances[distances.size() / 2] / extent};
}

}  // namespace retimegs::test
