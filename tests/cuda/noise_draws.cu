// The noise's draws on the device (noise_draws.hpp): one thread per row.
#include <cuda_runtime.h>

#include "cuda/noise_draws.hpp"
#include "retimegs/cuda/buffer.hpp"
#include "retimegs/cuda/check.hpp"
#include "retimegs/train/noise_formulas.hpp"

namespace retimegs::test {
namespace {

__global__ void draws_kernel(std::uint64_t key, const std::int32_t* rows, std::size_t count,
                             double* uniforms, float* normals) {
  const std::size_t j = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (j >= count) return;
  const std::uint64_t row = std::uint64_t(rows[j]);
  for (int k = 0; k < 4; ++k) uniforms[4 * j + k] = train::noise_uniform(key, row, k);
  float eps[3];
  train::normal3(key, row, eps);
  for (int a = 0; a < 3; ++a) normals[3 * j + a] = eps[a];
}

}  // namespace

NoiseDraws device_noise_draws(std::uint64_t key, const std::vector<std::int32_t>& rows) {
  cuda::DeviceBuffer<std::int32_t> d_rows;
  d_rows.upload(rows);
  cuda::DeviceBuffer<double> uniforms(4 * rows.size());
  cuda::DeviceBuffer<float> normals(3 * rows.size());
  uniforms.fill_bytes(0xff);  // poisoned: NaN wherever the kernel does not write
  normals.fill_bytes(0xff);
  if (!rows.empty()) {
    draws_kernel<<<int((rows.size() + 255) / 256), 256>>>(key, d_rows.data(), rows.size(),
                                                          uniforms.data(), normals.data());
    cuda::check(cudaGetLastError(), "draws_kernel launch");
  }
  return {uniforms.download(), normals.download()};
}

}  // namespace retimegs::test
