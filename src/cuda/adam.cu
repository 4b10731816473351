// Selective Adam on the device (include/retimegs/cuda/adam.hpp): one thread per value of the
// stepped rows, each running train::adam_update with the step's constants.
#include <cuda_runtime.h>

#include "launch.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/cuda/adam.hpp"
#include "retimegs/cuda/check.hpp"
#include "retimegs/train/adam.hpp"
#include "rows.hpp"

namespace retimegs::cuda {
namespace {

// Value j · width + k of the stepped set is column k of row rows[j] (row j when rows is null).
__global__ void __launch_bounds__(kThreads)
    adam_kernel(train::AdamStepConstants constants, const float* column_scale, int width,
                const std::int32_t* rows, std::size_t values, float* params, float* grads, float* m,
                float* v) {
  const std::size_t at = std::size_t(blockIdx.x) * kThreads + threadIdx.x;
  if (at >= values) return;
  const std::size_t j = at / width;
  const int k = int(at % width);
  const std::size_t i = (rows ? std::size_t(rows[j]) : j) * width + k;
  train::adam_update(constants, column_scale[k], grads[i], params[i], m[i], v[i]);
  grads[i] = 0;
}

__global__ void __launch_bounds__(kThreads)
    reset_kernel(int width, const std::int32_t* rows, std::size_t values, float* m, float* v) {
  const std::size_t at = std::size_t(blockIdx.x) * kThreads + threadIdx.x;
  if (at >= values) return;
  const std::size_t i = std::size_t(rows[at / width]) * width + at % width;
  m[i] = v[i] = 0;
}

}  // namespace

DeviceAdam::DeviceAdam(std::size_t rows, int width, train::AdamSettings settings,
                       const std::vector<float>& column_scale)
    : width_(width), settings_(settings) {
  if (width <= 0) fail("Adam on the device: width {} (a row needs at least one value)", width);
  if (!column_scale.empty() && column_scale.size() != std::size_t(width))
    fail("Adam on the device: {} column scales for rows of width {}", column_scale.size(), width);
  column_scale_.upload(column_scale.empty() ? std::vector<float>(width, 1.0f) : column_scale);
  m_.resize(rows * width);
  v_.resize(rows * width);
  m_.fill_bytes(0);  // all-zero bytes: +0.0f
  v_.fill_bytes(0);
}

void DeviceAdam::step_and_clear(float* params, float* grads, double lr, const std::int32_t* rows,
                                std::size_t count) {
  if (count > 0 && !rows) fail("Adam on the device: {} rows to step but no row list", count);
  update(params, grads, lr, rows, count);
}

void DeviceAdam::step_and_clear(float* params, float* grads, double lr) {
  update(params, grads, lr, nullptr, rows());
}

void DeviceAdam::update(float* params, float* grads, double lr, const std::int32_t* rows,
                        std::size_t count) {
  const train::AdamStepConstants constants = train::adam_step_constants(settings_, lr, ++steps_);
  const std::size_t values = count * width_;
  if (values == 0) return;
  adam_kernel<<<blocks_for(values), kThreads>>>(constants, column_scale_.data(), width_, rows,
                                                values, params, grads, m_.data(), v_.data());
  check(cudaGetLastError(), "adam_kernel launch");
}

void DeviceAdam::reset_rows(const std::int32_t* rows, std::size_t count) {
  const std::size_t values = count * width_;
  if (values == 0) return;
  reset_kernel<<<blocks_for(values), kThreads>>>(width_, rows, values, m_.data(), v_.data());
  check(cudaGetLastError(), "reset_kernel launch");
}

void DeviceAdam::resize(std::size_t rows) {
  const std::size_t kept = m_.size(), values = rows * width_;
  m_.resize_keep(values);
  v_.resize_keep(values);
  m_.fill_bytes(0, kept);  // the new rows, if any
  v_.fill_bytes(0, kept);
}

void DeviceAdam::reorder(const std::int32_t* old_from_new, std::size_t count) {
  if (count != rows()) fail("Adam on the device: reorder of {} rows by {} indices", rows(), count);
  for (DeviceBuffer<float>* moments : {&m_, &v_}) {
    DeviceBuffer<float> moved(moments->size());
    gather_rows(moments->data(), moved.data(), width_, old_from_new, count);
    moments->swap(moved);
  }
}

void DeviceAdam::assign(const train::Adam& host) {
  if (host.width() <= 0)
    fail("Adam on the device: the host group has width {} (not built)", host.width());
  width_ = host.width();
  settings_ = host.settings();
  column_scale_.upload(host.column_scale());
  m_.upload(host.m());
  v_.upload(host.v());
  steps_ = host.steps();
}

void DeviceAdam::download(train::Adam& host) const {
  if (host.width() != width_)
    fail("Adam on the device: download of rows of width {} into a host group of width {}", width_,
         host.width());
  host.m() = m_.download();
  host.v() = v_.download();
  host.step_count() = steps_;
}

}  // namespace retimegs::cuda
