// model::slice, slice_backward, shade and shade_backward on the GPU (include/retimegs/cuda/
// slice.hpp): one thread per row, each running the CPU's per-row formulas
// (model/slice_formulas.hpp).
#include "retimegs/cuda/slice.hpp"

#include <cuda_runtime.h>

#include <climits>

#include <cub/device/device_scan.cuh>

#include "launch.hpp"
#include "reduce.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/cuda/check.hpp"
#include "retimegs/model/slice_formulas.hpp"

namespace retimegs::cuda {
namespace {

using model::GaussianArrays;
using model::GaussianGradArrays;
using model::PrimitiveArrays;
using model::PrimitiveGradArrays;
using Params = model::SliceParams<float>;

// Throws Error unless the primitives' fields hold n rows each (DevicePrimitives::upload's check,
// for primitives filled on the device).
void check_rows(const DevicePrimitives& primitives, const char* what) {
  auto& self = const_cast<DevicePrimitives&>(primitives);  // fields() hands out buffers; only read
  const std::size_t n = primitives.size();
  for (const DevicePrimitives::Field& f : self.fields())
    if (f.values->size() != n * std::size_t(f.width))
      fail("{}: primitive field {} holds {} values for {} rows of {}", what, f.name,
           f.values->size(), n, f.width);
  if (n > std::size_t(INT32_MAX)) fail("{}: more than 2^31 primitives", what);
}

// Throws Error unless every gradient field holds n rows.
void check_grads(DevicePrimitiveGrads& grads, std::size_t n, const char* what) {
  const std::pair<const DeviceBuffer<float>*, int> all[] = {
      {&grads.v_mu, 3},
      {&grads.v_velocity, 9},
      {&grads.v_log_scale, 3},
      {&grads.v_q0, 4},
      {&grads.v_q1, 4},
      {&grads.v_sh, model::Primitives::kShWidth},
      {&grads.v_opacity_logit, 1},
      {&grads.v_mu_tau, 1},
      {&grads.v_temporal_log_scale, 1}};
  for (const auto& [buffer, width] : all)
    if (buffer->size() != n * std::size_t(width))
      fail("{}: the gradients are sized for {} values per field row of {}, the model has {} rows",
           what, buffer->size(), width, n);
}

// Throws Error unless the Gaussians' gradient is the batch's shape: m rows of `channels`.
void check_batch_gradient(const DeviceGaussianGrads& v_gaussians, std::size_t m, int channels,
                          const char* what) {
  if (v_gaussians.channels != channels || v_gaussians.size() != m ||
      v_gaussians.v_means.size() != 3 * m || v_gaussians.v_log_scales.size() != 3 * m ||
      v_gaussians.v_quats.size() != 4 * m ||
      v_gaussians.v_features.size() != std::size_t(channels) * m)
    fail(
        "{}: the Gaussians' gradient ({} rows, {} channels) does not match the batch ({} rows, {} "
        "channels)",
        what, v_gaussians.size(), v_gaussians.channels, m, channels);
}

// Candidate k (row list entry k, or primitive k): whether the batch keeps it (kept[k]) and the σ_τ
// it is drawn with (weight[k]); a row list entry out of order or range lowers *unordered to k.
// Thread `candidates` writes kept's trailing 0, so that the scan's last entry is the count.
__global__ void __launch_bounds__(kThreads)
    select_kernel(Params s, PrimitiveArrays<float> p, int n, const std::int32_t* __restrict__ rows,
                  int candidates, std::int32_t* __restrict__ kept, float* __restrict__ weight,
                  std::int32_t* __restrict__ unordered) {
  const int k = int(blockIdx.x) * kThreads + int(threadIdx.x);
  if (k > candidates) return;
  if (k == candidates) {
    kept[k] = 0;
    return;
  }
  int i = k;
  if (rows) {
    i = rows[k];
    if (i < 0 || i >= n || (k > 0 && i <= rows[k - 1])) {
      kept[k] = 0;
      atomicMin(unordered, k);
      return;
    }
  }
  float w = 0;
  kept[k] = model::select_primitive(s, p, std::size_t(i), w) ? 1 : 0;
  weight[k] = w;
}

// Each kept candidate k fills batch row offsets[k]: model::slice's row loop.
__global__ void __launch_bounds__(kThreads)
    fill_kernel(Params s, PrimitiveArrays<float> p, const std::int32_t* __restrict__ rows,
                int candidates, const std::int32_t* __restrict__ kept,
                const std::int32_t* __restrict__ offsets, const float* __restrict__ weight,
                const float* __restrict__ shaded_rgb, GaussianArrays<float> g,
                std::int32_t* __restrict__ primitive_from_gaussian, float* __restrict__ temporal) {
  const int k = int(blockIdx.x) * kThreads + int(threadIdx.x);
  if (k >= candidates || !kept[k]) return;
  const int i = rows ? rows[k] : k;
  const std::size_t row = std::size_t(offsets[k]);
  const float w = weight[k];
  primitive_from_gaussian[row] = i;
  temporal[row] = w;
  model::slice_row(s, p, std::size_t(i), w, shaded_rgb ? &shaded_rgb[3 * std::size_t(i)] : nullptr,
                   g, row);
}

// model::slice_backward's row loop; rows without gradient add nothing and are skipped.
__global__ void __launch_bounds__(kThreads)
    slice_backward_kernel(Params s, PrimitiveArrays<float> p, int m,
                          const std::int32_t* __restrict__ primitive_from_gaussian,
                          const float* __restrict__ temporal, GaussianGradArrays<float> vg,
                          PrimitiveGradArrays<float> grads, float* __restrict__ shaded_v_rgb) {
  const int row = int(blockIdx.x) * kThreads + int(threadIdx.x);
  if (row >= m || !model::has_gradient(vg, std::size_t(row), s.channels)) return;
  const std::size_t i = std::size_t(primitive_from_gaussian[row]);
  model::slice_row_backward(s, p, i, temporal[row], vg, std::size_t(row), grads,
                            shaded_v_rgb ? &shaded_v_rgb[3 * i] : nullptr);
}

// model::slice_time_vjp's rows, one thread per batch row, summed per block (reduce.hpp).
__global__ void __launch_bounds__(kThreads)
    slice_time_kernel(Params s, PrimitiveArrays<float> p, int m,
                      const std::int32_t* __restrict__ primitive_from_gaussian,
                      GaussianGradArrays<float> vg, double* __restrict__ partials) {
  const int row = int(blockIdx.x) * kThreads + int(threadIdx.x);
  double value[1] = {0};
  if (row < m && model::has_gradient(vg, std::size_t(row), s.channels)) {
    float v_sh[model::Primitives::kShWidth];
    value[0] = double(model::slice_row_time_vjp(s, p, std::size_t(primitive_from_gaussian[row]), vg,
                                                std::size_t(row), v_sh));
  }
  block_sums<kThreads, 1>(value, partials, int(gridDim.x), int(blockIdx.x));
}

// Adds the one total to *out.
struct AddTimeSum {
  double* out;
  __device__ void operator()(const double (&totals)[1]) const { *out += totals[0]; }
};

__global__ void __launch_bounds__(kThreads)
    shade_kernel(Params s, PrimitiveArrays<float> p, const std::int32_t* __restrict__ rows,
                 int count, float* __restrict__ rgb, float* __restrict__ v_rgb) {
  const int k = int(blockIdx.x) * kThreads + int(threadIdx.x);
  if (k >= count) return;
  const std::size_t i = std::size_t(rows ? rows[k] : k);
  model::shade_row(s, p, i, &rgb[3 * i], &v_rgb[3 * i]);
}

__global__ void __launch_bounds__(kThreads)
    shade_backward_kernel(Params s, PrimitiveArrays<float> p, const std::int32_t* __restrict__ rows,
                          int count, const float* __restrict__ v_rgb,
                          PrimitiveGradArrays<float> grads) {
  const int k = int(blockIdx.x) * kThreads + int(threadIdx.x);
  if (k >= count) return;
  const std::size_t i = std::size_t(rows ? rows[k] : k);
  model::shade_row_backward(s, p, i, &v_rgb[3 * i], grads);
}

}  // namespace

void slice(const DevicePrimitives& primitives, const model::ModelConfig& config,
           const model::TimeGrid& grid, double t, const Camera& camera,
           const DeviceSliceOptions& options, DeviceTimeSlice& out, const DeviceShaded* shaded) {
  const Params s = model::slice_params<float>(config, grid, t, camera, options.group,
                                              options.compensate, options.flow_features,
                                              options.min_opacity, options.side, options.side_seam);
  check_rows(primitives, "slice");
  const std::size_t n = primitives.size();
  if (shaded && shaded->rgb.size() != 3 * n)
    fail("slice: the shaded colours hold {} values for {} primitives", shaded->rgb.size(), n);
  const std::size_t candidates = options.rows ? options.row_count : n;
  if (candidates > std::size_t(INT32_MAX) - 2) fail("slice: more than 2^31 candidate rows");
  const PrimitiveArrays<float> p = model::primitive_arrays<float>(primitives);

  // Select, then the exclusive sum of the kept flags: each kept row's place in the batch, and in
  // its last entry the batch's size, read back with the first unordered row list entry.
  DeviceSliceScratch& scratch = out.scratch;
  scratch.kept.resize(candidates + 1);
  scratch.offsets.resize(candidates + 2);
  scratch.weight.resize(candidates);
  std::int32_t* unordered = scratch.offsets.data() + candidates + 1;
  check(cudaMemset(unordered, 0x7f, sizeof(std::int32_t)), "cudaMemset");  // 0x7f7f7f7f: none
  select_kernel<<<blocks_for(candidates + 1), kThreads>>>(s, p, int(n), options.rows,
                                                          int(candidates), scratch.kept.data(),
                                                          scratch.weight.data(), unordered);
  check(cudaGetLastError(), "slice select launch");
  with_cub_storage(
      scratch.cub_storage, "cub::DeviceScan::ExclusiveSum", [&](void* storage, std::size_t& bytes) {
        return cub::DeviceScan::ExclusiveSum(storage, bytes, scratch.kept.data(),
                                             scratch.offsets.data(), int(candidates + 1));
      });
  std::int32_t summary[2];  // the batch's size, the first unordered entry
  check(cudaMemcpy(summary, scratch.offsets.data() + candidates, sizeof summary,
                   cudaMemcpyDeviceToHost),
        "reading the slice's size back");
  if (std::size_t(summary[1]) < candidates) {
    std::int32_t entry = 0;
    check(cudaMemcpy(&entry, options.rows + summary[1], sizeof entry, cudaMemcpyDeviceToHost),
          "reading a row list entry back");
    fail("slice: row list entry {} ({}) is not ascending within the {} primitives", summary[1],
         entry, n);
  }

  const std::size_t m = std::size_t(summary[0]);
  DeviceGaussians& g = out.gaussians;
  g.channels = s.channels;
  g.means.resize(3 * m);
  g.log_scales.resize(3 * m);
  g.quats.resize(4 * m);
  g.opacities.resize(m);
  g.features.resize(std::size_t(s.channels) * m);
  out.primitive_from_gaussian.resize(m);
  out.temporal.resize(m);
  if (m == 0) return;
  const GaussianArrays<float> rows_out = {g.means.data(), g.log_scales.data(), g.quats.data(),
                                          g.opacities.data(), g.features.data()};
  fill_kernel<<<blocks_for(candidates), kThreads>>>(
      s, p, options.rows, int(candidates), scratch.kept.data(), scratch.offsets.data(),
      scratch.weight.data(), shaded ? shaded->rgb.data() : nullptr, rows_out,
      out.primitive_from_gaussian.data(), out.temporal.data());
  check(cudaGetLastError(), "slice fill launch");
}

void slice_backward(const DevicePrimitives& primitives, const model::ModelConfig& config,
                    const model::TimeGrid& grid, double t, const Camera& camera,
                    const DeviceSliceOptions& options, const DeviceTimeSlice& sliced,
                    const DeviceGaussianGrads& v_gaussians, DevicePrimitiveGrads& grads,
                    DeviceShaded* shaded) {
  Params s = model::slice_params<float>(config, grid, t, camera, model::Group::kAll,
                                        options.compensate, options.flow_features,
                                        options.min_opacity, options.side, options.side_seam);
  s.channels = sliced.gaussians.channels;
  check_rows(primitives, "slice_backward");
  const std::size_t n = primitives.size(), m = sliced.size();
  check_grads(grads, n, "slice_backward");
  check_batch_gradient(v_gaussians, m, s.channels, "slice_backward");
  if (shaded && shaded->v_rgb.size() != 3 * n)
    fail("slice_backward: the shaded colours hold {} gradient values for {} primitives",
         shaded->v_rgb.size(), n);
  if (m == 0) return;
  const GaussianGradArrays<float> vg = {v_gaussians.v_means.data(), v_gaussians.v_log_scales.data(),
                                        v_gaussians.v_quats.data(), v_gaussians.v_opacities.data(),
                                        v_gaussians.v_features.data()};
  slice_backward_kernel<<<blocks_for(m), kThreads>>>(
      s, model::primitive_arrays<float>(primitives), int(m), sliced.primitive_from_gaussian.data(),
      sliced.temporal.data(), vg, model::gradient_arrays<float>(grads),
      shaded ? shaded->v_rgb.data() : nullptr);
  check(cudaGetLastError(), "slice_backward launch");
}

void slice_time_sum(const DevicePrimitives& primitives, const model::ModelConfig& config,
                    const model::TimeGrid& grid, double t, const Camera& camera,
                    const DeviceSliceOptions& options, const DeviceTimeSlice& sliced,
                    const DeviceGaussianGrads& v_gaussians, double* sum,
                    DeviceBuffer<double>& partials) {
  Params s = model::slice_params<float>(config, grid, t, camera, model::Group::kAll,
                                        options.compensate, options.flow_features,
                                        options.min_opacity, options.side, options.side_seam);
  s.channels = sliced.gaussians.channels;
  check_rows(primitives, "slice_time_sum");
  const std::size_t m = sliced.size();
  check_batch_gradient(v_gaussians, m, s.channels, "slice_time_sum");
  if (m == 0) return;
  const GaussianGradArrays<float> vg = {v_gaussians.v_means.data(), v_gaussians.v_log_scales.data(),
                                        v_gaussians.v_quats.data(), v_gaussians.v_opacities.data(),
                                        v_gaussians.v_features.data()};
  const int blocks = int(blocks_for(m));
  partials.resize(std::size_t(blocks));
  slice_time_kernel<<<blocks, kThreads>>>(s, model::primitive_arrays<float>(primitives), int(m),
                                          sliced.primitive_from_gaussian.data(), vg,
                                          partials.data());
  check(cudaGetLastError(), "slice_time_kernel launch");
  finish_sums<1><<<1, kFinishThreads>>>(partials.data(), blocks, AddTimeSum{sum});
  check(cudaGetLastError(), "slice_time_sum finish_sums launch");
}

void shade(const DevicePrimitives& primitives, const model::ModelConfig& config,
           const model::TimeGrid& grid, double t, const Camera& camera, const std::int32_t* rows,
           std::size_t count, DeviceShaded& out) {
  const Params s =
      model::slice_params<float>(config, grid, t, camera, model::Group::kAll, false, false, 0.0);
  check_rows(primitives, "shade");
  const std::size_t n = primitives.size();
  if (count > n) fail("shade: {} rows for {} primitives", count, n);
  out.rgb.resize(3 * n);
  out.v_rgb.resize(3 * n);
  if (count == 0) return;
  shade_kernel<<<blocks_for(count), kThreads>>>(s, model::primitive_arrays<float>(primitives), rows,
                                                int(count), out.rgb.data(), out.v_rgb.data());
  check(cudaGetLastError(), "shade launch");
}

void shade_backward(const DevicePrimitives& primitives, const model::ModelConfig& config,
                    const model::TimeGrid& grid, double t, const Camera& camera,
                    const std::int32_t* rows, std::size_t count, const DeviceShaded& shaded,
                    DevicePrimitiveGrads& grads) {
  const Params s =
      model::slice_params<float>(config, grid, t, camera, model::Group::kAll, false, false, 0.0);
  check_rows(primitives, "shade_backward");
  const std::size_t n = primitives.size();
  check_grads(grads, n, "shade_backward");
  if (count > n) fail("shade_backward: {} rows for {} primitives", count, n);
  if (shaded.v_rgb.size() != 3 * n)
    fail("shade_backward: the shaded colours hold {} gradient values for {} primitives",
         shaded.v_rgb.size(), n);
  if (count == 0) return;
  shade_backward_kernel<<<blocks_for(count), kThreads>>>(
      s, model::primitive_arrays<float>(primitives), rows, int(count), shaded.v_rgb.data(),
      model::gradient_arrays<float>(grads));
  check(cudaGetLastError(), "shade_backward launch");
}

}  // namespace retimegs::cuda
