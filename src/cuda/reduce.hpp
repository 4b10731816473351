#pragma once
// Deterministic sums on the device, in two passes with no atomics: every block of a per-pixel
// kernel reduces its threads' values (block_sums) into one partial per block, and one block then
// adds the partials (finish_sums) and hands the totals to a functor. Both passes add in an order
// fixed by the launch shape, so a sum is the same on every run. Included by .cu files only.
#include <cub/block/block_reduce.cuh>

namespace retimegs::cuda {

// Threads of finish_sums' single block.
constexpr int kFinishThreads = 256;

// Sums values[k] over the kX × kY block; thread (0, 0) writes the K totals to
// partials[k · blocks + block]. Every thread of the block must call it.
template <int kX, int kY, int K>
__device__ void block_sums(const double (&values)[K], double* partials, int blocks, int block) {
  using Reduce = cub::BlockReduce<double, kX, cub::BLOCK_REDUCE_WARP_REDUCTIONS, kY>;
  __shared__ typename Reduce::TempStorage storage;
  for (int k = 0; k < K; ++k) {
    const double total = Reduce(storage).Sum(values[k]);
    if (threadIdx.x == 0 && threadIdx.y == 0) partials[k * blocks + block] = total;
    __syncthreads();  // the storage is reused by the next k
  }
}

// One block of kFinishThreads: the K totals of partials [K, blocks], passed to finish(totals) on
// thread 0.
template <int K, typename Finish>
__global__ void finish_sums(const double* partials, int blocks, Finish finish) {
  using Reduce = cub::BlockReduce<double, kFinishThreads>;
  __shared__ typename Reduce::TempStorage storage;
  double totals[K];
  for (int k = 0; k < K; ++k) {
    double sum = 0;
    for (int i = threadIdx.x; i < blocks; i += kFinishThreads) sum += partials[k * blocks + i];
    totals[k] = Reduce(storage).Sum(sum);
    __syncthreads();
  }
  if (threadIdx.x == 0) finish(totals);
}

}  // namespace retimegs::cuda
