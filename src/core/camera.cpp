#include "retimegs/core/camera.hpp"

#include <cmath>

#include "retimegs/core/error.hpp"

namespace retimegs {

Eigen::Matrix4d look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                        const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = (target - eye).normalized();  // forward
  Eigen::Vector3d x = z.cross(up);  // right (OpenCV: x = y × z with y = down)
  if (x.norm() < 1e-9) x = z.unitOrthogonal();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);  // down
  Eigen::Matrix3d r;
  r.row(0) = x.transpose();
  r.row(1) = y.transpose();
  r.row(2) = z.transpose();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = r;
  m.topRightCorner<3, 1>() = -r * eye;
  return m;
}

void check_rigid(const Eigen::Matrix4d& m, const std::string& what, double tolerance) {
  if (!m.allFinite()) fail("{}: matrix has a non-finite entry", what);
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  const double orth = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orth > tolerance)
    fail("{}: rotation block is not orthonormal (|R^T R - I| = {:.3g})", what, orth);
  const double det = r.determinant();
  if (std::abs(det - 1.0) > tolerance)
    fail("{}: rotation determinant is {:.6g}, not +1", what, det);
  const Eigen::RowVector4d last = m.row(3);
  if ((last - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9)
    fail("{}: last row is not (0, 0, 0, 1)", what);
}

}  // namespace retimegs
