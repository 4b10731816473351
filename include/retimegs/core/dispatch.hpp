#pragma once
// A run-time count to a compile-time one, for kernels whose loops unroll over it (the blends'
// channel counts on both devices).

namespace retimegs {

// Calls f.template operator()<k>() with k = n when n is one of kCounts, else with k = 0 (the
// kernel's run-time loop).
template <int... kCounts, typename F>
void dispatch_count(int n, F&& f) {
  const bool compiled = ((n == kCounts ? (f.template operator()<kCounts>(), true) : false) || ...);
  if (!compiled) f.template operator()<0>();
}

}  // namespace retimegs
