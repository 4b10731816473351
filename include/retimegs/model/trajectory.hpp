#pragma once
// Primitive trajectories as linear maps of the parameters (docs/method.md). For a fixed time every
// trajectory is x(t) = μ + Σ_j c_j v_j (plus, for STGS, a dependence on μ_τ), so one set of
// coefficients gives the position and its vector-Jacobian product alike.
#include "retimegs/core/hd.hpp"
#include "retimegs/model/primitives.hpp"

namespace retimegs::model {

// x = μ + Σ_j coef[j] · v_j, j = 0..2 (v1, v2, v3 for Retime; b1, b2, b3 for STGS).
// For STGS, d x / d μ_τ = -(b1 + 2 b2 Δ + 3 b3 Δ²): `stgs_delta` holds Δ = t - μ_τ.
template <typename T>
struct TrajectoryCoefficients {
  T coef[3] = {0, 0, 0};
  T stgs_delta = 0;
};

// Uniform Catmull-Rom weights of the control points p0..p3 at u (u = 0 at p1, u = 1 at p2);
// outside [0, 1] the curve continues linearly with the end tangent ½(p2 - p0) or ½(p3 - p1).
template <typename T>
RETIMEGS_HD void catmull_rom_weights(T u, T w[4]) {
  if (u < T(0)) {
    w[0] = -u / 2, w[1] = 1, w[2] = u / 2, w[3] = 0;
  } else if (u > T(1)) {
    w[0] = 0, w[1] = -(u - 1) / 2, w[2] = 1, w[3] = (u - 1) / 2;
  } else {
    const T u2 = u * u, u3 = u2 * u;
    w[0] = (-u + 2 * u2 - u3) / 2;
    w[1] = (2 - 5 * u2 + 3 * u3) / 2;
    w[2] = (u + 4 * u2 - 3 * u3) / 2;
    w[3] = (-u2 + u3) / 2;
  }
}

// Control points as coefficients of (v1, v2, v3) on top of μ (Δt = step):
//   p1 = μ - ½Δt v2, p2 = μ + ½Δt v2, p0 = p1 - Δt v1, p3 = p2 + Δt v3.
template <typename T>
RETIMEGS_HD TrajectoryCoefficients<T> control_point(int k, T step) {
  TrajectoryCoefficients<T> c;
  const T h = step / 2;
  c.coef[1] = (k <= 1) ? -h : h;
  if (k == 0) c.coef[0] = -step;
  if (k == 3) c.coef[2] = step;
  return c;
}

// Position coefficients at time t for a primitive with temporal centre μ_τ; the primitive's own
// interval is [μ_τ - Δt/2, μ_τ + Δt/2] (stretching keeps μ_τ).
template <typename T>
RETIMEGS_HD TrajectoryCoefficients<T> trajectory_at(Representation representation,
                                                    TrajectoryKind kind, T mu_tau, T t, T step) {
  TrajectoryCoefficients<T> c;
  if (representation == Representation::kStgs) {
    const T d = t - mu_tau;
    c.coef[0] = d, c.coef[1] = d * d, c.coef[2] = d * d * d;
    c.stgs_delta = d;
    return c;
  }
  if (kind == TrajectoryKind::kLinear) {
    c.coef[1] = t - mu_tau;
    return c;
  }
  const T u = (t - (mu_tau - step / 2)) / step;
  T w[4];
  catmull_rom_weights(u, w);
  // Σ w_k p_k with Σ w_k = 1.
  c.coef[0] = -step * w[0];
  c.coef[1] = step / 2 * (-w[0] - w[1] + w[2] + w[3]);
  c.coef[2] = step * w[3];
  return c;
}

// d/du of catmull_rom_weights: the cubic's derivative inside [0, 1], the end tangents' outside.
template <typename T>
RETIMEGS_HD void catmull_rom_weights_du(T u, T w[4]) {
  if (u < T(0)) {
    w[0] = T(-0.5), w[1] = 0, w[2] = T(0.5), w[3] = 0;
  } else if (u > T(1)) {
    w[0] = 0, w[1] = T(-0.5), w[2] = 0, w[3] = T(0.5);
  } else {
    const T u2 = u * u;
    w[0] = (-1 + 4 * u - 3 * u2) / 2;
    w[1] = (-10 * u + 9 * u2) / 2;
    w[2] = (1 + 8 * u - 9 * u2) / 2;
    w[3] = (-2 * u + 3 * u2) / 2;
  }
}

// The velocity coefficients at time t: dx/dt = Σ_j d coef[j] / dt · v_j (trajectory_at's
// derivative in t, μ and μ_τ held; stgs_delta unused).
template <typename T>
RETIMEGS_HD TrajectoryCoefficients<T> trajectory_dt(Representation representation,
                                                    TrajectoryKind kind, T mu_tau, T t, T step) {
  TrajectoryCoefficients<T> c;
  if (representation == Representation::kStgs) {
    const T d = t - mu_tau;
    c.coef[0] = 1, c.coef[1] = 2 * d, c.coef[2] = 3 * d * d;
    return c;
  }
  if (kind == TrajectoryKind::kLinear) {
    c.coef[1] = 1;
    return c;
  }
  const T u = (t - (mu_tau - step / 2)) / step;
  T w[4];
  catmull_rom_weights_du(u, w);  // d/dt = d/du / step
  c.coef[0] = -w[0];
  c.coef[1] = (-w[0] - w[1] + w[2] + w[3]) / 2;
  c.coef[2] = w[3];
  return c;
}

// The clip's ends for tie_end_velocities: Δt/2, the first and last training times, ε (frames).
template <typename T>
struct EndTie {
  T half, first, last, epsilon;
};

// The paper's fallback where an interval has no neighbour, kept through training (the training
// config's tie_end_velocities): a primitive whose own interval [μ_τ - Δt/2, μ_τ + Δt/2] starts at
// the clip's first training time takes v1 := v2, one whose interval ends at the last v3 := v2.
// v [3, 3].
template <typename T>
RETIMEGS_HD void tie_end_velocities(const EndTie<T>& tie, T mu_tau, T* v) {
  if (mu_tau - tie.half <= tie.first + tie.epsilon)
    for (int a = 0; a < 3; ++a) v[a] = v[3 + a];
  if (mu_tau + tie.half >= tie.last - tie.epsilon)
    for (int a = 0; a < 3; ++a) v[6 + a] = v[3 + a];
}

// x = μ + Σ coef_j v_j.   mu [3], v [3, 3] (row j = v_{j+1}).
template <typename T>
RETIMEGS_HD void apply_trajectory(const TrajectoryCoefficients<T>& c, const T* mu, const T* v,
                                  T x[3]) {
  for (int a = 0; a < 3; ++a)
    x[a] = mu[a] + c.coef[0] * v[a] + c.coef[1] * v[3 + a] + c.coef[2] * v[6 + a];
}

// VJP: v_mu += v_x, v_v[j] += coef_j v_x; for STGS v_mu_tau += v_x · dx/dμ_τ.
template <typename T>
RETIMEGS_HD void apply_trajectory_vjp(Representation representation,
                                      const TrajectoryCoefficients<T>& c, const T* v,
                                      const T v_x[3], T* v_mu, T* v_v, T& v_mu_tau) {
  for (int a = 0; a < 3; ++a) {
    v_mu[a] += v_x[a];
    for (int j = 0; j < 3; ++j) v_v[3 * j + a] += c.coef[j] * v_x[a];
  }
  if (representation == Representation::kStgs) {
    const T d = c.stgs_delta;
    for (int a = 0; a < 3; ++a)
      v_mu_tau -= v_x[a] * (v[a] + 2 * d * v[3 + a] + 3 * d * d * v[6 + a]);
  }
}

}  // namespace retimegs::model
