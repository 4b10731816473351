#pragma once
// model::Primitives and model::PrimitiveGrads resident on the GPU: one DeviceBuffer per field,
// the host's [N, width] layouts and field order, so that a field's kernels index rows as the CPU
// does and a copy either way is one memcpy per field.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "retimegs/cuda/buffer.hpp"
#include "retimegs/model/primitives.hpp"

namespace retimegs::cuda {

struct DevicePrimitives {
  DeviceBuffer<float> mu, velocity, log_scale, q0, q1, sh, opacity_logit, mu_tau, tau_l, tau_r,
      temporal_log_scale;

  // Every field with its row width, in model::Primitives::fields() order.
  struct Field {
    const char* name;
    DeviceBuffer<float>* values;
    int width;
  };
  static constexpr int kFieldCount = model::Primitives::kFieldCount;
  std::array<Field, kFieldCount> fields();

  std::size_t size() const { return opacity_logit.size(); }
  // Copies every field in (the buffers keep their allocations where large enough). Throws Error
  // when a field's size disagrees with the row count.
  void upload(const model::Primitives& host);
  // Copies every field out into `host` (resized to size()).
  void download(model::Primitives& host) const;

  // Grows (the new rows zero, as model::Primitives::resize) or shrinks to n rows, the first rows
  // kept in every field.
  void resize(std::size_t n);
  // model::Primitives::reorder: row k of every field becomes old row old_from_new[k], for the
  // size() rows of old_from_new (device, int32, each in [0, size())). Throws Error unless
  // count == size().
  void reorder(const std::int32_t* old_from_new, std::size_t count);
  // The same from a host array.
  void reorder(const std::vector<std::int32_t>& old_from_new);
  // model::Primitives::copy_row for k in [0, count): row to[k] of every field takes row from[k]
  // (to, from: device, int32, in [0, size())). The to rows are distinct and none of them is a from
  // row (relocation's dead slots and growth's new rows take copies of live rows), so that the
  // copies' order does not matter.
  void copy_rows(const std::int32_t* to, const std::int32_t* from, std::size_t count);

 private:
  DeviceBuffer<float> scratch_;  // reorder's gather target, swapped field by field
};

struct DevicePrimitiveGrads {
  DeviceBuffer<float> v_mu, v_velocity, v_log_scale, v_q0, v_q1, v_sh, v_opacity_logit, v_mu_tau,
      v_temporal_log_scale;

  std::size_t size() const { return v_opacity_logit.size(); }
  // n rows, every value zero (the state between training steps).
  void resize_zero(std::size_t n);
  void download(model::PrimitiveGrads& host) const;
};

}  // namespace retimegs::cuda
