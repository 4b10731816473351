#pragma once
// Which CUDA device this process can run on (DESIGN.md §3 "A second device: CUDA"). A plain C++
// header, built with or without CUDA: a build without it answers "built without CUDA", so that
// `--device auto` and the GPU tests ask one question everywhere.
#include <cstddef>
#include <optional>
#include <string>

namespace retimegs::cuda {

// The first GPU, as the CUDA runtime reports it.
struct DeviceInfo {
  std::string name;              // e.g. "NVIDIA H100 80GB HBM3"
  std::size_t total_memory = 0;  // bytes
  int multiprocessors = 0;
  int compute_major = 0;  // compute capability major.minor, e.g. 9.0 for Hopper
  int compute_minor = 0;
};

// The first GPU, or the reason why this process has none that runs this build's kernels.
struct DeviceQuery {
  std::optional<DeviceInfo> device;
  std::string reason;  // set when device is not: no driver, no device, built without CUDA, ...
  bool usable() const { return device.has_value(); }
};

// Never throws: a machine without a driver or a GPU is an answer, not an error. The first call
// creates the CUDA context of the first device.
DeviceQuery query_device();

// Where a command computes: `--device cpu|cuda|auto` of train, render and eval.
enum class Device { kCpu, kCuda };

// "cpu", "cuda" or "auto" (auto: cuda when this build has it and query_device() finds a usable
// GPU, else cpu). Throws Error naming the choice: an unknown word, or "cuda" where there is no
// usable GPU (with query_device()'s reason and the next step: --device cpu).
Device resolve_device(const std::string& choice);
// "cpu" or "cuda", as the log and the console name it; with the GPU's name for cuda.
std::string describe(Device device);

}  // namespace retimegs::cuda
