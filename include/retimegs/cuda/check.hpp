#pragma once
// Errors of CUDA runtime calls as retimegs::Error. Needs the CUDA runtime's headers, which only
// the CUDA build has (retimegs::cuda links them when RETIMEGS_HAS_CUDA).
#include <cuda_runtime_api.h>

namespace retimegs::cuda {

// Throws retimegs::Error "CUDA: <what> failed: <error text> (<error name>)" unless status is
// cudaSuccess. `what` names the call and what it was asked for, e.g. "cudaMalloc(4096 bytes)";
// after a kernel launch, check(cudaGetLastError(), "blend_forward launch").
void check(cudaError_t status, const char* what);

}  // namespace retimegs::cuda
