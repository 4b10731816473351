#pragma once
// A std::vector whose resize() leaves trivially constructible elements unset, for the large
// per-call arrays of the rasteriser that their writer fills completely (or reads only where it
// wrote): value-initialising them is a serial pass over tens of megabytes per call.
#include <cstddef>
#include <new>
#include <utility>
#include <vector>

namespace retimegs {

template <typename T>
struct UninitAllocator {
  using value_type = T;
  static constexpr std::align_val_t kAlignment{alignof(T) > 64 ? alignof(T) : 64};  // cache line

  UninitAllocator() = default;
  template <typename U>
  UninitAllocator(const UninitAllocator<U>&) {}  // NOLINT: rebinding is implicit

  T* allocate(std::size_t n) { return static_cast<T*>(::operator new(n * sizeof(T), kAlignment)); }
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
