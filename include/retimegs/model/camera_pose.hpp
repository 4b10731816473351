#pragma once
// Per-camera pose correction (docs/method.md, "Camera refinement"; nerfstudio's camera optimiser
// and gsplat's pose_opt do the same for static scenes): a user's calibration is a few pixels off,
// so training can learn for each training camera a small rigid motion Δ = (exp([ω]×), τ) applied
// in the camera's own frame, world_to_camera' = Δ · world_to_camera: ω turns the camera about its
// centre (axis-angle, radians), τ shifts it (world units, camera axes). The model stores them by
// camera name; render, eval and the viewer draw a training camera through its correction.
//
// Gradient. Δ moves the camera, which moves every Gaussian's image position and shape: the
// gradient reaches Δ through the projection (the means and rotations the rasteriser's backward
// already differentiates). A Gaussian's colour (its SH view direction) and its flow channels
// (its image displacement) also depend on the camera; both are held, as their change under a
// correction of a degree is second order against the image motion it causes.
// camera_pose_vjp below is the reduction over a render's Gaussians.
#include <array>
#include <cmath>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/gaussians.hpp"
#include "retimegs/core/hd.hpp"

namespace retimegs::model {

struct CameraPose {
  std::array<double, 3> rotation{};     // ω: axis-angle in camera axes, radians (0: none)
  std::array<double, 3> translation{};  // τ: camera axes, world units
  bool is_identity() const {
    for (int k = 0; k < 3; ++k)
      if (rotation[k] != 0 || translation[k] != 0) return false;
    return true;
  }
};

// The camera seen through its correction: world_to_camera' = Δ · world_to_camera.
Camera corrected(const Camera& camera, const CameraPose& pose);
// Δ as a rigid 4x4 (exp of ω by Rodrigues' formula, in double).
Eigen::Matrix4d pose_matrix(const CameraPose& pose);

// One Gaussian's part of the world-frame sums camera_pose_vjp reduces (both devices call it):
// with p its mean, q = (w, u) its raw quaternion and v_p, v_q their gradients,
//   moment += p × v_p + ½ (w v_u − v_w u + u × v_u),   force += v_p.
// moment is d loss / d θ for a rotation exp([θ]×) of the whole scene about the world origin (the
// first term through the mean, the second through the Gaussian's rotation, q' = (1, θ/2) ⊗ q);
// force is d loss / d x for a shift x of the scene.
template <typename T, typename A>
RETIMEGS_HD inline void add_pose_moment(const T* p, const T* q, const T* v_p, const T* v_q,
                                        A (&moment)[3], A (&force)[3]) {
  const A px = p[0], py = p[1], pz = p[2], vx = v_p[0], vy = v_p[1], vz = v_p[2];
  const A w = q[0], ux = q[1], uy = q[2], uz = q[3];
  const A vw = v_q[0], vux = v_q[1], vuy = v_q[2], vuz = v_q[3];
  moment[0] += py * vz - pz * vy + A(0.5) * (w * vux - vw * ux + uy * vuz - uz * vuy);
  moment[1] += pz * vx - px * vz + A(0.5) * (w * vuy - vw * uy + uz * vux - ux * vuz);
  moment[2] += px * vy - py * vx + A(0.5) * (w * vuz - vw * uz + ux * vuy - uy * vux);
  force[0] += vx, force[1] += vy, force[2] += vz;
}

// The gradient of a correction from the world-frame sums of a render through camera
// `seen` = corrected(camera, pose): d loss / d ω then d loss / d τ. With (R, t) seen's
// world_to_camera, a left perturbation exp(δ) of Δ has d loss / d δ_τ = R force and
// d loss / d δ_ω = R moment + t × (R force); ω itself then takes J_l(ω)^T (d/dδ_ω − τ × d/dδ_τ),
// J_l the left Jacobian of SO(3).
std::array<double, 6> pose_gradient(const Camera& seen, const CameraPose& pose,
                                    const std::array<double, 3>& moment,
                                    const std::array<double, 3>& force);

// d loss / d (ω, τ) of a render of `gaussians` through seen = corrected(camera, pose), given the
// rasteriser's gradient `grads` (v_means and v_quats; other fields unread). Rows whose gradient
// is zero (culled) add nothing. Sums in double; float rows in parallel.
template <typename T>
std::array<double, 6> camera_pose_vjp(const GaussiansT<T>& gaussians,
                                      const GaussianGradsT<T>& grads, const Camera& seen,
                                      const CameraPose& pose);

}  // namespace retimegs::model
