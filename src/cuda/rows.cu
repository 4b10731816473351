// Row gathers and copies of [rows, width] arrays (rows.hpp): one thread per value.
#include <cuda_runtime.h>

#include "launch.hpp"
#include "retimegs/cuda/check.hpp"
#include "rows.hpp"

namespace retimegs::cuda {
namespace {

__global__ void __launch_bounds__(kThreads)
    gather_kernel(const float* in, float* out, int width, const std::int32_t* from,
                  std::size_t values) {
  const std::size_t at = std::size_t(blockIdx.x) * kThreads + threadIdx.x;
  if (at >= values) return;
  out[at] = in[std::size_t(from[at / width]) * width + at % width];
}

__global__ void __launch_bounds__(kThreads)
    copy_kernel(float* values, int width, const std::int32_t* to, const std::int32_t* from,
                std::size_t n) {
  const std::size_t at = std::size_t(blockIdx.x) * kThreads + threadIdx.x;
  if (at >= n) return;
  const std::size_t k = at / width, c = at % width;
  values[std::size_t(to[k]) * width + c] = values[std::size_t(from[k]) * width + c];
}

}  // namespace

void gather_rows(const float* in, float* out, int width, const std::int32_t* from,
                 std::size_t count) {
  const std::size_t values = count * std::size_t(width);
  if (values == 0) return;
  gather_kernel<<<blocks_for(values), kThreads>>>(in, out, width, from, values);
  check(cudaGetLastError(), "gather_kernel launch");
}

void copy_rows(float* values, int width, const std::int32_t* to, const std::int32_t* from,
               std::size_t count) {
  const std::size_t n = count * std::size_t(width);
  if (n == 0) return;
  copy_kernel<<<blocks_for(n), kThreads>>>(values, width, to, from, n);
  check(cudaGetLastError(), "copy_kernel launch");
}

}  // namespace retimegs::cuda
