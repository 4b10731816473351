// Stage 1 in float, one Gaussian per simd lane: EWA projection and its vector-Jacobian product,
// formula for formula the scalar code of project.cpp (see there for the derivations), with the
// culling and clamping branches as lane masks.
#include "project_lanes.hpp"

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "simd.hpp"

namespace retimegs::render {
namespace {

using simd::vf;
using simd::vi;
constexpr int kLanes = simd::kLanes;

// The Gaussians [first, first + count) of a batch, count <= 16. In a partial batch (the last),
// lanes past `count` repeat the last Gaussian, so that they compute finite values; their results
// are never stored.
struct Batch {
  std::size_t first;
  int count;

  bool full() const { return count == kLanes; }
  std::uint32_t all() const { return simd::bits(simd::lanes_below(count)); }

  // columns[k] = component k of each lane's row of a [N, W] array.
  template <int W>
  void load(const float* data, vf (&columns)[W]) const {
    simd::load_columns<W>(&data[first * W], count, columns);
  }
  vf load(const float* data) const {  // [N]
    vf column[1];
    load<1>(data, column);
    return column[0];
  }
  vi load(const std::int32_t* data) const { return simd::load_lanes(&data[first], count); }
  // Writes the batch's rows of a [N, W] array: the columns' values in the lanes of `keep`, zero
  // in the others.
  template <int W>
  void store(float* data, const vf (&columns)[W], simd::mask keep) const {
    vf kept[W];
    for (int k = 0; k < W; ++k) kept[k] = simd::select(keep, columns[k], vf{});
    if (full()) return simd::store_columns<W>(&data[first * W], kept);
    for (int l = 0; l < count; ++l)
      for (int k = 0; k < W; ++k) data[(first + l) * W + k] = kept[k][l];
  }
  void store(float* data, vf column, simd::mask keep) const { store<1>(data, {column}, keep); }
  void store(std::int32_t* data, vi column, simd::mask keep) const {  // [N]
    const vi kept = simd::select(keep, column, vi{});
    if (full())
      std::memcpy(&data[first], &kept, sizeof(kept));
    else
      for (int l = 0; l < count; ++l) data[first + l] = kept[l];
  }
};

// The camera's numbers that every lane shares: the pinhole and its field-of-view guard.
struct CameraConstants : PinholeT<float> {
  FovGuardT<float> lim;

