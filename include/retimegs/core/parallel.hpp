#pragma once
// One threading library across the project: OpenMP. `--threads` maps to set_threads().
#include <cstddef>
#include <functional>

namespace retimegs {

// 0 = all hardware threads.
void set_threads(int threads);
int max_threads();

// Runs body(i) for every i in [0, n) on the OpenMP threads, dynamically scheduled (the loops this
// serves run coarse jobs of uneven cost: files, views). OpenMP cannot carry an exception out of a
// parallel region, so the first one thrown by any body(i) is kept, iterations not yet started are
// skipped, those already running finish, and the kept exception is rethrown unchanged (its own
// type and message) once every thread has stopped.
void parallel_for(std::size_t n, const std::function<void(std::size_t)>& body);

}  // namespace retimegs
