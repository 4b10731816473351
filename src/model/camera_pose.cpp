#include "retimegs/model/camera_pose.hpp"

#include <cstddef>
#include <type_traits>

namespace retimegs::model {

namespace {

Eigen::Vector3d vec(const std::array<double, 3>& a) {
  return {a[0], a[1], a[2]};
}

Eigen::Matrix3d skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d s;
  s << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return s;
}

// J_l(ω) = I + (1 − cos θ)/θ² [ω]× + (θ − sin θ)/θ³ [ω]×², θ = |ω|; its series below 1e-4 rad.
Eigen::Matrix3d left_jacobian(const Eigen::Vector3d& w) {
  const double theta = w.norm();
  const Eigen::Matrix3d s = skew(w);
  if (theta < 1e-4) return Eigen::Matrix3d::Identity() + 0.5 * s + s * s / 6.0;
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() + (1 - std::cos(theta)) / t2 * s +
         (theta - std::sin(theta)) / (t2 * theta) * s * s;
}

constexpr std::ptrdiff_t kParallelRows = 1 << 12;  // below: one thread

}  // namespace

Eigen::Matrix4d pose_matrix(const CameraPose& pose) {
  const Eigen::Vector3d w = vec(pose.rotation);
  const double theta = w.norm();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  if (theta > 0) m.topLeftCorner<3, 3>() = Eigen::AngleAxisd(theta, w / theta).toRotationMatrix();
  m.topRightCorner<3, 1>() = vec(pose.translation);
  return m;
}

Camera corrected(const Camera& camera, const CameraPose& pose) {
  Camera out = camera;
  if (!pose.is_identity()) out.world_to_camera = pose_matrix(pose) * camera.world_to_camera;
  return out;
}

std::array<double, 6> pose_gradient(const Camera& seen, const CameraPose& pose,
                                    const std::array<double, 3>& moment,
                                    const std::array<double, 3>& force) {
  const Eigen::Matrix3d r = seen.rotation();
  const Eigen::Vector3d t = seen.translation();
  const Eigen::Vector3d v_tau = r * Eigen::Vector3d(force[0], force[1], force[2]);
  const Eigen::Vector3d v_delta =
      r * Eigen::Vector3d(moment[0], moment[1], moment[2]) + t.cross(v_tau);
  const Eigen::Vector3d v_omega = left_jacobian(vec(pose.rotation)).transpose() *
                                  (v_delta - vec(pose.translation).cross(v_tau));
  return {v_omega.x(), v_omega.y(), v_omega.z(), v_tau.x(), v_tau.y(), v_tau.z()};
}

template <typename T>
std::array<double, 6> camera_pose_vjp(const GaussiansT<T>& g, const GaussianGradsT<T>& grads,
                                      const Camera& seen, const CameraPose& pose) {
  const std::ptrdiff_t n = std::ptrdiff_t(g.size());
  double m0 = 0, m1 = 0, m2 = 0, f0 = 0, f1 = 0, f2 = 0;
#pragma omp parallel for schedule(static) reduction(+ : m0, m1, m2, f0, f1, f2) \
    if (std::is_same_v<T, float> && n >= kParallelRows)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    double moment[3] = {0, 0, 0}, force[3] = {0, 0, 0};
    add_pose_moment(&g.means[3 * i], &g.quats[4 * i], &grads.v_means[3 * i], &grads.v_quats[4 * i],
                    moment, force);
    m0 += moment[0], m1 += moment[1], m2 += moment[2];
    f0 += force[0], f1 += force[1], f2 += force[2];
  }
  return pose_gradient(seen, pose, {m0, m1, m2}, {f0, f1, f2});
}

template std::array<double, 6> camera_pose_vjp<float>(const GaussiansT<float>&,
                                                      const GaussianGradsT<float>&, const Camera&,
                                                      const CameraPose&);
template std::array<double, 6> camera_pose_vjp<double>(const GaussiansT<double>&,
                                                       const GaussianGradsT<double>&, const Camera&,
                                                       const CameraPose&);

}  // namespace retimegs::model
