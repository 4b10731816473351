#pragma once
// Wall-clock time of a stretch of code, for the stage breakdowns of benchmarks and logs.
#include <chrono>

namespace retimegs {

class Stopwatch {
 public:
  // Seconds since construction or the previous lap, and restarts.
  double lap() {
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - start_).count();
    start_ = now;
    return seconds;
  }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace retimegs
