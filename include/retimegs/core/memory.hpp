#pragma once
// Memory for the rasteriser's large per-call arrays (tens of megabytes per render and per
// gradient, allocated and freed every training step).
#include <atomic>
#include <cstddef>
#include <cstring>
#include <new>
#include <utility>
#include <vector>

namespace retimegs {

// Keeps freed blocks of up to 32 MiB in the process heap instead of returning them to the kernel
// (glibc's mallopt; no effect elsewhere). By default glibc gives large freed blocks back (unmaps
// them, or trims the heap top), so every step of a render loop would fault its tens of megabytes
// back in, zeroed, a 4 KiB page at a time.
// Called once by the `retimegs` program and the benchmarks; memory stays at the peak of a step.
void keep_freed_memory();

// The process's peak resident memory so far, in bytes (getrusage's ru_maxrss).
std::size_t peak_rss_bytes();

namespace detail {
inline std::atomic<int> uninit_poison{-1};
}

// Tests only: fill every later UninitAllocator allocation with this byte (0xff: NaN floats, -1
// integers), so that an element that its writer leaves unset shows up; -1 (the default) leaves
// the memory as operator new returns it.
inline void set_uninit_poison(int byte) {
  detail::uninit_poison.store(byte);
}

// A std::vector whose resize() leaves trivially constructible elements unset, for arrays that
// their writer fills completely (or that are read only where written): value-initialising them
// is a serial pass over tens of megabytes per call.
template <typename T>
struct UninitAllocator {
  using value_type = T;
  static constexpr std::align_val_t kAlignment{alignof(T) > 64 ? alignof(T) : 64};  // cache line

  UninitAllocator() = default;
  template <typename U>
  UninitAllocator(const UninitAllocator<U>&) {}  // NOLINT: rebinding is implicit

  T* allocate(std::size_t n) {
    void* p = ::operator new(n * sizeof(T), kAlignment);
    if (const int byte = detail::uninit_poison.load(std::memory_order_relaxed); byte >= 0)
      std::memset(p, byte, n * sizeof(T));
    return static_cast<T*>(p);
  }
  void deallocate(T* p, std::size_t) noexcept { ::operator delete(p, kAlignment); }
  // Default-initialisation instead of value-initialisation.
  template <typename U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
  template <typename U>
  bool operator==(const UninitAllocator<U>&) const {
    return true;
  }
};

template <typename T>
using UninitVector = std::vector<T, UninitAllocator<T>>;

}  // namespace retimegs
