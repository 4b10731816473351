#pragma once
// An array in GPU memory that owns its allocation (cudaMalloc / cudaFree), with copies to and from
// the host. resize() keeps the allocation while it is large enough, so that a loop that renders
// every step allocates only until its sizes settle; resize_keep() also keeps the contents.
// Every buffer's bytes count towards the process's device memory (device_memory_use): what
// training reports as the GPU memory it needed.
#include <cuda_runtime_api.h>

#include <atomic>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "retimegs/cuda/check.hpp"

namespace retimegs::cuda {

// Bytes held by all DeviceBuffers of the process: now, and the most at any time so far. The CUDA
// context and allocations outside DeviceBuffer are not counted.
struct DeviceMemoryUse {
  std::size_t held = 0, peak = 0;
};

namespace detail {
inline std::atomic<std::size_t> device_bytes_held{0}, device_bytes_peak{0};

inline void count_allocation(std::size_t bytes) {
  const std::size_t held = device_bytes_held.fetch_add(bytes) + bytes;
  std::size_t peak = device_bytes_peak.load();
  while (held > peak && !device_bytes_peak.compare_exchange_weak(peak, held)) {
  }
}
inline void count_release(std::size_t bytes) {
  device_bytes_held.fetch_sub(bytes);
}
}  // namespace detail

inline DeviceMemoryUse device_memory_use() {
  return {detail::device_bytes_held.load(), detail::device_bytes_peak.load()};
}

template <typename T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(std::size_t n) { resize(n); }
  ~DeviceBuffer() { release(); }
  DeviceBuffer(DeviceBuffer&& other) noexcept { swap(other); }
  DeviceBuffer& operator=(DeviceBuffer&& other) noexcept {
    DeviceBuffer(std::move(other)).swap(*this);
    return *this;
  }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;

  // n elements; the contents are unspecified after a resize that grows the allocation.
  void resize(std::size_t n) {
    if (n > capacity_) {
      release();
      const std::string what = "cudaMalloc(" + std::to_string(n * sizeof(T)) + " bytes)";
      check(cudaMalloc(reinterpret_cast<void**>(&data_), n * sizeof(T)), what.c_str());
      detail::count_allocation(n * sizeof(T));
      capacity_ = n;
    }
    size_ = n;
  }

  // n elements, the first min(n, size()) as they were, the rest unspecified. Where the allocation
  // is too small, a new one of exactly n takes a device-side copy of the old contents.
  void resize_keep(std::size_t n) {
    if (n > capacity_) {
      T* grown = nullptr;
      const std::string what = "cudaMalloc(" + std::to_string(n * sizeof(T)) + " bytes)";
      check(cudaMalloc(reinterpret_cast<void**>(&grown), n * sizeof(T)), what.c_str());
      detail::count_allocation(n * sizeof(T));
      if (size_ > 0) {
        const cudaError_t copied =
            cudaMemcpy(grown, data_, size_ * sizeof(T), cudaMemcpyDeviceToDevice);
        if (copied != cudaSuccess) {
          cudaFree(grown);
          detail::count_release(n * sizeof(T));
        }
        check(copied, "resize_keep copy");
      }
      const std::size_t kept = size_;
      release();
      data_ = grown;
      size_ = kept;
      capacity_ = n;
    }
    size_ = n;
  }

  // Copies host[0, n) in (resizing to n); synchronous.
  void upload(const T* host, std::size_t n) {
    resize(n);
    if (n > 0) check(cudaMemcpy(data_, host, n * sizeof(T), cudaMemcpyHostToDevice), "upload");
  }
  template <typename Vector>
  void upload(const Vector& host) {
    upload(host.data(), host.size());
  }
  // Copies the whole array out to host[0, size()); synchronous.
  void download(T* host) const {
    if (size_ > 0)
      check(cudaMemcpy(host, data_, size_ * sizeof(T), cudaMemcpyDeviceToHost), "download");
  }
  std::vector<T> download() const {
    std::vector<T> host(size_);
    download(host.data());
    return host;
  }
  // Every byte of elements [first, size()) set to `byte` (tests poison outputs with 0xff: every
  // float a NaN; 0 is +0.0 in every float).
  void fill_bytes(unsigned char byte, std::size_t first = 0) {
    if (size_ > first)
      check(cudaMemset(data_ + first, byte, (size_ - first) * sizeof(T)), "cudaMemset");
  }

  T* data() { return data_; }
  const T* data() const { return data_; }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

  void swap(DeviceBuffer& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(size_, other.size_);
    std::swap(capacity_, other.capacity_);
  }

 private:
  void release() {
    if (data_) {
      cudaFree(data_);  // only fails on a corrupted context, which the next call reports
      detail::count_release(capacity_ * sizeof(T));
    }
    data_ = nullptr;
    size_ = capacity_ = 0;
  }

  T* data_ = nullptr;
  std::size_t size_ = 0, capacity_ = 0;
};

}  // namespace retimegs::cuda
