#pragma once
// Cameras recovered up to a similarity (structure from motion) against the true ones: the
// tests of `import videos` without a calibration.
#include <algorithm>
#include <cmath>
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

// Two recovered cameras against the true two, in degrees: what a similarity leaves of a pair's
// poses, their relative rotation and the direction of the baseline as the first camera sees it
// (two centres do not determine a similarity: scale and the rotation about the baseline stay
// free, hence no centre errors).
struct PairErrors {
  double rotation = 1e30;  // of the second camera relative to the first
  double baseline = 1e30;  // between the directions to the second camera's centre
};

inline PairErrors pair_error_degrees(const Camera& truth_a, const Camera& truth_b,
                                     const Camera& recovered_a, const Camera& recovered_b) {
  const auto relative = [](const Camera& a, const Camera& b) -> Eigen::Matrix3d {
    return b.rotation() * a.rotation().transpose();
  };
  const auto baseline = [](const Camera& a, const Camera& b) -> Eigen::Vector3d {
    return (a.rotation() * (b.center() - a.center())).normalized();
  };
  constexpr double kDegrees = 180 / 3.14159265358979323846;
  PairErrors e;
  e.rotation =
      Eigen::AngleAxisd(relative(recovered_a, recovered_b) * relative(truth_a, truth_b).transpose())
          .angle() *
      kDegrees;
  e.baseline = std::acos(std::clamp(
                   baseline(recovered_a, recovered_b).dot(baseline(truth_a, truth_b)), -1.0, 1.0)) *
               kDegrees;
  return e;
}

// What two views determine of two cameras whatever their focal lengths: the epipolar geometry.
// Points the true cameras both see (a grid of the first's pixels, at depths 0.7 to 1.3 times the
// distance to where the two optical axes pass nearest) are projected by the true cameras, and the
// distance in pixels of the second's projection from the epipolar line of the first's, by the
// recovered cameras, is returned: the largest over those points.
inline double epipolar_error_px(const Camera& truth_a, const Camera& truth_b,
                                const Camera& recovered_a, const Camera& recovered_b) {
  // The depth along a's axis nearest b's axis.
  const Eigen::Vector3d ca = truth_a.center(), cb = truth_b.center();
  const Eigen::Vector3d da = truth_a.rotation().row(2).transpose(),
                        db = truth_b.rotation().row(2).transpose();
  const Eigen::Vector3d w = ca - cb;
  const double b = da.dot(db), d = da.dot(w), e = db.dot(w);
  const double depth = (b * e - d) / (1 - b * b);
  const auto k = [](const Camera& c) {
    Eigen::Matrix3d m;
    m << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1;
    return m;
  };
  const Eigen::Matrix3d r = recovered_b.rotation() * recovered_a.rotation().transpose();
  const Eigen::Vector3d t = recovered_b.translation() - r * recovered_a.translation();
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  const Eigen::Matrix3d f =
      k(recovered_b).inverse().transpose() * tx * r * k(recovered_a).inverse();
  double worst = 0;
  for (int gy = 1; gy < 8; ++gy)
    for (int gx = 1; gx < 8; ++gx)
      for (const double scale : {0.7, 1.0, 1.3}) {
        const Eigen::Vector2d pa(truth_a.width * gx / 8.0, truth_a.height * gy / 8.0);
        const Eigen::Vector3d x = truth_a.unproject(pa, scale * depth);
        if (truth_b.world_to_cam(x).z() <= 0) continue;
        const Eigen::Vector2d pb = truth_b.project(x);
        if (!truth_b.in_image(pb)) continue;
        const Eigen::Vector3d line = f * pa.homogeneous();
        worst = std::max(worst, std::abs(line.dot(pb.homogeneous())) / line.head<2>().norm());
      }
  return worst;
}

}  // namespace retimegs::test
