#pragma once
// What the backend's kernels share at launch: the block size of the one-thread-per-item kernels,
// their grid size, and CUB's two-call temporary storage.
#include <cstddef>
#include <cstdint>

#include "retimegs/cuda/buffer.hpp"
#include "retimegs/cuda/check.hpp"

namespace retimegs::cuda {

constexpr int kThreads = 256;  // per block of a kernel with one thread per item

// Blocks of kThreads for n items.
inline unsigned blocks_for(std::size_t n) {
  return unsigned((n + kThreads - 1) / kThreads);
}

// CUB's temporary storage for one call: asks for the size, grows `storage`, runs.
template <typename F>
void with_cub_storage(DeviceBuffer<std::uint8_t>& storage, const char* what, F&& run) {
  std::size_t bytes = 0;
  check(run(nullptr, bytes), what);
  storage.resize(bytes);
  check(run(storage.data(), bytes), what);
}

}  // namespace retimegs::cuda
