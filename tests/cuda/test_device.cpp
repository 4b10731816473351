// The device query, the error check of CUDA calls and the device buffers' memory count
// (include/retimegs/cuda/).
#include <cstdlib>
#include <numeric>
#include <string>
#include <vector>

#include <cuda_runtime_api.h>
#include <gtest/gtest.h>

#include "cuda/require_gpu.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/cuda/buffer.hpp"
#include "retimegs/cuda/check.hpp"
#include "retimegs/cuda/device.hpp"

namespace retimegs::cuda {
namespace {

// What the machine has, asked of the driver's own tool rather than of the code under test.
bool nvidia_smi_lists_a_gpu() {
  return std::system("nvidia-smi -L 2>/dev/null | grep -q '^GPU '") == 0;
}

TEST(Device, QueryFindsTheGpuOrSaysWhyNot) {
  DeviceQuery query;
  ASSERT_NO_THROW(query = query_device());
  if (nvidia_smi_lists_a_gpu()) {
    ASSERT_TRUE(query.usable()) << query.reason;
    EXPECT_FALSE(query.device->name.empty());
    EXPECT_GT(query.device->total_memory, std::size_t{1} << 30);
    EXPECT_GT(query.device->multiprocessors, 0);
    EXPECT_GE(query.device->compute_major, 7);  // CUDA 13 runs Turing (7.5) and newer
    EXPECT_TRUE(query.reason.empty()) << query.reason;
  } else {
    EXPECT_FALSE(query.usable()) << query.device->name;
    EXPECT_FALSE(query.reason.empty());
  }
}

TEST(Check, SuccessPasses) {
  EXPECT_NO_THROW(check(cudaSuccess, "cudaMalloc(64 bytes)"));
}

TEST(Check, FailureNamesTheCallAndTheError) {
  try {
    check(cudaErrorMemoryAllocation, "cudaMalloc(64 bytes)");
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(),
                 "CUDA: cudaMalloc(64 bytes) failed: out of memory (cudaErrorMemoryAllocation)");
  }
}

TEST(Device, MemoryRoundTrip) {
  RETIMEGS_REQUIRE_GPU();
  std::vector<int> host(1 << 20);
  std::iota(host.begin(), host.end(), 7);
  const std::size_t bytes = host.size() * sizeof(int);
  void* device = nullptr;
  check(cudaMalloc(&device, bytes), "cudaMalloc");
  check(cudaMemcpy(device, host.data(), bytes, cudaMemcpyHostToDevice), "cudaMemcpy to device");
  check(cudaMemset(device, 0, bytes / 2), "cudaMemset");  // the first half's ints become 0
  std::vector<int> back(host.size(), -1);
  check(cudaMemcpy(back.data(), device, bytes, cudaMemcpyDeviceToHost), "cudaMemcpy to host");
  check(cudaFree(device), "cudaFree");
  for (std::size_t i = 0; i < back.size(); ++i)
    ASSERT_EQ(back[i], i < back.size() / 2 ? 0 : host[i]) << "at " << i;
}

TEST(Check, AFailedCallThrowsAndTheDeviceStaysUsable) {
  RETIMEGS_REQUIRE_GPU();
  void* device = nullptr;
  const std::size_t too_much = 4 * test::gpu().device->total_memory;
  try {
    check(cudaMalloc(&device, too_much), "cudaMalloc(4x the device's memory)");
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find("cudaMalloc(4x the device's memory) failed: out of memory"),
        std::string::npos)
        << e.what();
  }
  // The failure was read back: a later launch's check(cudaGetLastError()) does not see it.
  EXPECT_EQ(cudaGetLastError(), cudaSuccess);
  check(cudaMalloc(&device, 4096), "cudaMalloc(4096 bytes)");  // the failure is not sticky
  check(cudaFree(device), "cudaFree");
}

TEST(DeviceBuffer, CountsWhatItHoldsAndTheMostItHeld) {
  RETIMEGS_REQUIRE_GPU();
  const DeviceMemoryUse before = device_memory_use();
  constexpr std::size_t kMiB = std::size_t{1} << 20;
  {
    DeviceBuffer<float> a(kMiB / 4);
    EXPECT_EQ(device_memory_use().held, before.held + kMiB);
    a.resize(kMiB / 8);  // fits: the allocation stays
    EXPECT_EQ(device_memory_use().held, before.held + kMiB);
    a.resize_keep(kMiB / 2);  // the old and the new allocation both exist during the copy
    EXPECT_EQ(device_memory_use().held, before.held + 2 * kMiB);
    EXPECT_GE(device_memory_use().peak, before.held + 3 * kMiB);
    DeviceBuffer<float> b = std::move(a);  // a move is no new allocation
    EXPECT_EQ(device_memory_use().held, before.held + 2 * kMiB);
  }
  EXPECT_EQ(device_memory_use().held, before.held);
  EXPECT_GE(device_memory_use().peak, before.held + 3 * kMiB);
}

}  // namespace
}  // namespace retimegs::cuda
