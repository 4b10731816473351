#pragma once
// The GPU tests' guard: every test of test_cuda that needs a device starts with it.
#include <gtest/gtest.h>

#include "retimegs/cuda/device.hpp"

namespace retimegs::test {

// Asked once per process: the first query creates the CUDA context.
inline const cuda::DeviceQuery& gpu() {
  static const cuda::DeviceQuery query = cuda::query_device();
  return query;
}

}  // namespace retimegs::test

// Skips the current test, with the reason, where this process has no usable CUDA device; ctest
// then reports it as skipped (tests/CMakeLists.txt).
#define RETIMEGS_REQUIRE_GPU()                                                     \
  do {                                                                             \
    if (!::retimegs::test::gpu().usable())                                         \
      GTEST_SKIP() << "no usable CUDA device: " << ::retimegs::test::gpu().reason; \
  } while (0)
