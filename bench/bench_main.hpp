#pragma once
// The main of every Google Benchmark target here: as the retimegs program does, freed blocks stay
// in the heap between iterations, so a loop does not fault its large buffers back in each time.
#include <benchmark/benchmark.h>

#include "retimegs/core/memory.hpp"

#define RETIMEGS_BENCHMARK_MAIN()                                     \
  int main(int argc, char** argv) {                                   \
    retimegs::keep_freed_memory();                                    \
    benchmark::Initialize(&argc, argv);                               \
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1; \
    benchmark::RunSpecifiedBenchmarks();                              \
    benchmark::Shutdown();                                            \
    return 0;                                                         \
  }
