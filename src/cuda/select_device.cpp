// --device cpu|cuda|auto (include/retimegs/cuda/device.hpp), for builds with and without CUDA.
#include "retimegs/core/error.hpp"
#include "retimegs/cuda/device.hpp"

namespace retimegs::cuda {

Device resolve_device(const std::string& choice) {
  if (choice == "cpu") return Device::kCpu;
  if (choice != "cuda" && choice != "auto")
    fail("--device '{}': expected cpu, cuda or auto", choice);
  const DeviceQuery query = query_device();
  if (query.usable()) return Device::kCuda;
  if (choice == "auto") return Device::kCpu;
  fail("--device cuda: no usable GPU ({}); run with --device cpu (or auto)", query.reason);
}

std::string describe(Device device) {
  if (device == Device::kCpu) return "cpu";
  const DeviceQuery query = query_device();
  return query.usable() ? "cuda (" + query.device->name + ")" : "cuda";
}

}  // namespace retimegs::cuda
