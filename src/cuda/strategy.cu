// The MCMC noise, the relocation's corrections and the end velocities' tie on the device
// (include/retimegs/cuda/strategy.hpp): one thread per row.
#include <cuda_runtime.h>

#include "launch.hpp"
#include "retimegs/cuda/check.hpp"
#include "retimegs/cuda/strategy.hpp"
#include "retimegs/train/noise_formulas.hpp"
#include "retimegs/train/relocation.hpp"

namespace retimegs::cuda {
namespace {

__global__ void __launch_bounds__(kThreads)
    noise_kernel(const std::int32_t* rows, std::size_t count, double lr_means, std::uint64_t key,
                 const float* opacity_logit, const float* q0, const float* log_scale, float* mu) {
  const std::size_t j = std::size_t(blockIdx.x) * kThreads + threadIdx.x;
  if (j >= count) return;
  const std::size_t i = std::size_t(rows[j]);
  train::noise_row(key, i, lr_means, opacity_logit[i], q0 + 4 * i, log_scale + 3 * i, mu + 3 * i);
}

__global__ void __launch_bounds__(kThreads)
    tie_kernel(const std::int32_t* rows, std::size_t count, model::EndTie<float> tie,
               const float* mu_tau, float* velocity) {
  const std::size_t j = std::size_t(blockIdx.x) * kThreads + threadIdx.x;
  if (j >= count) return;
  const std::size_t i = std::size_t(rows[j]);
  model::tie_end_velocities(tie, mu_tau[i], velocity + 9 * i);
}

__global__ void __launch_bounds__(kThreads)
    correct_kernel(const std::int32_t* rows, std::size_t count, const float* logits,
                   const float* shifts, float* opacity_logit, float* log_scale) {
  const std::size_t k = std::size_t(blockIdx.x) * kThreads + threadIdx.x;
  if (k >= count) return;
  const std::size_t i = std::size_t(rows[k]);
  train::correct_source(logits[k], shifts[k], opacity_logit[i], log_scale + 3 * i);
}

}  // namespace

void correct_sources(DevicePrimitives& p, const std::int32_t* rows, const float* logits,
                     const float* shifts, std::size_t count) {
  if (count == 0) return;
  correct_kernel<<<blocks_for(count), kThreads>>>(rows, count, logits, shifts,
                                                  p.opacity_logit.data(), p.log_scale.data());
  check(cudaGetLastError(), "correct_kernel launch");
}

void tie_end_velocities(DevicePrimitives& p, const std::int32_t* rows, std::size_t count,
                        const model::EndTie<float>& tie) {
  if (count == 0) return;
  tie_kernel<<<blocks_for(count), kThreads>>>(rows, count, tie, p.mu_tau.data(), p.velocity.data());
  check(cudaGetLastError(), "tie_kernel launch");
}

void inject_noise(DevicePrimitives& p, const std::int32_t* rows, std::size_t count, double lr_means,
                  std::uint64_t key) {
  if (count == 0) return;
  noise_kernel<<<blocks_for(count), kThreads>>>(rows, count, lr_means, key, p.opacity_logit.data(),
                                                p.q0.data(), p.log_scale.data(), p.mu.data());
  check(cudaGetLastError(), "noise_kernel launch");
}

}  // namespace retimegs::cuda
