#pragma once
// The per-primitive math of slice, slice_backward, shade and shade_backward (model/slice.hpp),
// written once for both devices (DESIGN.md §3): the CPU's src/model/slice.cpp and the CUDA
// kernels of src/cuda/slice.cu call these on one row each, so that CI's CPU tests exercise the
// math the GPU runs. The arrays are plain pointers into the host or the device layouts
// (PrimitivesT's [N, width] fields, GaussiansT's [M, width] arrays); the settings of one call are
// a SliceParams, built on the host by slice_params (model/slice.hpp) and passed by value.
#include <cstddef>

#include "retimegs/core/hd.hpp"
#include "retimegs/core/limits.hpp"
#include "retimegs/core/pinhole.hpp"
#include "retimegs/model/primitives.hpp"
#include "retimegs/model/sh.hpp"  // sh_formulas.hpp, and the host's out-of-line instances
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/model/trajectory.hpp"

namespace retimegs::model {

// Which primitives take part (docs/method.md, triple rendering). kLeft / kRight need t = t_i, a
// training time: kLeft = active on [t_{i-1}, t_i], kRight = active on [t_i, t_{i+1}].
enum class Group { kAll, kLeft, kRight };

constexpr int kFlowChannels = 4;  // forward (u, v), backward (u, v) in pixels
// Where the flow features sit in a render with flow_features: right after RGB.
constexpr int kForwardFlowChannel = 3, kBackwardFlowChannel = 5;

// Camera z floor when projecting trajectory control points for the flow features: a control
// point at or behind the camera would divide by a vanishing depth. A guard of its own (gsplat's
// 0.01), not the render's near plane, which culls whole Gaussians and is the user's (--near).
constexpr double kFlowNearZ = 1e-2;

// Read-only pointers to the fields of PrimitivesT (same names and layouts), host or device.
template <typename T>
struct PrimitiveArrays {
  const T *mu, *velocity, *log_scale, *q0, *q1, *sh, *opacity_logit, *mu_tau, *tau_l, *tau_r,
      *temporal_log_scale;
};
// Pointers to the fields of PrimitiveGradsT.
template <typename T>
struct PrimitiveGradArrays {
  T *v_mu, *v_velocity, *v_log_scale, *v_q0, *v_q1, *v_sh, *v_opacity_logit, *v_mu_tau,
      *v_temporal_log_scale;
};

// The field pointers of primitives and of their gradients, wherever the arrays live: P and G hold
// PrimitivesT's / PrimitiveGradsT's fields as containers with data() (host vectors, or the CUDA
// backend's device buffers).
template <typename T, typename P>
PrimitiveArrays<T> primitive_arrays(const P& p) {
  return {p.mu.data(),    p.velocity.data(), p.log_scale.data(),         p.q0.data(),
          p.q1.data(),    p.sh.data(),       p.opacity_logit.data(),     p.mu_tau.data(),
          p.tau_l.data(), p.tau_r.data(),    p.temporal_log_scale.data()};
}
template <typename T, typename G>
PrimitiveGradArrays<T> gradient_arrays(G& g) {
  return {g.v_mu.data(),
          g.v_velocity.data(),
          g.v_log_scale.data(),
          g.v_q0.data(),
          g.v_q1.data(),
          g.v_sh.data(),
          g.v_opacity_logit.data(),
          g.v_mu_tau.data(),
          g.v_temporal_log_scale.data()};
}

// Pointers to the arrays of GaussiansT (the batch being written).
template <typename T>
struct GaussianArrays {
  T *means, *log_scales, *quats, *opacities, *features;
};
// Read-only pointers to the arrays of GaussianGradsT that slice_backward reads.
template <typename T>
struct GaussianGradArrays {
  const T *v_means, *v_log_scales, *v_quats, *v_opacities, *v_features;
};

// The settings of one slice (or its backward) in the scalar T: the model's, the time's, the
// camera's and the options', converted from double once on the host.
template <typename T>
struct SliceParams {
  Representation representation = Representation::kRetime;
  TrajectoryKind trajectory = TrajectoryKind::kCatmullRom;
  int sh_degree = 0;
  int channels = 3;           // feature channels of the batch: 3 or 3 + kFlowChannels
  T t = 0, step = 1;          // the time and the grid step Δt
  T t_first = 0, t_last = 0;  // the clip's first and last training times (RetimeWindow)
  T gamma = 1, epsilon = 0;   // γ in frames, ε
  int seams[kMaxSeams] = {};  // [seam_count] ModelConfig::seams, by value for the kernels
  int seam_count = 0;
  T seam_scale = 1;                 // frames (seam_scale_frames)
  SeamSide side = SeamSide::kNone;  // RetimeWindow::side, side_seam
  T side_seam = 0;
  T eye[3] = {0, 0, 0};  // the camera centre: the view directions start there
  PinholeT<T> pinhole;   // projects the flow features' control points
  Group group = Group::kAll;
  T group_from = 0, group_to = 0;  // kLeft / kRight: the window must cover [from, to]
  bool compensate = false, flow_features = false;
  T min_opacity = 0;          // the cut: σ · σ_τ >= min_opacity ...
  bool cut_positive = false;  // ... and, unless min_opacity > 0, σ_τ > 0
};

// The RetimeGS window of primitive i (temporal_opacity.hpp's retime_window, from the params).
template <typename T>
RETIMEGS_HD inline RetimeWindow<T> window_of(const SliceParams<T>& s, const PrimitiveArrays<T>& p,
                                             std::size_t i) {
  return {p.mu_tau[i], p.tau_l[i], p.tau_r[i],   s.t_first,    s.t_last, s.gamma,    s.epsilon,
          s.step,      s.seams,    s.seam_count, s.seam_scale, s.side,   s.side_seam};
}

// σ_τ(t) of primitive i: the STGS Gaussian or the RetimeGS window.
template <typename T>
RETIMEGS_HD inline T temporal_opacity_of(const SliceParams<T>& s, const PrimitiveArrays<T>& p,
                                         std::size_t i) {
  if (s.representation == Representation::kStgs)
    return stgs_temporal_opacity(p.mu_tau[i], p.temporal_log_scale[i], s.t);
  return window_of(s, p, i)(s.t);
}

// Whether primitive i is in the batch (its group, then the min_opacity cut), with the σ_τ it is
// drawn with in w (1 when compensated).
template <typename T>
RETIMEGS_HD inline bool select_primitive(const SliceParams<T>& s, const PrimitiveArrays<T>& p,
                                         std::size_t i, T& w) {
  if (s.group != Group::kAll && !window_of(s, p, i).covers(s.group_from, s.group_to)) return false;
  w = s.compensate ? T(1) : temporal_opacity_of(s, p, i);
  return sigmoid(p.opacity_logit[i]) * w >= s.min_opacity && (s.cut_positive || w > T(0));
}

// Pixel coordinates of world point p and, when a jacobian is given, d(u, v)/dp [2, 3]. The
// camera z is floored at kFlowNearZ, where it gets no gradient.
template <typename T>
RETIMEGS_HD inline void project_point(const PinholeT<T>& camera, const T p[3], T uv[2],
                                      T* jacobian) {
  const Point3T<T> c = camera.to_camera(p[0], p[1], p[2]);
  const bool clamped = c.z < T(kFlowNearZ);
  const T z = clamped ? T(kFlowNearZ) : c.z;
  const Pixel2T<T> pixel = camera.project(c.x, c.y, z);
  uv[0] = pixel.u, uv[1] = pixel.v;
  if (!jacobian) return;
  PinholeJacobianT<T> j = camera.jacobian(c.x, c.y, z);
  if (clamped) j.j02 = j.j12 = 0;
  // Through the camera point's rotation: d(u, v)/dp = J R.
  const T* r = camera.rotation;
  for (int a = 0; a < 3; ++a) {
    jacobian[a] = j.j00 * r[a] + j.j02 * r[6 + a];
    jacobian[3 + a] = j.j11 * r[3 + a] + j.j12 * r[6 + a];
  }
}

// Flow rule (docs/method.md, triple rendering): at t >= μ_τ the primitive sits at p2 (L rule:
// forward to p3, backward to p1); before, at p1 (R rule: forward to p2, backward to p0).
struct FlowRule {
  int base, forward, backward;
};
template <typename T>
RETIMEGS_HD inline FlowRule flow_rule(T mu_tau, T t) {
  return t >= mu_tau ? FlowRule{2, 3, 1} : FlowRule{1, 2, 0};
}

template <typename T>
RETIMEGS_HD inline void control_point_position(int k, T step, const T* mu, const T* v, T p[3]) {
  apply_trajectory(control_point<T>(k, step), mu, v, p);
}

// Primitive i's SH colour seen from the camera with the primitive at x.
template <typename T>
RETIMEGS_HD inline void color_at(const SliceParams<T>& s, const PrimitiveArrays<T>& p,
                                 std::size_t i, const T x[3], T rgb[3]) {
  const T dir[3] = {x[0] - s.eye[0], x[1] - s.eye[1], x[2] - s.eye[2]};
#if defined(__CUDA_ARCH__)
  sh_formula::color(s.sh_degree, &p.sh[PrimitivesT<T>::kShWidth * i], dir, rgb);
#else
  sh_color(s.sh_degree, &p.sh[PrimitivesT<T>::kShWidth * i], dir, rgb);  // sh.hpp: the same formula
#endif
}

// VJP of color_at with the primitive on its trajectory `c`: adds the SH gradient into v_sh and
// the position's (through the view direction) into v_x.
template <typename T>
RETIMEGS_HD inline void color_vjp(const SliceParams<T>& s, const PrimitiveArrays<T>& p,
                                  std::size_t i, const TrajectoryCoefficients<T>& c,
                                  const T v_rgb[3], T* v_sh, T v_x[3]) {
  T x[3];
  apply_trajectory(c, &p.mu[3 * i], &p.velocity[9 * i], x);
  const T dir[3] = {x[0] - s.eye[0], x[1] - s.eye[1], x[2] - s.eye[2]};
  constexpr int kSh = PrimitivesT<T>::kShWidth;
#if defined(__CUDA_ARCH__)
  sh_formula::color_vjp(s.sh_degree, &p.sh[kSh * i], dir, v_rgb, &v_sh[kSh * i], v_x);
#else
  sh_color_vjp(s.sh_degree, &p.sh[kSh * i], dir, v_rgb, &v_sh[kSh * i], v_x);  // the same formula
#endif
}

// Row `row` of the batch from primitive i, drawn with temporal opacity w: opacity, mean, scale,
// rotation q(t) = q0 + q1 (t - μ_τ) (normalised by the renderer), colour (copied from
// shaded_rgb [3] when given, else the SH's) and the flow features.
template <typename T>
RETIMEGS_HD inline void slice_row(const SliceParams<T>& s, const PrimitiveArrays<T>& p,
                                  std::size_t i, T w, const T* shaded_rgb,
                                  const GaussianArrays<T>& g, std::size_t row) {
  const T* mu = &p.mu[3 * i];
  const T* v = &p.velocity[9 * i];
  g.opacities[row] = sigmoid(p.opacity_logit[i]) * w;
  T* x = &g.means[3 * row];
  apply_trajectory(trajectory_at(s.representation, s.trajectory, p.mu_tau[i], s.t, s.step), mu, v,
                   x);
  for (int a = 0; a < 3; ++a) g.log_scales[3 * row + a] = p.log_scale[3 * i + a];
  const T dt = s.t - p.mu_tau[i];
  for (int a = 0; a < 4; ++a) g.quats[4 * row + a] = p.q0[4 * i + a] + p.q1[4 * i + a] * dt;
  T* features = &g.features[s.channels * row];
  if (shaded_rgb)
    for (int a = 0; a < 3; ++a) features[a] = shaded_rgb[a];
  else
    color_at(s, p, i, x, features);
  if (s.flow_features) {
    const FlowRule rule = flow_rule(p.mu_tau[i], s.t);
    T pb[3], pf[3], pk[3], uv_b[2], uv_f[2], uv_k[2];
    control_point_position(rule.base, s.step, mu, v, pb);
    control_point_position(rule.forward, s.step, mu, v, pf);
    control_point_position(rule.backward, s.step, mu, v, pk);
    project_point<T>(s.pinhole, pb, uv_b, nullptr);
    project_point<T>(s.pinhole, pf, uv_f, nullptr);
    project_point<T>(s.pinhole, pk, uv_k, nullptr);
    T* forward = &features[kForwardFlowChannel];
    T* backward = &features[kBackwardFlowChannel];
    forward[0] = uv_f[0] - uv_b[0], forward[1] = uv_f[1] - uv_b[1];
    backward[0] = uv_k[0] - uv_b[0], backward[1] = uv_k[1] - uv_b[1];
  }
}

// Whether row `row` of the renderer's gradient has a non-zero entry (the chain rule is linear in
// it, so a zero row adds exactly zero).
template <typename T>
RETIMEGS_HD inline bool has_gradient(const GaussianGradArrays<T>& vg, std::size_t row,
                                     int channels) {
  bool nonzero = vg.v_opacities[row] != T(0);
  for (int k = 0; k < 3; ++k) nonzero |= vg.v_means[3 * row + k] != T(0);
  for (int k = 0; k < 3; ++k) nonzero |= vg.v_log_scales[3 * row + k] != T(0);
  for (int k = 0; k < 4; ++k) nonzero |= vg.v_quats[4 * row + k] != T(0);
  for (int k = 0; k < channels; ++k)
    nonzero |= vg.v_features[std::size_t(channels) * row + k] != T(0);
  return nonzero;
}

// The chain rule of slice_row: adds (+=) row `row`'s renderer gradient into primitive i's
// gradients. `temporal` is the σ_τ the row was drawn with. With shaded_v_rgb (primitive i's [3])
// the colour's gradient is added there instead of being taken through the SH.
template <typename T>
RETIMEGS_HD inline void slice_row_backward(const SliceParams<T>& s, const PrimitiveArrays<T>& p,
                                           std::size_t i, T temporal,
                                           const GaussianGradArrays<T>& vg, std::size_t row,
                                           const PrimitiveGradArrays<T>& grads, T* shaded_v_rgb) {
  const T* mu = &p.mu[3 * i];
  const T* v = &p.velocity[9 * i];
  T* v_mu = &grads.v_mu[3 * i];
  T* v_v = &grads.v_velocity[9 * i];
  T v_mu_tau = 0;
  const bool stgs = s.representation == Representation::kStgs;

  // Opacity σ · σ_τ.
  const T sig = sigmoid(p.opacity_logit[i]);
  const T v_opacity = vg.v_opacities[row];
  grads.v_opacity_logit[i] += v_opacity * temporal * sig * (1 - sig);
  if (stgs && !s.compensate)
    stgs_temporal_opacity_vjp(p.mu_tau[i], p.temporal_log_scale[i], s.t, v_opacity * sig, v_mu_tau,
                              grads.v_temporal_log_scale[i]);
  // Scale and rotation.
  for (int a = 0; a < 3; ++a) grads.v_log_scale[3 * i + a] += vg.v_log_scales[3 * row + a];
  const T dt = s.t - p.mu_tau[i];
  for (int a = 0; a < 4; ++a) {
    const T vq = vg.v_quats[4 * row + a];
    grads.v_q0[4 * i + a] += vq;
    grads.v_q1[4 * i + a] += vq * dt;
    v_mu_tau -= vq * p.q1[4 * i + a];
  }
  // Position: directly and through the view direction of the SH colour.
  const TrajectoryCoefficients<T> coefficients =
      trajectory_at(s.representation, s.trajectory, p.mu_tau[i], s.t, s.step);
  T v_x[3] = {vg.v_means[3 * row], vg.v_means[3 * row + 1], vg.v_means[3 * row + 2]};
  const T* v_rgb = &vg.v_features[s.channels * row];
  if (shaded_v_rgb) {
    for (int a = 0; a < 3; ++a) shaded_v_rgb[a] += v_rgb[a];
  } else {
    color_vjp(s, p, i, coefficients, v_rgb, grads.v_sh, v_x);
  }
  apply_trajectory_vjp(s.representation, coefficients, v, v_x, v_mu, v_v, v_mu_tau);
  // Flow features: differences of projected control points.
  if (s.flow_features) {
    const FlowRule rule = flow_rule(p.mu_tau[i], s.t);
    const T* v_flow = &vg.v_features[s.channels * row + kForwardFlowChannel];
    const int points[3] = {rule.base, rule.forward, rule.backward};
    // d feature / d point: forward = π(pf) - π(pb), backward = π(pk) - π(pb).
    const T v_uv[3][2] = {{-v_flow[0] - v_flow[2], -v_flow[1] - v_flow[3]},
                          {v_flow[0], v_flow[1]},
                          {v_flow[2], v_flow[3]}};
    for (int q = 0; q < 3; ++q) {
      T point[3], uv[2], jac[6];
      control_point_position(points[q], s.step, mu, v, point);
      project_point(s.pinhole, point, uv, jac);
      const T v_point[3] = {jac[0] * v_uv[q][0] + jac[3] * v_uv[q][1],
                            jac[1] * v_uv[q][0] + jac[4] * v_uv[q][1],
                            jac[2] * v_uv[q][0] + jac[5] * v_uv[q][1]};
      T unused = 0;
      apply_trajectory_vjp(Representation::kRetime, control_point<T>(points[q], s.step), v, v_point,
                           v_mu, v_v, unused);
    }
  }
  if (stgs) grads.v_mu_tau[i] += v_mu_tau;
}

// d loss / d t of row `row` (primitive i) of a batch drawn at time s.t: the chain rule of
// slice_row's dependence on t, the renderer's gradient dotted with the row's rate of change.
// The opacity through σ_τ(t) (not when compensated), the mean along its trajectory (directly and
// through the view direction of its SH colour), the rotation q0 + q1 (t − μ_τ). The flow features
// are differences of control points, constant in t between the rule's switches, and add nothing.
// `v_sh` is scratch of PrimitivesT<T>::kShWidth values (the SH's gradient, discarded).
template <typename T>
RETIMEGS_HD inline T slice_row_time_vjp(const SliceParams<T>& s, const PrimitiveArrays<T>& p,
                                        std::size_t i, const GaussianGradArrays<T>& vg,
                                        std::size_t row, T* v_sh) {
  const T sig = sigmoid(p.opacity_logit[i]);
  T dw = 0;  // d σ_τ / d t
  if (!s.compensate) {
    if (s.representation == Representation::kStgs) {
      const T scale = std::exp(p.temporal_log_scale[i]);
      const T d = (s.t - p.mu_tau[i]) / scale;
      dw = -2 * d * std::exp(-d * d) / scale;
    } else {
      dw = window_of(s, p, i).d_dt(s.t);
    }
  }
  T v_t = vg.v_opacities[row] * sig * dw;
  for (int a = 0; a < 4; ++a) v_t += vg.v_quats[4 * row + a] * p.q1[4 * i + a];
  const TrajectoryCoefficients<T> coefficients =
      trajectory_at(s.representation, s.trajectory, p.mu_tau[i], s.t, s.step);
  T v_x[3] = {vg.v_means[3 * row], vg.v_means[3 * row + 1], vg.v_means[3 * row + 2]};
  T x[3];
  apply_trajectory(coefficients, &p.mu[3 * i], &p.velocity[9 * i], x);
  const T dir[3] = {x[0] - s.eye[0], x[1] - s.eye[1], x[2] - s.eye[2]};
  constexpr int kSh = PrimitivesT<T>::kShWidth;
  for (int k = 0; k < kSh; ++k) v_sh[k] = 0;
  const T* v_rgb = &vg.v_features[s.channels * row];
#if defined(__CUDA_ARCH__)
  sh_formula::color_vjp(s.sh_degree, &p.sh[kSh * i], dir, v_rgb, v_sh, v_x);
#else
  sh_color_vjp(s.sh_degree, &p.sh[kSh * i], dir, v_rgb, v_sh, v_x);            // the same formula
#endif
  const TrajectoryCoefficients<T> rate =
      trajectory_dt(s.representation, s.trajectory, p.mu_tau[i], s.t, s.step);
  const T* v = &p.velocity[9 * i];
  for (int a = 0; a < 3; ++a)
    v_t += v_x[a] * (rate.coef[0] * v[a] + rate.coef[1] * v[3 + a] + rate.coef[2] * v[6 + a]);
  return v_t;
}

// shade's row: primitive i's SH colour at its position at t into rgb [3], zero into v_rgb [3].
template <typename T>
RETIMEGS_HD inline void shade_row(const SliceParams<T>& s, const PrimitiveArrays<T>& p,
                                  std::size_t i, T rgb[3], T v_rgb[3]) {
  T x[3];
  apply_trajectory(trajectory_at(s.representation, s.trajectory, p.mu_tau[i], s.t, s.step),
                   &p.mu[3 * i], &p.velocity[9 * i], x);
  color_at(s, p, i, x, rgb);
  for (int a = 0; a < 3; ++a) v_rgb[a] = T(0);
}

// shade_backward's row: the colour's gradient v_rgb [3] of primitive i through the SH and the
// view direction; a zero v_rgb adds nothing and is skipped.
template <typename T>
RETIMEGS_HD inline void shade_row_backward(const SliceParams<T>& s, const PrimitiveArrays<T>& p,
                                           std::size_t i, const T v_rgb[3],
                                           const PrimitiveGradArrays<T>& grads) {
  if (v_rgb[0] == T(0) && v_rgb[1] == T(0) && v_rgb[2] == T(0)) return;
  const TrajectoryCoefficients<T> coefficients =
      trajectory_at(s.representation, s.trajectory, p.mu_tau[i], s.t, s.step);
  T v_x[3] = {0, 0, 0}, v_mu_tau = 0;
  color_vjp(s, p, i, coefficients, v_rgb, grads.v_sh, v_x);
  apply_trajectory_vjp(s.representation, coefficients, &p.velocity[9 * i], v_x, &grads.v_mu[3 * i],
                       &grads.v_velocity[9 * i], v_mu_tau);
  if (s.representation == Representation::kStgs) grads.v_mu_tau[i] += v_mu_tau;
}

}  // namespace retimegs::model
