#pragma once
// model::slice and its backward on the GPU (model/slice.hpp): the primitives at time t as a batch
// of 3D Gaussians, with the same rows in the same order, the same cut and groups, and the same
// per-row math (model/slice_formulas.hpp, which the CPU's slice runs too). One thread per
// candidate row:
//   slice           select (group, min_opacity cut; the row list's order checked), an exclusive
//                   cub::DeviceScan of the kept flags, then one read back of the count (the
//                   batch's size) and one kernel that compacts and fills the rows
//   slice_backward  one thread per batch row; every primitive is in a batch at most once, so its
//                   gradient slots are written by one thread, without atomics
//   shade, shade_backward  one thread per listed row
// Outputs and scratch keep their allocations across calls.
//
//   cuda::DevicePrimitives p;  p.upload(primitives);
//   cuda::DeviceTimeSlice sliced;
//   cuda::slice(p, config, grid, t, camera, {}, sliced);           // sliced.gaussians, ...
//   cuda::rasterize_forward(sliced.gaussians, camera, ...);  ... rasterize_backward(..., v_g);
//   cuda::slice_backward(p, config, grid, t, camera, {}, sliced, v_g, grads);
#include <cstddef>
#include <cstdint>

#include "retimegs/core/camera.hpp"
#include "retimegs/cuda/buffer.hpp"
#include "retimegs/cuda/primitives.hpp"
#include "retimegs/cuda/rasterize.hpp"
#include "retimegs/model/primitives.hpp"
#include "retimegs/model/slice.hpp"

namespace retimegs::cuda {

// model::SliceOptions with the row list on the device.
struct DeviceSliceOptions {
  model::Group group = model::Group::kAll;
  bool compensate = false;
  bool flow_features = false;
  double min_opacity = 1.0 / 255.0;
  model::SeamSide side = model::SeamSide::kNone;
  double side_seam = 0;  // frames
  // The ascending rows to consider (device, row_count entries); nullptr: all rows.
  const std::int32_t* rows = nullptr;
  std::size_t row_count = 0;
};

// model::Shaded on the device: [N, 3] each, valid on the rows shade() was given.
struct DeviceShaded {
  DeviceBuffer<float> rgb, v_rgb;
};

// The selection's intermediates (one entry per candidate row).
struct DeviceSliceScratch {
  DeviceBuffer<std::int32_t> kept;     // [candidates + 1] 1 where selected, then a 0
  DeviceBuffer<std::int32_t> offsets;  // [candidates + 2] their exclusive sum; [candidates + 1]:
                                       // the first row list entry out of order (or INT32_MAX)
  DeviceBuffer<float> weight;          // [candidates] the σ_τ each selected row is drawn with
  DeviceBuffer<std::uint8_t> cub_storage;
};

// model::TimeSlice on the device.
struct DeviceTimeSlice {
  DeviceGaussians gaussians;                           // [M] channels 3 or 3 + kFlowChannels
  DeviceBuffer<std::int32_t> primitive_from_gaussian;  // [M]
  DeviceBuffer<float> temporal;                        // [M] σ_τ(t) as applied (1 compensated)
  DeviceSliceScratch scratch;

  std::size_t size() const { return primitive_from_gaussian.size(); }
};

// model::slice on the device: the batch in `out`. `shaded`, when given, holds the colours at
// (t, camera) of every row the batch can select. Throws Error as the CPU does (a group at a time
// that is not an interior/end training time, a row list out of order, a non-finite t). One host
// synchronisation (the batch's size).
void slice(const DevicePrimitives& primitives, const model::ModelConfig& config,
           const model::TimeGrid& grid, double t, const Camera& camera,
           const DeviceSliceOptions& options, DeviceTimeSlice& out,
           const DeviceShaded* shaded = nullptr);

// model::slice_backward on the device: accumulates (+=) into `grads` (sized to the primitives)
// the gradient of `v_gaussians` (the renderer's gradient of the batch `sliced`, with the same
// arguments as its slice). With `shaded` the colours' gradient is added into shaded->v_rgb. No
// host synchronisation.
void slice_backward(const DevicePrimitives& primitives, const model::ModelConfig& config,
                    const model::TimeGrid& grid, double t, const Camera& camera,
                    const DeviceSliceOptions& options, const DeviceTimeSlice& sliced,
                    const DeviceGaussianGrads& v_gaussians, DevicePrimitiveGrads& grads,
                    DeviceShaded* shaded = nullptr);

// model::slice_time_vjp on the device: d loss / d t of the batch `sliced` (slice's arguments)
// from the renderer's gradient `v_gaussians`, added (+=) into *sum (device), so that a step's
// passes accumulate before one copy to the host. Per-block partials (scratch `partials`) added in
// a fixed order: the same on every run. No host synchronisation.
void slice_time_sum(const DevicePrimitives& primitives, const model::ModelConfig& config,
                    const model::TimeGrid& grid, double t, const Camera& camera,
                    const DeviceSliceOptions& options, const DeviceTimeSlice& sliced,
                    const DeviceGaussianGrads& v_gaussians, double* sum,
                    DeviceBuffer<double>& partials);

// model::shade on the device: the SH colour at (t, camera) of each of the `count` ascending
// `rows` (device; nullptr: rows 0 .. count - 1) into out.rgb, zero into their out.v_rgb. `out`
// is sized to the primitives; its other rows keep their values unless that size changed.
void shade(const DevicePrimitives& primitives, const model::ModelConfig& config,
           const model::TimeGrid& grid, double t, const Camera& camera, const std::int32_t* rows,
           std::size_t count, DeviceShaded& out);

// model::shade_backward on the device: accumulates (+=) into `grads` the gradient of the rows'
// colours, shaded.v_rgb, through the SH and the view direction.
void shade_backward(const DevicePrimitives& primitives, const model::ModelConfig& config,
                    const model::TimeGrid& grid, double t, const Camera& camera,
                    const std::int32_t* rows, std::size_t count, const DeviceShaded& shaded,
                    DevicePrimitiveGrads& grads);

}  // namespace retimegs::cuda
