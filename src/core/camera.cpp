#include "retimegs/core/camera.hpp"

#include <algorithm>
#include <cmath>

#include "retimegs/core/error.hpp"

namespace retimegs {

Camera resized(Camera camera, int width, int height) {
  if (width <= 0 || height <= 0 || camera.width <= 0 || camera.height <= 0)
    fail("camera '{}': cannot resize {}x{} to {}x{}", camera.name, camera.width, camera.height,
         width, height);
  const double sx = double(width) / camera.width, sy = double(height) / camera.height;
  camera.fx *= sx, camera.cx *= sx, camera.fy *= sy, camera.cy *= sy;
  camera.width = width, camera.height = height;
  return camera;
}

void check_downscale(double downscale) {
  if (!(downscale >= 1.0) || !std::isfinite(downscale))
    fail("--downscale: must be a finite number >= 1, got {}", downscale);
}

Camera downscaled(Camera camera, double downscale) {
  check_downscale(downscale);
  const int width = std::max(1, int(std::lround(camera.width / downscale)));
  const int height = std::max(1, int(std::lround(camera.height / downscale)));
  return resized(std::move(camera), width, height);
}

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

Eigen::Matrix4d world_to_camera_from_opengl(const Eigen::Matrix4d& camera_to_world) {
  Eigen::Matrix3d r = camera_to_world.topLeftCorner<3, 3>();
  r.col(1) *= -1;  // y up -> y down
  r.col(2) *= -1;  // z backward -> z forward
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = r.transpose();
  m.topRightCorner<3, 1>() = -r.transpose() * camera_to_world.topRightCorner<3, 1>();
  return m;
}

}  // namespace retimegs
