// The cameras' common look-at region (look_region.hpp).
#include "look_region.hpp"

#include <algorithm>

#include <Eigen/Eigenvalues>

#include "retimegs/io/training_views.hpp"

namespace retimegs::prepare::detail {

namespace {

using Eigen::Vector3d;

// Axes closer to parallel than this (smallest / largest eigenvalue of sum(I - d d^T)) do not fix
// a common look-at point: a forward-facing rig.
constexpr double kMinAxisConditioning = 1e-2;

}  // namespace

void common_region(const io::Scene& scene, const std::vector<int>& cameras, Vector3d& lo,
                   Vector3d& hi) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Vector3d b = Vector3d::Zero();
  for (int c : cameras) {
    const Camera& cam = scene.cameras[c];
    const Vector3d d = cam.rotation().row(2).transpose();  // viewing direction in world space
    const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - d * d.transpose();
    a += p;
    b += p * cam.center();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(a);
  const Vector3d values = eig.eigenvalues();  // ascending
  if (values(0) > kMinAxisConditioning * values(2)) {
    const Vector3d centre = a.ldlt().solve(b);
    double radius = 0;
    int in_front = 0;
    for (int c : cameras) {
      const Camera& cam = scene.cameras[c];
      radius = std::max(radius, (cam.center() - centre).norm());
      in_front += cam.world_to_cam(centre).z() > 0;
    }
    if (2 * in_front > int(cameras.size()) && radius > 0) {
      lo = centre - Vector3d::Constant(radius);
      hi = centre + Vector3d::Constant(radius);
      return;
    }
  }
  const io::Box box = io::cameras_look_box(scene, cameras);
  lo = box.lo();
  hi = box.hi();
}

}  // namespace retimegs::prepare::detail
