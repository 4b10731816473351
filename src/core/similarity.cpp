#include "retimegs/core/similarity.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "retimegs/core/error.hpp"

namespace retimegs {

Similarity Similarity::inverse() const {
  Similarity inv;
  inv.scale = 1 / scale;
  inv.rotation = rotation.transpose();
  inv.translation = -inv.scale * (inv.rotation * translation);
  return inv;
}

Similarity fit_similarity(const std::vector<Eigen::Vector3d>& from,
                          const std::vector<Eigen::Vector3d>& to) {
  if (from.size() != to.size())
    fail("a similarity between {} and {} points: the counts must agree", from.size(), to.size());
  if (from.size() < 3) fail("a similarity needs three points or more, got {}", from.size());
  Eigen::Matrix3Xd a(3, from.size()), b(3, to.size());
  for (std::size_t i = 0; i < from.size(); ++i)
    a.col(Eigen::Index(i)) = from[i], b.col(Eigen::Index(i)) = to[i];
  // Points on one line leave the rotation about it free: the second singular value of the
  // centred points vanishes against the first.
  const Eigen::Matrix3Xd centred = a.colwise() - a.rowwise().mean();
  const Eigen::Vector3d sv = Eigen::JacobiSVD<Eigen::Matrix3Xd>(centred).singularValues();
  constexpr double kCollinear = 1e-9;  // relative: what double-precision points on a line leave
  if (!(sv[1] > kCollinear * sv[0]))
    fail("a similarity needs points that span more than a line ({} points on one line)",
         from.size());
  const Eigen::Matrix4d m = Eigen::umeyama(a, b, /*with_scaling=*/true);
  Similarity s;
  s.scale = std::cbrt(m.topLeftCorner<3, 3>().determinant());
  s.rotation = m.topLeftCorner<3, 3>() / s.scale;
  s.translation = m.topRightCorner<3, 1>();
  return s;
}

Camera transformed(const Camera& camera, const Similarity& s) {
  Camera out = camera;
  const Eigen::Matrix3d r = camera.rotation() * s.rotation.transpose();
  const Eigen::Vector3d centre = s.apply(camera.center());
  out.world_to_camera.setIdentity();
  out.world_to_camera.topLeftCorner<3, 3>() = r;
  out.world_to_camera.topRightCorner<3, 1>() = -r * centre;
  return out;
}

double rotation_angle_degrees(const Camera& a, const Camera& b) {
  const Eigen::Matrix3d relative = a.rotation() * b.rotation().transpose();
  // acos of (trace - 1) / 2 loses precision near 0; the angle-axis conversion does not.
  return Eigen::AngleAxisd(relative).angle() * 180 / std::numbers::pi;
}

}  // namespace retimegs