  explicit CameraConstants(const PinholeT<float>& camera) : PinholeT<float>(camera), lim(camera) {}
};

// e^x for |x| < 87 (log-scales), from the blend's 2^y (formulas.hpp's exp_approx per lane).
inline vf exp_lanes(vf x) {
  return simd::exp2(x * kLog2e);
}

// Everything the forward computes for a batch that the backward needs again (formulas.hpp's
// ProjectionGeometryT, one value per lane).
struct GeometryLanes {
  vf p[3];                  // camera-space mean
  vf qnorm, q[4];           // |q| and the normalised quaternion (w, x, y, z)
  vf rq[9];                 // [3, 3] rotation of the Gaussian
  vf scale[3];              // exp(log_scale)
  vf m[9];                  // [3, 3] rq diag(scale)
  vf cov_cam[6];            // camera-space 3-D covariance
  vf jc[2][3];              // [2, 3] J cov_cam
  vf tx_over_z, ty_over_z;  // guarded x/z, y/z
  simd::mask clamped_x, clamped_y;
  // d pixel / d camera point J, at the guarded point (z tx_over_z, z ty_over_z, z)
  PinholeJacobianT<vf> jac;
  vf cov2d[3];  // blurred 2-D covariance: 00 01 11
};

// Lanes whose every value is finite (x - x is 0 unless x is infinite or NaN).
template <int W>
simd::mask all_finite(const vf (&values)[W]) {
  simd::mask finite = simd::lanes_below(kLanes);
  for (const vf& x : values) finite &= simd::less_equal(x - x, vf{});
  return finite;
}

// `valid`, when given: the lanes whose mean, quaternion and log-scales check_gaussians accepts
// (finite, and a non-zero quaternion).
GeometryLanes geometry(const GaussiansT<float>& g, const Batch& batch, const CameraConstants& cam,
                       float low_pass, simd::mask* valid = nullptr) {
  GeometryLanes geo;
  vf mean[3];
  batch.load<3>(g.means.data(), mean);
  const auto [x_cam, y_cam, z_cam] = cam.to_camera(mean[0], mean[1], mean[2]);
  geo.p[0] = x_cam, geo.p[1] = y_cam, geo.p[2] = z_cam;
  vf q[4];
  batch.load<4>(g.quats.data(), q);
  geo.qnorm = simd::sqrt_nonnegative(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (int k = 0; k < 4; ++k) geo.q[k] = q[k] / geo.qnorm;
  quat_to_rotation(geo.q[0], geo.q[1], geo.q[2], geo.q[3], geo.rq);
  batch.load<3>(g.log_scales.data(), geo.scale);
  if (valid) {
    const vf norm2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    *valid = all_finite(mean) & all_finite(q) & all_finite(geo.scale) & simd::less(vf{}, norm2);
  }
  for (vf& scale : geo.scale) scale = exp_lanes(scale);
  vf cov_world[6];
  world_covariance(geo.rq, geo.scale, geo.m, cov_world);
  camera_covariance(cam.rotation, cov_world, geo.cov_cam);

  const vf pz = geo.p[2];
  const vf xz = geo.p[0] / pz, yz = geo.p[1] / pz;
  geo.clamped_x = ~(simd::greater_equal(xz, simd::splat(-cam.lim.x_neg)) &
                    simd::less_equal(xz, simd::splat(cam.lim.x_pos)));
  geo.clamped_y = ~(simd::greater_equal(yz, simd::splat(-cam.lim.y_neg)) &
                    simd::less_equal(yz, simd::splat(cam.lim.y_pos)));
  geo.tx_over_z = simd::min(simd::max(xz, simd::splat(-cam.lim.x_neg)), simd::splat(cam.lim.x_pos));
  geo.ty_over_z = simd::min(simd::max(yz, simd::splat(-cam.lim.y_neg)), simd::splat(cam.lim.y_pos));
  geo.jac = cam.jacobian(pz * geo.tx_over_z, pz * geo.ty_over_z, pz);
  image_covariance(geo.jac, geo.cov_cam, low_pass, geo.jc, geo.cov2d);
  return geo;
}

// Lanes whose radius_tile_rect (project.cpp) is not empty, with C-style truncation.
simd::mask tile_rect_not_empty(vf u, vf v, vi radius, int tiles_x, int tiles_y) {
  const vf lim = simd::splat(float(kMaxPixelCoordinate));
  u = simd::min(simd::max(u, -lim), lim);
  v = simd::min(simd::max(v, -lim), lim);
  const vf r = __builtin_convertvector(radius, vf) * kInverseTileSize;
  const auto clamp = [](vi a, int hi) {
    return simd::min(simd::max(a, vi{}), simd::splat_int(hi));
  };
  const auto trunc = [](vf a) { return __builtin_convertvector(a, vi); };
  const vi x0 = clamp(trunc(u * kInverseTileSize - r), tiles_x);
  const vi x1 = clamp(trunc(u * kInverseTileSize + r) + 1, tiles_x);
  const vi y0 = clamp(trunc(v * kInverseTileSize - r), tiles_y);
  const vi y1 = clamp(trunc(v * kInverseTileSize + r) + 1, tiles_y);
  return simd::less(x0, x1) & simd::less(y0, y1);
}

}  // namespace

void project_forward_lanes(const GaussiansT<float>& g, const PinholeT<float>& camera,
                           const RenderOptions& options, ProjectedT<float>& out) {
  check_sizes_and_features(g);  // before anything is allocated or read
  const std::size_t n = g.size();
  // Every row is written below (zero for the culled).
  out.means2d.resize(2 * n);
  out.conics.resize(3 * n);
  out.depths.resize(n);
  out.radii.resize(n);
  const CameraConstants cam(camera);
  const int tiles_x = tile_count(camera.width);
  const int tiles_y = tile_count(camera.height);
  const float min_opacity = std::max(options.min_alpha, 0.0f);
  const std::ptrdiff_t batches = std::ptrdiff_t((n + kLanes - 1) / kLanes);
  bool invalid = false;  // some lane's inputs fail check_gaussians

#pragma omp parallel for schedule(static) reduction(| : invalid)
  for (std::ptrdiff_t b = 0; b < batches; ++b) {
    const Batch batch{std::size_t(b) * kLanes, int(std::min<std::size_t>(kLanes, n - b * kLanes))};
    const vf opacity = batch.load(g.opacities.data());
    simd::mask valid;
    const GeometryLanes geo = geometry(g, batch, cam, options.low_pass, &valid);
    valid &= simd::greater_equal(opacity, vf{}) & simd::less_equal(opacity, simd::splat(1.0f));
    invalid |= simd::any(simd::and_not(simd::lanes_below(batch.count), valid));
    const vf z = geo.p[2];
    const vf* cov = geo.cov2d;
    const vf det = cov[0] * cov[2] - cov[1] * cov[1];
    const vf half_trace = 0.5f * (cov[0] + cov[2]);
    const vf lambda = half_trace + simd::sqrt_nonnegative(
                                       simd::max(half_trace * half_trace - det,
                                                 simd::splat(float(kRadiusDiscriminantFloor))));
    const vi radius = simd::ceil_to_int(float(kRadiusSigmas) * simd::sqrt_nonnegative(lambda));
    const vf zc = z + options.centre_depth_offset;
    const auto [u, v] = cam.project(geo.p[0], geo.p[1], zc);
    // Culled: opacity <= 0 or < min_alpha, z < near plane, singular covariance, off image.
    const simd::mask visible = simd::less(simd::splat(0.0f), opacity) &
                               simd::greater_equal(opacity, simd::splat(min_opacity)) &
                               simd::greater_equal(z, simd::splat(options.near_plane)) &
                               simd::less(simd::splat(0.0f), det) &
                               tile_rect_not_empty(u, v, radius, tiles_x, tiles_y);
    batch.store<2>(out.means2d.data(), {u, v}, visible);
    batch.store<3>(out.conics.data(), {cov[2] / det, -cov[1] / det, cov[0] / det}, visible);
    batch.store(out.depths.data(), z, visible);
    batch.store(out.radii.data(), radius, visible);
  }
  if (invalid) check_gaussians(g);  // throws, naming the first bad value
}

void project_backward_lanes(const GaussiansT<float>& g, const PinholeT<float>& camera,
                            const ProjectedT<float>& projected, const RenderOptions& options,
                            GaussianGradsT<float>& grads) {
  const std::size_t n = g.size();
  // Every row is written below.
  grads.v_means.resize(3 * n);
  grads.v_log_scales.resize(3 * n);
  grads.v_quats.resize(4 * n);
  const CameraConstants cam(camera);
  const std::ptrdiff_t batches = std::ptrdiff_t((n + kLanes - 1) / kLanes);

#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t b = 0; b < batches; ++b) {
    const Batch batch{std::size_t(b) * kLanes, int(std::min<std::size_t>(kLanes, n - b * kLanes))};
    // The stores below write zero rows for the culled lanes.
    const simd::mask visible = simd::less(vi{}, batch.load(projected.radii.data()));
    if (!(simd::bits(visible) & batch.all())) {
      const vf zero[4] = {};
      batch.store<3>(grads.v_means.data(), {zero[0], zero[1], zero[2]}, visible);
      batch.store<3>(grads.v_log_scales.data(), {zero[0], zero[1], zero[2]}, visible);
      batch.store<4>(grads.v_quats.data(), zero, visible);
      continue;
    }
    const GeometryLanes geo = geometry(g, batch, cam, options.low_pass);

    // conic = cov2d^-1, cov2d = J cov_cam J^T + low-pass, cov_cam = Rv M M^T Rv^T.
    vf conic[3], v_conic[3];
    batch.load<3>(projected.conics.data(), conic);
    batch.load<3>(grads.v_conics.data(), v_conic);
    vf v_cov2d[2][2];
    conic_vjp<float>(conic, v_conic, v_cov2d);
    PinholeJacobianT<vf> v_jac;
    vf v_rq[3][3], v_log_scale[3];
    covariance_vjp(geo.jac, geo.jc, cam.rotation, geo.rq, geo.scale, geo.m, v_cov2d, v_jac, v_rq,
                   v_log_scale);
    batch.store<3>(grads.v_log_scales.data(), v_log_scale, visible);
    vf v_qhat[4], v_quat[4];
    quat_to_rotation_vjp(geo.q[0], geo.q[1], geo.q[2], geo.q[3], v_rq, v_qhat);
    normalize_quat_vjp(geo.q, geo.qnorm, v_qhat, v_quat);
    batch.store<4>(grads.v_quats.data(), v_quat, visible);

    // Camera-space mean: through the pixel centre, the Jacobian and the depth.
    vf v_mean2d[2];
    batch.load<2>(grads.v_means2d.data(), v_mean2d);
    const vf pz = geo.p[2];
    vf v_p[3];
    mean2d_vjp(cam, geo.p[0], geo.p[1], pz, options.centre_depth_offset, v_mean2d[0], v_mean2d[1],
               batch.load(grads.v_depths.data()), v_p);
    const auto [v_tx, v_ty, v_z] =
        cam.jacobian_vjp(pz * geo.tx_over_z, pz * geo.ty_over_z, pz, v_jac);
    v_p[2] += v_z;
    // A clamped direction's x/z is a constant times z.
    v_p[2] += simd::select(geo.clamped_x, v_tx * geo.tx_over_z, vf{}) +
              simd::select(geo.clamped_y, v_ty * geo.ty_over_z, vf{});
    v_p[0] += simd::select(geo.clamped_x, vf{}, v_tx);
    v_p[1] += simd::select(geo.clamped_y, vf{}, v_ty);
    vf v_mean[3];
    world_mean_vjp(cam.rotation, v_p, v_mean);
    batch.store<3>(grads.v_means.data(), v_mean, visible);
  }
}

}  // namespace retimegs::render
