#pragma once
// The noise's draws computed on the device by train/noise_formulas.hpp's own functions
// (noise_draws.cu), for tests/cuda/test_strategy_cuda.cpp to compare with the host's.
#include <cstdint>
#include <vector>

namespace retimegs::test {

struct NoiseDraws {
  std::vector<double> uniforms;  // [rows, 4] noise_uniform(key, row, k)
  std::vector<float> normals;    // [rows, 3] normal3(key, row)
};

// The draws of each of `rows` under `key`, computed on the device.
NoiseDraws device_noise_draws(std::uint64_t key, const std::vector<std::int32_t>& rows);

}  // namespace retimegs::test
