#pragma once
// train::Adam on the GPU (DESIGN.md §3 "A second device: CUDA"): one parameter group of rows of
// `width` floats, its moments resident on the device, stepped selectively over the step's active
// rows with the per-column learning-rate scale and the group's step count in the bias correction.
// Each value runs train/adam_update.hpp's adam_update, as train::Adam does: the same floats up to
// where the two compilers contract into fused multiply-adds, a few roundings of each term
// (tests/cuda/test_adam_cuda.cpp states the bound); rows outside the step keep every bit.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "retimegs/cuda/buffer.hpp"
#include "retimegs/train/adam_update.hpp"

namespace retimegs::train {
class Adam;
}  // namespace retimegs::train

namespace retimegs::cuda {

class DeviceAdam {
 public:
  DeviceAdam() = default;
  // Zero moments. column_scale [width] (optional) multiplies the learning rate per column.
  DeviceAdam(std::size_t rows, int width, train::AdamSettings settings = {},
             const std::vector<float>& column_scale = {});

  // train::Adam::step_and_clear: params -= lr · s_col · m̂ / (sqrt(v̂) + ε) over the rows
  // rows[0, count) (device, ascending int32, distinct), then those rows' gradients set to zero.
  // params and grads are device [rows(), width]. Every call advances the step count, an empty
  // row set's too, as on the CPU.
  void step_and_clear(float* params, float* grads, double lr, const std::int32_t* rows,
                      std::size_t count);
  // The same over every row.
  void step_and_clear(float* params, float* grads, double lr);
  // Zeroes the moments of rows[0, count) (device): their parameters were replaced.
  void reset_rows(const std::int32_t* rows, std::size_t count);
  // train::Adam::resize: grows (zero moments for the new rows) or shrinks to `rows` rows, the
  // first rows' moments kept.
  void resize(std::size_t rows);
  // train::Adam::reorder: row k's moments become old row old_from_new[k]'s, for the rows() rows of
  // old_from_new (device, int32, each in [0, rows())). Throws Error unless count == rows().
  void reorder(const std::int32_t* old_from_new, std::size_t count);

  // The whole state of a host group copied in: width, settings, column scales, moments and step
  // count (a step moving its optimiser to the GPU, e.g. on resume from a checkpoint).
  void assign(const train::Adam& host);
  // The moments and the step count copied out into `host` (its rows resized to rows()), a group
  // of the same width (checkpoints). Throws Error when the widths differ.
  void download(train::Adam& host) const;

  std::size_t rows() const { return width_ ? m_.size() / width_ : 0; }
  int width() const { return width_; }
  // State, for checkpoints: the moments [rows, width] and the step count.
  DeviceBuffer<float>& m() { return m_; }
  DeviceBuffer<float>& v() { return v_; }
  const DeviceBuffer<float>& m() const { return m_; }
  const DeviceBuffer<float>& v() const { return v_; }
  std::int64_t& step_count() { return steps_; }
  std::int64_t steps() const { return steps_; }

 private:
  int width_ = 0;
  train::AdamSettings settings_;
  DeviceBuffer<float> column_scale_;  // [width]
  DeviceBuffer<float> m_, v_;         // [rows, width]
  std::int64_t steps_ = 0;

  // rows == nullptr: the first `count` rows.
  void update(float* params, float* grads, double lr, const std::int32_t* rows, std::size_t count);
};

}  // namespace retimegs::cuda
