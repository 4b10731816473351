#include "retimegs/train/step.hpp"

#include "retimegs/core/error.hpp"
#include "retimegs/train/cpu_step.hpp"
#if RETIMEGS_HAS_CUDA
#include "retimegs/train/cuda_step.hpp"
#endif

namespace retimegs::train {

std::unique_ptr<TrainingStep> make_step(const TrainingSet& set, const TrainConfig& config,
                                        cuda::Device device) {
  if (device == cuda::Device::kCpu) return std::make_unique<CpuStep>(set, config);
#if RETIMEGS_HAS_CUDA
  return make_cuda_step(set, config);
#else
  fail(
      "training on the GPU: this build has no CUDA backend (rebuild where nvcc is found, or "
      "train with --device cpu)");
#endif
}

}  // namespace retimegs::train
