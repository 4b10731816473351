#pragma once
// One threading library across the project: OpenMP. `--threads` maps to set_threads().

namespace retimegs {

// 0 = all hardware threads.
void set_threads(int threads);
int max_threads();

}  // namespace retimegs
