#pragma once
// The density strategy's per-step work on the GPU (train/strategy.hpp, DESIGN.md §3 "A second
// device: CUDA"): the 3DGS-MCMC noise on the step's active rows. Each row runs
// train/noise_formulas.hpp's noise_row, as train::inject_noise does: the same draws ε (integer
// and double arithmetic; sin, cos and log may round a double's last bit differently, which
// reaches a float rarely) and the same float steps, every multiply-add spelled out so that neither
// compiler fuses differently; exp may differ by an ulp in rare near-ties
// (tests/cuda/test_strategy_cuda.cpp states the bound).
#include <cstddef>
#include <cstdint>

#include "retimegs/cuda/primitives.hpp"
#include "retimegs/model/trajectory.hpp"

namespace retimegs::cuda {

// train::inject_noise on the device over rows[0, count) (device, int32, distinct): each row's mean
// moves by its noise under `key`, which the caller draws from its generator as the CPU does
// (key = rng(), one per call), so that a run draws the same numbers on either device.
void inject_noise(DevicePrimitives& primitives, const std::int32_t* rows, std::size_t count,
                  double lr_means, std::uint64_t key);

// train::apply's corrections of the drawn sources (train::correct_source) on the device: for k
// in [0, count), row rows[k] (distinct) takes opacity logit logits[k] and its three log scales
// move by shifts[k]. All three arrays on the device.
void correct_sources(DevicePrimitives& primitives, const std::int32_t* rows, const float* logits,
                     const float* shifts, std::size_t count);

// model::tie_end_velocities on rows[0, count) (device, int32), as the CPU step applies it.
void tie_end_velocities(DevicePrimitives& primitives, const std::int32_t* rows, std::size_t count,
                        const model::EndTie<float>& tie);

}  // namespace retimegs::cuda
