#include "retimegs/core/parallel.hpp"

#include <omp.h>

#include <atomic>
#include <exception>

#include "retimegs/core/error.hpp"

namespace retimegs {

void set_threads(int threads) {
  // Each OpenMP thread takes a stack and per-thread render buffers; far beyond the cores that
  // only costs memory (100 000 threads ran out of it).
  constexpr int kMaxThreads = 1024;
  if (threads < 0 || threads > kMaxThreads)
    fail("--threads: must lie in [0, {}] (0: all {} cores), got {}", kMaxThreads,
         omp_get_num_procs(), threads);
  omp_set_num_threads(threads == 0 ? omp_get_num_procs() : threads);
}

int max_threads() {
  return omp_get_max_threads();
}

void parallel_for(std::size_t n, const std::function<void(std::size_t)>& body) {
  std::exception_ptr error;
  std::atomic<bool> failed{false};
#pragma omp parallel for schedule(dynamic)
  for (std::size_t i = 0; i < n; ++i) {
    if (failed.load()) continue;
    try {
      body(i);
    } catch (...) {
#pragma omp critical(retimegs_parallel_for)
      if (!error) error = std::current_exception();
      failed = true;
    }
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace retimegs
