// The MCMC noise on the device (cuda/strategy.hpp) against the CPU's: train::inject_noise is a
// loop of train/noise_formulas.hpp's noise_row over the rows, which the host side of these tests
// runs (the train library itself is not part of the GPU-only build). Both devices run the same
// float steps with every multiply-add spelled out, so most values agree to the bit; what may
// differ is the last bit of the library functions: exp (float, the device rounding from double),
// and log, sin, cos in double, which reach a float of ε only near a rounding tie.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "cuda/noise_draws.hpp"
#include "cuda/random_arrays.hpp"
#include "cuda/require_gpu.hpp"
#include "retimegs/cuda/primitives.hpp"
#include "retimegs/cuda/strategy.hpp"
#include "retimegs/model/primitives.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/train/noise_formulas.hpp"

namespace retimegs::cuda {
namespace {

// n primitives with every field random: opacities from faint (noise at full gate) to opaque
// (gated off), scales from e^-5 to e^0, rotations of any (unnormalised) quaternion.
model::Primitives random_primitives(std::size_t n, std::uint64_t seed) {
  model::Primitives p;
  p.resize(n);
  std::uint64_t s = seed;
  for (const auto& f : p.fields()) *f.values = test::random_floats(f.values->size(), -3, 3, ++s);
  p.opacity_logit = test::random_floats(n, -9.0f, 2.0f, ++s);
  p.log_scale = test::random_floats(3 * n, -5.0f, 0.0f, ++s);
  p.q0 = test::random_floats(4 * n, -1.0f, 1.0f, ++s);
  return p;
}

TEST(NoiseCuda, DrawsMatchTheHost) {
  RETIMEGS_REQUIRE_GPU();
  const std::vector<std::int32_t> rows = test::random_rows(20000, 0.5, 3);
  const std::uint64_t key = std::mt19937_64(17)();
  const test::NoiseDraws device = test::device_noise_draws(key, rows);
  ASSERT_EQ(device.uniforms.size(), 4 * rows.size());
  std::size_t differing = 0;
  for (std::size_t j = 0; j < rows.size(); ++j) {
    // The uniforms are integer arithmetic and an exact conversion: equal to the bit.
    for (int k = 0; k < 4; ++k)
      ASSERT_EQ(device.uniforms[4 * j + k], train::noise_uniform(key, rows[j], k))
          << "row " << rows[j] << " uniform " << k;
    float eps[3];
    train::normal3(key, rows[j], eps);
    for (int a = 0; a < 3; ++a) {
      // From the same doubles through log, sqrt, sin, cos: the devices' libraries round a double's
      // last bit their own way, which changes the float only next to a rounding tie: 1 ulp.
      const std::int64_t d = test::ulps(device.normals[3 * j + a], eps[a]);
      ASSERT_LE(d, 1) << "row " << rows[j] << " eps " << a << ": " << device.normals[3 * j + a]
                      << " vs " << eps[a];
      differing += d != 0;
    }
  }
  std::printf("[ measured ] noise draws: %zu of %zu normal values differ by an ulp\n", differing,
              3 * rows.size());
}

TEST(NoiseCuda, InjectNoiseMatchesTheCpuRowByRow) {
  RETIMEGS_REQUIRE_GPU();
  const std::size_t n = 30011;
  const model::Primitives before = random_primitives(n, 5);
  const std::vector<std::int32_t> rows = test::random_rows(n, 0.6, 6);
  const std::uint64_t key = std::mt19937_64(7)();
  const double lr_means = 1.6e-4 * 2.5;  // lr_means times a scene extent

  model::Primitives host = before;
  for (const std::int32_t r : rows)
    train::noise_row(key, std::uint64_t(r), lr_means, host.opacity_logit[r], &host.q0[4 * r],
                     &host.log_scale[3 * r], &host.mu[3 * r]);

  DevicePrimitives device;
  device.upload(before);
  DeviceBuffer<std::int32_t> d_rows;
  d_rows.upload(rows);
  inject_noise(device, d_rows.data(), rows.size(), lr_means, key);
  model::Primitives got;
  device.download(got);

  // Every field but mu keeps every bit, and so do the means of rows outside the set.
  const auto want_fields = before.fields();
  const auto got_fields = got.fields();
  for (int f = 0; f < model::Primitives::kFieldCount; ++f) {
    if (want_fields[f].values == &before.mu) continue;
    ASSERT_EQ(*got_fields[f].values, *want_fields[f].values) << want_fields[f].name;
  }
  std::vector<bool> in_set(n, false);
  for (const std::int32_t r : rows) in_set[r] = true;
  std::size_t moved = 0, gated = 0, identical = 0;
  double worst = 0;  // of |device − host| / bound
  for (std::size_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      const float g = got.mu[3 * i + a], h = host.mu[3 * i + a];
      if (!in_set[i]) {
        ASSERT_EQ(test::ulps(g, before.mu[3 * i + a]), 0) << "row " << i << " is not in the set";
        continue;
      }
      // The bound: the last roundings of mu + k·δ (2 ulps of the result), and the library
      // functions' last bits (ε, e^{2s}, the gate) carried through R diag(s²) Rᵀ ε at a few
      // roundings of the magnitude M = Σ_j |r_aj| s²_j Σ_k |r_kj| |ε_k| of each term.
      float eps[3], r[9];
      train::normal3(key, i, eps);
      train::noise_rotation(&before.q0[4 * i], r);
      double m = 0;
      for (int j = 0; j < 3; ++j) {
        double inner = 0;
        for (int k = 0; k < 3; ++k) inner += std::abs(double(r[3 * k + j])) * std::abs(eps[k]);
        m += std::abs(double(r[3 * a + j])) * std::exp(2.0 * before.log_scale[3 * i + j]) * inner;
      }
      const double sigma = model::sigmoid<double>(before.opacity_logit[i]);
      const double gate =
          model::sigmoid(-train::kNoiseSharpness * (sigma - train::kNoiseThreshold));
      const double k = gate * lr_means * train::kNoiseScale;
      const double bound = 2 * FLT_EPSILON * std::abs(h) + 8 * FLT_EPSILON * k * m;
      const double d = std::abs(double(g) - double(h));
      ASSERT_LE(d, bound) << "row " << i << " axis " << a << ": " << g << " vs " << h << " (before "
                          << before.mu[3 * i + a] << ")";
      if (bound > 0) worst = std::max(worst, d / bound);
      identical += test::ulps(g, h) == 0;
      if (a == 0) {
        moved += h != before.mu[3 * i];
        gated += gate < train::kNoiseMinGate;
      }
    }
  }
  // Both kinds of rows are there: moved by the noise, and opaque ones the gate leaves alone.
  EXPECT_GT(moved, rows.size() / 4);
  EXPECT_GT(gated, rows.size() / 10);
  std::printf(
      "[ measured ] noise: %zu of %zu means bit-identical, worst difference %.3f of its bound\n",
      identical, 3 * rows.size(), worst);
}

TEST(NoiseCuda, NoRowsChangesNothing) {
  RETIMEGS_REQUIRE_GPU();
  const model::Primitives before = random_primitives(100, 9);
  DevicePrimitives device;
  device.upload(before);
  inject_noise(device, nullptr, 0, 1e-3, 42);
  model::Primitives got;
  device.download(got);
  EXPECT_EQ(got.mu, before.mu);
}

}  // namespace
}  // namespace retimegs::cuda
