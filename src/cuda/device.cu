// The device query and the error check of CUDA runtime calls.
#include <cuda_runtime.h>

#include <fmt/format.h>

#include "retimegs/core/error.hpp"
#include "retimegs/cuda/check.hpp"
#include "retimegs/cuda/device.hpp"

namespace retimegs::cuda {
namespace {

// Does nothing: asking for its attributes loads this build's code onto the device, which fails
// where the build holds no code for the GPU's compute capability.
__global__ void probe_kernel() {}

std::string error_text(cudaError_t status) {
  return fmt::format("{} ({})", cudaGetErrorString(status), cudaGetErrorName(status));
}

// CUDA versions are encoded as 1000 * major + 10 * minor.
std::string version_text(int version) {
  return fmt::format("{}.{}", version / 1000, version % 1000 / 10);
}

DeviceQuery no_device(std::string reason) {
  cudaGetLastError();  // a failed query must not surface as the error of a later call
  return {std::nullopt, std::move(reason)};
}

}  // namespace

void check(cudaError_t status, const char* what) {
  if (status == cudaSuccess) return;
  // A failed call also leaves its error as the thread's last error: read it back here, so that a
  // later launch's check(cudaGetLastError(), ...) does not report this failure as its own.
  // (Sticky errors, which end the context, stay whatever is read.)
  cudaGetLastError();
  fail("CUDA: {} failed: {}", what, error_text(status));
}

DeviceQuery query_device() {
  int driver = 0;  // 0 where no driver is installed
  int runtime = 0;
  cudaDriverGetVersion(&driver);
  cudaRuntimeGetVersion(&runtime);
  if (driver == 0) return no_device("no NVIDIA driver (libcuda) found");
  int count = 0;
  const cudaError_t counted = cudaGetDeviceCount(&count);
  if (counted == cudaErrorInsufficientDriver)
    return no_device(fmt::format("the NVIDIA driver runs CUDA {}, this build needs CUDA {}",
                                 version_text(driver), version_text(runtime)));
  if (counted == cudaErrorNoDevice || (counted == cudaSuccess && count == 0))
    return no_device("no CUDA device");
  if (counted != cudaSuccess)
    return no_device(fmt::format("no CUDA device: cudaGetDeviceCount: {}", error_text(counted)));

  cudaDeviceProp properties{};
  const cudaError_t described = cudaGetDeviceProperties(&properties, 0);
  if (described != cudaSuccess)
    return no_device(fmt::format("cudaGetDeviceProperties(0): {}", error_text(described)));
  DeviceInfo info{properties.name, properties.totalGlobalMem, properties.multiProcessorCount,
                  properties.major, properties.minor};

  cudaFuncAttributes attributes{};
  const cudaError_t loaded = cudaFuncGetAttributes(&attributes, probe_kernel);
  if (loaded == cudaErrorNoKernelImageForDevice || loaded == cudaErrorInvalidDeviceFunction)
    return no_device(fmt::format(
        "{} (compute capability {}.{}) runs none of this build's code (CUDA architectures {}): "
        "configure with -DCMAKE_CUDA_ARCHITECTURES={}{}",
        info.name, info.compute_major, info.compute_minor, RETIMEGS_CUDA_ARCHITECTURES,
        info.compute_major, info.compute_minor));
  if (loaded != cudaSuccess)
    return no_device(
        fmt::format("{}: loading this build's code failed: {}", info.name, error_text(loaded)));
  return {std::move(info), ""};
}

}  // namespace retimegs::cuda
