#pragma once
// A counter-based hash: random draws that are a function of their indices alone (a step, a row),
// so that they need no generator state, come out the same on both devices and after a resume.
#include <cstdint>

#include "retimegs/core/hd.hpp"

namespace retimegs {

// splitmix64's finaliser: a bijection of 64-bit words whose outputs pass as independent uniform
// bits for consecutive inputs.
RETIMEGS_HD inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace retimegs
