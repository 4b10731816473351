// The device query of a build without the CUDA backend (no nvcc at configure time, or
// -DRETIMEGS_CUDA=OFF): there is never a device to run on.
#include "retimegs/cuda/device.hpp"

namespace retimegs::cuda {

DeviceQuery query_device() {
  return {std::nullopt,
          "built without CUDA (no nvcc when it was configured, or -DRETIMEGS_CUDA=OFF)"};
}

}  // namespace retimegs::cuda
