#pragma once
// Inputs and comparisons of the GPU tests: random arrays (never all zero) and row subsets, an
// image's first channels, and the distance of two floats in units in the last place.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "retimegs/core/image.hpp"

namespace retimegs::test {

// n values uniform in [lo, hi) (lo < hi, so not all zero).
inline std::vector<float> random_floats(std::size_t n, float lo, float hi, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  std::vector<float> out(n);
  for (float& v : out) v = u(rng);
  return out;
}

// An ascending random subset of [0, n), about `fraction` of it.
inline std::vector<std::int32_t> random_rows(std::size_t n, double fraction, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::bernoulli_distribution take(fraction);
  std::vector<std::int32_t> rows;
  for (std::size_t r = 0; r < n; ++r)
    if (take(rng)) rows.push_back(std::int32_t(r));
  return rows;
}

// The first `channels` channels of an image.
inline Image first_channels(const Image& image, int channels) {
  Image out(image.width, image.height, channels);
  for (std::size_t p = 0; p < image.pixels(); ++p)
    for (int c = 0; c < channels; ++c)
      out.data[p * channels + c] = image.data[p * image.channels + c];
  return out;
}

// How many floats lie between a and b (0: the same value; NaN against anything: the maximum).
inline std::int64_t ulps(float a, float b) {
  if (std::isnan(a) || std::isnan(b)) return std::numeric_limits<std::int64_t>::max();
  const auto ordered = [](float f) {
    std::int32_t i;
    std::memcpy(&i, &f, sizeof i);
    return i < 0 ? std::int64_t(std::numeric_limits<std::int32_t>::min()) - i : std::int64_t(i);
  };
  const std::int64_t d = ordered(a) - ordered(b);
  return d < 0 ? -d : d;
}

}  // namespace retimegs::test
