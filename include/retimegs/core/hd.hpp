#pragma once
// Functions that both compilers build (DESIGN.md §3, "A second device: CUDA"): a formula marked
// RETIMEGS_HD is compiled for the GPU by nvcc and for the CPU by every compiler, so that the CPU
// backend, which CI tests, runs the same math as the CUDA kernels.
#if defined(__CUDACC__)
#define RETIMEGS_HD __host__ __device__
#else
#define RETIMEGS_HD
#endif
