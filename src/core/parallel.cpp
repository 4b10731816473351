#include "retimegs/core/parallel.hpp"

#include <omp.h>

#include "retimegs/core/error.hpp"

namespace retimegs {

void set_threads(int threads) {
  if (threads < 0) fail("--threads: must be >= 0, got {}", threads);
  omp_set_num_threads(threads == 0 ? omp_get_num_procs() : threads);
}

int max_threads() {
  return omp_get_max_threads();
}

}  // namespace retimegs
