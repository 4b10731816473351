// Selective Adam on the device (cuda/adam.hpp) against the CPU's update (train::Adam's loop over
// train/adam_update.hpp) from the same state: equal up to the roundings the two compilers may fuse
// away (kRoundings of each term), the rows outside the step untouched to the bit.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "cuda/random_arrays.hpp"
#include "cuda/require_gpu.hpp"
#include "retimegs/cuda/adam.hpp"
#include "retimegs/train/adam_update.hpp"

namespace retimegs::cuda {
namespace {

// Roundings of a term that one device may skip by fusing a multiply into an add, with margin.
constexpr double kRoundings = 4;

// A group's state on the host.
struct State {
  std::vector<float> params, grads, m, v;
};

// What train::Adam::step_and_clear does, over `rows` (nullptr: every row).
void host_step(State& s, int width, const std::vector<float>& scale,
               const train::AdamStepConstants& k, const std::vector<std::int32_t>* rows) {
  const std::size_t count = rows ? rows->size() : s.m.size() / width;
  for (std::size_t j = 0; j < count; ++j) {
    const std::size_t r = rows ? std::size_t((*rows)[j]) : j;
    for (int c = 0; c < width; ++c) {
      const std::size_t i = r * width + c;
      train::adam_update(k, scale[c], s.grads[i], s.params[i], s.m[i], s.v[i]);
      s.grads[i] = 0;
    }
  }
}

// How far the device may be from the host in m, v and the parameter of value i after a step
// from `before`: each term's roundings, and the update's share of the moments' error.
struct Bounds {
  double m, v, param;
};

Bounds bounds(const State& before, const State& after, std::size_t i, float scale,
              const train::AdamStepConstants& k) {
  const double eps = kRoundings * FLT_EPSILON;
  const double g = before.grads[i];
  Bounds b;
  b.m = eps * (std::abs(k.b1 * before.m[i]) + std::abs(k.one_minus_b1 * g));
  b.v = eps * (k.b2 * before.v[i] + k.one_minus_b2 * g * g);
  const double den = std::sqrt(double(after.v[i])) * k.inv_sqrt_c2 + k.eps;
  const double update = double(k.step_size) * scale * after.m[i] / den;
  b.param = eps * (std::abs(after.params[i]) + std::abs(update)) +
            double(k.step_size) * scale * b.m / den + std::abs(update) * b.v / (2 * after.v[i]);
  return b;
}

// Steps of a group whose moments hold state, over changing row sets (a sparse set, every row, an
// empty set, a dense set) at changing rates. Each step starts both devices from the host's state.
void check_steps(std::size_t n, int width, const std::vector<float>& column_scale,
                 std::uint64_t seed) {
  const std::size_t values = n * width;
  const std::vector<float> scale =
      column_scale.empty() ? std::vector<float>(width, 1.0f) : column_scale;
  State host{test::random_floats(values, -2.0f, 2.0f, seed),
             {},
             test::random_floats(values, -0.1f, 0.1f, seed + 1),
             test::random_floats(values, 0.0f, 0.01f, seed + 2)};
  DeviceAdam adam(n, width, {}, column_scale);
  adam.step_count() = 7;  // the bias correction of a group that has stepped before
  std::int64_t steps = adam.steps();

  const std::vector<std::vector<std::int32_t>> sets = {
      test::random_rows(n, 0.3, seed + 3), {}, {}, test::random_rows(n, 0.9, seed + 4)};
  const bool every_row[] = {false, true, false, false};
  const double rates[] = {1.6e-4, 5e-3, 1e-3, 2.5e-2};
  double worst = 0;  // of |device − host| / bound
  for (int s = 0; s < 4; ++s) {
    SCOPED_TRACE(testing::Message() << "step " << s << " of width " << width);
    host.grads = test::random_floats(values, -1.0f, 1.0f, seed + 10 + s);
    DeviceBuffer<float> d_params, d_grads;
    d_params.upload(host.params);
    d_grads.upload(host.grads);
    adam.m().upload(host.m);
    adam.v().upload(host.v);
    DeviceBuffer<std::int32_t> d_rows;
    d_rows.upload(sets[s]);
    const std::vector<std::int32_t>* rows = every_row[s] ? nullptr : &sets[s];

    const State before = host;
    const train::AdamStepConstants k = train::adam_step_constants({}, rates[s], ++steps);
    host_step(host, width, scale, k, rows);
    if (rows)
      adam.step_and_clear(d_params.data(), d_grads.data(), rates[s], d_rows.data(), rows->size());
    else
      adam.step_and_clear(d_params.data(), d_grads.data(), rates[s]);
    ASSERT_EQ(adam.steps(), steps);

    const State device{d_params.download(), d_grads.download(), adam.m().download(),
                       adam.v().download()};
    std::vector<bool> stepped(n, rows == nullptr);
    if (rows)
      for (const std::int32_t r : *rows) stepped[r] = true;
    for (std::size_t i = 0; i < values; ++i) {
      if (!stepped[i / width]) {  // untouched: every bit as before
        ASSERT_EQ(test::ulps(device.params[i], before.params[i]), 0) << "param " << i;
        ASSERT_EQ(test::ulps(device.m[i], before.m[i]), 0) << "m " << i;
        ASSERT_EQ(test::ulps(device.v[i], before.v[i]), 0) << "v " << i;
        ASSERT_EQ(test::ulps(device.grads[i], before.grads[i]), 0) << "grad " << i;
        continue;
      }
      ASSERT_EQ(device.grads[i], 0.0f) << "grad " << i << " not cleared";
      const Bounds b = bounds(before, host, i, scale[i % width], k);
      const double dm = std::abs(double(device.m[i]) - host.m[i]);
      const double dv = std::abs(double(device.v[i]) - host.v[i]);
      const double dp = std::abs(double(device.params[i]) - host.params[i]);
      ASSERT_LE(dm, b.m) << "m " << i << ": " << device.m[i] << " vs " << host.m[i];
      ASSERT_LE(dv, b.v) << "v " << i << ": " << device.v[i] << " vs " << host.v[i];
      ASSERT_LE(dp, b.param) << "param " << i << ": " << device.params[i] << " vs "
                             << host.params[i];
      worst = std::max({worst, dm / b.m, dv / b.v, dp / b.param});
    }
  }
  std::printf("[ measured ] Adam, width %d: worst difference %.3f of its bound\n", width, worst);
}

TEST(AdamCuda, SelectiveStepsMatchTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  check_steps(1001, 3, {}, 11);            // a mean's rows
  std::vector<float> sh_scale(48, 0.05f);  // SH: the rest bands at 1/20 of the DC rate
  std::fill_n(sh_scale.begin(), 3, 1.0f);
  check_steps(777, 48, sh_scale, 23);
}

TEST(AdamCuda, ResetRowsZeroesOnlyThoseRows) {
  RETIMEGS_REQUIRE_GPU();
  const std::size_t n = 513;
  const int width = 7;
  std::vector<float> m = test::random_floats(n * width, 0.5f, 1.0f, 31);
  std::vector<float> v = test::random_floats(n * width, 0.5f, 1.0f, 32);
  DeviceAdam adam(n, width);
  adam.m().upload(m);
  adam.v().upload(v);
  const std::vector<std::int32_t> rows = test::random_rows(n, 0.2, 33);
  ASSERT_FALSE(rows.empty());
  DeviceBuffer<std::int32_t> d_rows;
  d_rows.upload(rows);
  adam.reset_rows(d_rows.data(), rows.size());
  for (const std::int32_t r : rows)
    for (int k = 0; k < width; ++k) m[r * width + k] = v[r * width + k] = 0.0f;
  const std::vector<float> got_m = adam.m().download(), got_v = adam.v().download();
  for (std::size_t i = 0; i < m.size(); ++i) {
    ASSERT_EQ(test::ulps(got_m[i], m[i]), 0) << "m " << i;
    ASSERT_EQ(test::ulps(got_v[i], v[i]), 0) << "v " << i;
  }
}

TEST(AdamCuda, NewGroupStartsFromZeroMoments) {
  RETIMEGS_REQUIRE_GPU();
  const DeviceAdam adam(300, 4);
  EXPECT_EQ(adam.m().download(), std::vector<float>(1200, 0.0f));
  EXPECT_EQ(adam.v().download(), std::vector<float>(1200, 0.0f));
  EXPECT_EQ(adam.steps(), 0);
}

}  // namespace
}  // namespace retimegs::cuda
