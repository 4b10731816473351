#include "retimegs/model/slice.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <omp.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/pinhole.hpp"
#include "retimegs/model/sh.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/model/trajectory.hpp"

namespace retimegs::model {

namespace {

// Below this many candidate rows the selection runs on one thread (waking the others costs more).
constexpr std::size_t kParallelCandidates = 4096;

// Camera z floor when projecting trajectory control points for the flow features: a control
// point at or behind the camera would divide by a vanishing depth. A guard of its own (gsplat's
// 0.01), not the render's near plane, which culls whole Gaussians and is the user's (--near).
constexpr double kFlowNearZ = 1e-2;

// Pixel coordinates of world point p and, when a jacobian is given, d(u, v)/dp [2, 3]. The
// camera z is floored at kFlowNearZ, where it gets no gradient.
template <typename T>
void project_point(const PinholeT<T>& camera, const T p[3], T uv[2], T* jacobian = nullptr) {
  const auto [x, y, z_cam] = camera.to_camera(p[0], p[1], p[2]);
  const bool clamped = z_cam < T(kFlowNearZ);
  const T z = clamped ? T(kFlowNearZ) : z_cam;
  const auto pixel = camera.project(x, y, z);
  uv[0] = pixel.u, uv[1] = pixel.v;
  if (!jacobian) return;
  PinholeJacobianT<T> j = camera.jacobian(x, y, z);
  if (clamped) j.j02 = j.j12 = 0;
  // Through the camera point's rotation: d(u, v)/dp = J R.
  const auto& r = camera.rotation;
  for (int a = 0; a < 3; ++a) {
    jacobian[a] = j.j00 * r[a] + j.j02 * r[6 + a];
    jacobian[3 + a] = j.j11 * r[3 + a] + j.j12 * r[6 + a];
  }
}

// The camera centre in T, where the view directions of the SH colours start.
template <typename T>
std::array<T, 3> eye_of(const Camera& camera) {
  const Eigen::Vector3d e = camera.center();
  return {T(e[0]), T(e[1]), T(e[2])};
}

// Index of training time t, or -1 when t is not on the grid.
int grid_index(const TimeGrid& grid, double t) {
  const double i = std::round((t - grid.first) / grid.step);
  if (i < 0 || i >= grid.count || std::abs(grid.at(int(i)) - t) > 1e-6) return -1;
  return int(i);
}

// Flow rule (docs/method.md, triple rendering): at t >= μ_τ the primitive sits at p2 (L rule:
// forward to p3, backward to p1); before, at p1 (R rule: forward to p2, backward to p0).
struct FlowRule {
  int base, forward, backward;
};
template <typename T>
FlowRule flow_rule(T mu_tau, T t) {
  return t >= mu_tau ? FlowRule{2, 3, 1} : FlowRule{1, 2, 0};
}

template <typename T>
void control_point_position(int k, T step, const T* mu, const T* v, T p[3]) {
  apply_trajectory(control_point<T>(k, step), mu, v, p);
}

// Row i's SH colour seen from `eye` with the primitive at x.
template <typename T>
void color_at(const PrimitivesT<T>& p, std::size_t i, int degree, const T x[3],
              const std::array<T, 3>& eye, T rgb[3]) {
  const T dir[3] = {x[0] - eye[0], x[1] - eye[1], x[2] - eye[2]};
  sh_color(degree, &p.sh[PrimitivesT<T>::kShWidth * i], dir, rgb);
}

// VJP of color_at with the primitive at its trajectory `c`: adds the SH gradient into grads.v_sh
// and the position's (through the view direction) into v_x.
template <typename T>
void color_vjp(const PrimitivesT<T>& p, std::size_t i, int degree,
               const TrajectoryCoefficients<T>& c, const std::array<T, 3>& eye, const T v_rgb[3],
               PrimitiveGradsT<T>& grads, T v_x[3]) {
  T x[3];
  apply_trajectory(c, &p.mu[3 * i], &p.velocity[9 * i], x);
  const T dir[3] = {x[0] - eye[0], x[1] - eye[1], x[2] - eye[2]};
  constexpr int kSh = PrimitivesT<T>::kShWidth;
  sh_color_vjp(degree, &p.sh[kSh * i], dir, v_rgb, &grads.v_sh[kSh * i], v_x);
}

}  // namespace

template <typename T>
bool in_group(const PrimitivesT<T>& p, std::size_t i, const ModelConfig& config,
              const TimeGrid& grid, double t, Group group) {
  if (group == Group::kAll) return true;
  if (config.representation == Representation::kStgs)
    fail("group renders are not defined for the STGS baseline");
  const int index = grid_index(grid, t);
  const RetimeWindow<T> w = retime_window(p, i, config, grid);
  if (group == Group::kLeft) return w.covers(T(grid.at(index - 1)), T(t));
  return w.covers(T(t), T(grid.at(index + 1)));
}

template <typename T>
TimeSliceT<T> slice(const PrimitivesT<T>& p, const ModelConfig& config, const TimeGrid& grid,
                    double t, const Camera& camera, const SliceOptions& options) {
  TimeSliceT<T> out;
  slice(p, config, grid, t, camera, options, out);
  return out;
}

template <typename T>
void slice(const PrimitivesT<T>& p, const ModelConfig& config, const TimeGrid& grid, double t_in,
           const Camera& camera, const SliceOptions& options, TimeSliceT<T>& out,
           const ShadedT<T>* shaded) {
  if (!std::isfinite(t_in)) fail("slice: time {} is not finite", t_in);
  if (options.group != Group::kAll) {
    if (config.representation == Representation::kStgs)
      fail("group renders are not defined for the STGS baseline");
    const int index = grid_index(grid, t_in);
    if (index < 0 || (options.group == Group::kLeft && index == 0) ||
        (options.group == Group::kRight && index == grid.count - 1))
      fail("slice: the {} group is not defined at t = {} (training times {}..{} step {})",
           options.group == Group::kLeft ? "left" : "right", t_in, grid.first, grid.last(),
           grid.step);
  }
  const T t = T(t_in), step = T(grid.step);
  const std::size_t n = p.size();
  const int channels = 3 + (options.flow_features ? kFlowChannels : 0);

  // Select the rows in primitive order: each chunk of the candidates compacts its selected rows to
  // its own start, then the chunks are concatenated in order, so the batch is the serial scan's
  // for any thread count. The rows are then filled in parallel.
  const std::vector<std::int32_t>* rows = options.rows;
  const std::size_t candidates = rows ? rows->size() : n;
  std::vector<std::int32_t>& selected = out.primitive_from_gaussian;
  std::vector<T>& temporal = out.temporal;  // [selected]
  selected.resize(candidates);
  temporal.resize(candidates);
  const int chunks = omp_get_max_threads();
  std::vector<std::size_t> kept(chunks, 0);  // [chunks] rows selected in each chunk
  std::size_t unordered = candidates;        // the first row list entry out of order, if any
#pragma omp parallel for schedule(static, 1) \
    reduction(min                            \
              : unordered) if (candidates >= kParallelCandidates)
  for (int chunk = 0; chunk < chunks; ++chunk) {
    const std::size_t begin = candidates * chunk / chunks, end = candidates * (chunk + 1) / chunks;
    std::size_t to = begin;
    for (std::size_t k = begin; k < end; ++k) {
      const std::size_t i = rows ? std::size_t((*rows)[k]) : k;
      if (rows && (i >= n || (k > 0 && i <= std::size_t((*rows)[k - 1])))) {
        unordered = k;
        break;
      }
      if (!in_group(p, i, config, grid, t_in, options.group)) continue;
      const T w = options.compensate ? T(1) : temporal_opacity(p, i, config, grid, t);
      if (sigmoid(p.opacity_logit[i]) * w >= T(options.min_opacity) &&
          (options.min_opacity > 0 || w > T(0))) {
        selected[to] = std::int32_t(i);
        temporal[to++] = w;
      }
    }
    kept[chunk] = to - begin;
  }
  if (unordered < candidates)
    fail("slice: row list entry {} ({}) is not ascending within the {} primitives", unordered,
         (*rows)[unordered], n);
  std::size_t m = 0;
  for (int chunk = 0; chunk < chunks; ++chunk) {
    const std::size_t begin = candidates * chunk / chunks;
    std::copy_n(selected.begin() + begin, kept[chunk], selected.begin() + m);
    std::copy_n(temporal.begin() + begin, kept[chunk], temporal.begin() + m);
    m += kept[chunk];
  }
  selected.resize(m);
  temporal.resize(m);

  out.gaussians.resize(m, channels);
  const PinholeT<T> pinhole(camera);
  const std::array<T, 3> eye = eye_of<T>(camera);
  GaussiansT<T>& g = out.gaussians;
#pragma omp parallel for schedule(static)
  for (std::size_t row = 0; row < m; ++row) {
    const std::size_t i = selected[row];
    const T* mu = &p.mu[3 * i];
    const T* v = &p.velocity[9 * i];
    g.opacities[row] = sigmoid(p.opacity_logit[i]) * temporal[row];
    T* x = &g.means[3 * row];
    apply_trajectory(trajectory_at(config.representation, config.trajectory, p.mu_tau[i], t, step),
                     mu, v, x);
    for (int a = 0; a < 3; ++a) g.log_scales[3 * row + a] = p.log_scale[3 * i + a];
    const T dt = t - p.mu_tau[i];
    for (int a = 0; a < 4; ++a) g.quats[4 * row + a] = p.q0[4 * i + a] + p.q1[4 * i + a] * dt;
    T* features = &g.features[channels * row];
    if (shaded)
      std::copy_n(&shaded->rgb[3 * i], 3, features);
    else
      color_at(p, i, config.sh_degree, x, eye, features);
    if (options.flow_features) {
      const FlowRule rule = flow_rule(p.mu_tau[i], t);
      T pb[3], pf[3], pk[3], uv_b[2], uv_f[2], uv_k[2];
      control_point_position(rule.base, step, mu, v, pb);
      control_point_position(rule.forward, step, mu, v, pf);
      control_point_position(rule.backward, step, mu, v, pk);
      project_point(pinhole, pb, uv_b);
      project_point(pinhole, pf, uv_f);
      project_point(pinhole, pk, uv_k);
      T* forward = &features[kForwardFlowChannel];
      T* backward = &features[kBackwardFlowChannel];
      forward[0] = uv_f[0] - uv_b[0], forward[1] = uv_f[1] - uv_b[1];
      backward[0] = uv_k[0] - uv_b[0], backward[1] = uv_k[1] - uv_b[1];
    }
  }
}

namespace {

// Whether row `row` of the renderer's gradient has a non-zero entry (the chain rule is linear in
// it, so a zero row adds exactly zero).
template <typename T>
bool has_gradient(const GaussianGradsT<T>& vg, std::size_t row, int channels) {
  const auto any = [](const T* values, int count) {
    bool nonzero = false;
    for (int k = 0; k < count; ++k) nonzero |= values[k] != T(0);
    return nonzero;
  };
  return vg.v_opacities[row] != T(0) || any(&vg.v_means[3 * row], 3) ||
         any(&vg.v_log_scales[3 * row], 3) || any(&vg.v_quats[4 * row], 4) ||
         any(&vg.v_features[std::size_t(channels) * row], channels);
}

}  // namespace

template <typename T>
void slice_backward(const PrimitivesT<T>& p, const ModelConfig& config, const TimeGrid& grid,
                    double t_in, const Camera& camera, const SliceOptions& options,
                    const TimeSliceT<T>& sliced, const GaussianGradsT<T>& vg,
                    PrimitiveGradsT<T>& grads, ShadedT<T>* shaded) {
  const T t = T(t_in), step = T(grid.step);
  const int channels = sliced.gaussians.channels;
  const PinholeT<T> pinhole(camera);
  const std::array<T, 3> eye = eye_of<T>(camera);
  const bool stgs = config.representation == Representation::kStgs;
  const std::size_t m = sliced.primitive_from_gaussian.size();
  // Every primitive appears at most once in a batch: rows write disjoint gradient slots.
#pragma omp parallel for schedule(static)
  for (std::size_t row = 0; row < m; ++row) {
    if (!has_gradient(vg, row, channels)) continue;
    const std::size_t i = sliced.primitive_from_gaussian[row];
    const T* mu = &p.mu[3 * i];
    const T* v = &p.velocity[9 * i];
    T* v_mu = &grads.v_mu[3 * i];
    T* v_v = &grads.v_velocity[9 * i];
    T v_mu_tau = 0;

    // Opacity σ · σ_τ.
    const T s = sigmoid(p.opacity_logit[i]);
    const T v_opacity = vg.v_opacities[row];
    grads.v_opacity_logit[i] += v_opacity * sliced.temporal[row] * s * (1 - s);
    if (stgs && !options.compensate)
      stgs_temporal_opacity_vjp(p.mu_tau[i], p.temporal_log_scale[i], t, v_opacity * s, v_mu_tau,
                                grads.v_temporal_log_scale[i]);
    // Scale and rotation.
    for (int a = 0; a < 3; ++a) grads.v_log_scale[3 * i + a] += vg.v_log_scales[3 * row + a];
    const T dt = t - p.mu_tau[i];
    for (int a = 0; a < 4; ++a) {
      const T vq = vg.v_quats[4 * row + a];
      grads.v_q0[4 * i + a] += vq;
      grads.v_q1[4 * i + a] += vq * dt;
      v_mu_tau -= vq * p.q1[4 * i + a];
    }
    // Position: directly and through the view direction of the SH colour.
    const auto coefficients =
        trajectory_at(config.representation, config.trajectory, p.mu_tau[i], t, step);
    T v_x[3] = {vg.v_means[3 * row], vg.v_means[3 * row + 1], vg.v_means[3 * row + 2]};
    const T* v_rgb = &vg.v_features[channels * row];
    if (shaded) {
      for (int a = 0; a < 3; ++a) shaded->v_rgb[3 * i + a] += v_rgb[a];
    } else {
      color_vjp(p, i, config.sh_degree, coefficients, eye, v_rgb, grads, v_x);
    }
    apply_trajectory_vjp(config.representation, coefficients, v, v_x, v_mu, v_v, v_mu_tau);
    // Flow features: differences of projected control points.
    if (options.flow_features) {
      const FlowRule rule = flow_rule(p.mu_tau[i], t);
      const T* v_flow = &vg.v_features[channels * row + kForwardFlowChannel];
      const int points[3] = {rule.base, rule.forward, rule.backward};
      // d feature / d point: forward = π(pf) - π(pb), backward = π(pk) - π(pb).
      const T v_uv[3][2] = {{-v_flow[0] - v_flow[2], -v_flow[1] - v_flow[3]},
                            {v_flow[0], v_flow[1]},
                            {v_flow[2], v_flow[3]}};
      for (int q = 0; q < 3; ++q) {
        T point[3], uv[2], jac[6];
        control_point_position(points[q], step, mu, v, point);
        project_point(pinhole, point, uv, jac);
        const T v_point[3] = {jac[0] * v_uv[q][0] + jac[3] * v_uv[q][1],
                              jac[1] * v_uv[q][0] + jac[4] * v_uv[q][1],
                              jac[2] * v_uv[q][0] + jac[5] * v_uv[q][1]};
        T unused = 0;
        apply_trajectory_vjp(Representation::kRetime, control_point<T>(points[q], step), v, v_point,
                             v_mu, v_v, unused);
      }
    }
    if (stgs) grads.v_mu_tau[i] += v_mu_tau;
  }
}

template <typename T>
void shade(const PrimitivesT<T>& p, const ModelConfig& config, const TimeGrid& grid, double t_in,
           const Camera& camera, const std::vector<std::int32_t>& rows, ShadedT<T>& out) {
  const T t = T(t_in), step = T(grid.step);
  const std::array<T, 3> eye = eye_of<T>(camera);
  out.rgb.resize(3 * p.size());
  out.v_rgb.resize(3 * p.size());
  const std::ptrdiff_t count = std::ptrdiff_t(rows.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < count; ++k) {
    const std::size_t i = std::size_t(rows[k]);
    T x[3];
    apply_trajectory(trajectory_at(config.representation, config.trajectory, p.mu_tau[i], t, step),
                     &p.mu[3 * i], &p.velocity[9 * i], x);
    color_at(p, i, config.sh_degree, x, eye, &out.rgb[3 * i]);
    std::fill_n(&out.v_rgb[3 * i], 3, T(0));
  }
}

template <typename T>
void shade_backward(const PrimitivesT<T>& p, const ModelConfig& config, const TimeGrid& grid,
                    double t_in, const Camera& camera, const std::vector<std::int32_t>& rows,
                    const ShadedT<T>& shaded, PrimitiveGradsT<T>& grads) {
  const T t = T(t_in), step = T(grid.step);
  const std::array<T, 3> eye = eye_of<T>(camera);
  const std::ptrdiff_t count = std::ptrdiff_t(rows.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < count; ++k) {
    const std::size_t i = std::size_t(rows[k]);
    const T* v_rgb = &shaded.v_rgb[3 * i];
    if (v_rgb[0] == T(0) && v_rgb[1] == T(0) && v_rgb[2] == T(0)) continue;
    const auto coefficients =
        trajectory_at(config.representation, config.trajectory, p.mu_tau[i], t, step);
    T v_x[3] = {0, 0, 0}, v_mu_tau = 0;
    color_vjp(p, i, config.sh_degree, coefficients, eye, v_rgb, grads, v_x);
    apply_trajectory_vjp(config.representation, coefficients, &p.velocity[9 * i], v_x,
                         &grads.v_mu[3 * i], &grads.v_velocity[9 * i], v_mu_tau);
    if (config.representation == Representation::kStgs) grads.v_mu_tau[i] += v_mu_tau;
  }
}

#define RETIMEGS_INSTANTIATE(T)                                                                  \
  template bool in_group<T>(const PrimitivesT<T>&, std::size_t, const ModelConfig&,              \
                            const TimeGrid&, double, Group);                                     \
  template TimeSliceT<T> slice<T>(const PrimitivesT<T>&, const ModelConfig&, const TimeGrid&,    \
                                  double, const Camera&, const SliceOptions&);                   \
  template void slice<T>(const PrimitivesT<T>&, const ModelConfig&, const TimeGrid&, double,     \
                         const Camera&, const SliceOptions&, TimeSliceT<T>&, const ShadedT<T>*); \
  template void slice_backward<T>(const PrimitivesT<T>&, const ModelConfig&, const TimeGrid&,    \
                                  double, const Camera&, const SliceOptions&,                    \
                                  const TimeSliceT<T>&, const GaussianGradsT<T>&,                \
                                  PrimitiveGradsT<T>&, ShadedT<T>*);                             \
  template void shade<T>(const PrimitivesT<T>&, const ModelConfig&, const TimeGrid&, double,     \
                         const Camera&, const std::vector<std::int32_t>&, ShadedT<T>&);          \
  template void shade_backward<T>(const PrimitivesT<T>&, const ModelConfig&, const TimeGrid&,    \
                                  double, const Camera&, const std::vector<std::int32_t>&,       \
                                  const ShadedT<T>&, PrimitiveGradsT<T>&);
RETIMEGS_INSTANTIATE(float)
RETIMEGS_INSTANTIATE(double)
#undef RETIMEGS_INSTANTIATE

}  // namespace retimegs::model
