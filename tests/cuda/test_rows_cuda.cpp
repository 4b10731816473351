// Row moves of the step's device state against the host's: DeviceBuffer::resize_keep,
// DevicePrimitives::resize / reorder / copy_rows against model::Primitives' resize / reorder /
// copy_row, and DeviceAdam's resize / reorder / assign / download against train::Adam's state.
// Moves copy floats: every comparison is to the bit. The kept or moved values are random (never
// zero) and the rows a resize adds are first filled with stale non-zero values, so that a move
// that drops or misplaces a row, or a grown row left unzeroed, shows.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "cuda/random_arrays.hpp"
#include "cuda/require_gpu.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/cuda/adam.hpp"
#include "retimegs/cuda/buffer.hpp"
#include "retimegs/cuda/primitives.hpp"
#include "retimegs/model/primitives.hpp"
#include "retimegs/train/adam.hpp"
#include "retimegs/train/adam_update.hpp"

namespace retimegs::cuda {
namespace {

model::Primitives random_primitives(std::size_t n, std::uint64_t seed) {
  model::Primitives p;
  p.resize(n);
  for (const auto& f : p.fields())
    *f.values = test::random_floats(f.values->size(), 0.5f, 2.0f, ++seed);
  return p;
}

std::vector<std::int32_t> random_permutation(std::size_t n, std::uint64_t seed) {
  std::vector<std::int32_t> perm(n);
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937_64(seed));
  return perm;
}

void expect_same(const model::Primitives& got, const model::Primitives& want) {
  ASSERT_EQ(got.size(), want.size());
  const auto g = got.fields();
  const auto w = want.fields();
  for (int f = 0; f < model::Primitives::kFieldCount; ++f)
    EXPECT_EQ(*g[f].values, *w[f].values) << w[f].name;
}

TEST(BufferCuda, ResizeKeepKeepsTheFirstValues) {
  RETIMEGS_REQUIRE_GPU();
  const std::vector<float> values = test::random_floats(1000, 0.5f, 2.0f, 1);
  DeviceBuffer<float> b;
  b.upload(values);
  b.resize_keep(5000);  // a new allocation
  ASSERT_EQ(b.size(), 5000u);
  std::vector<float> got = b.download();
  EXPECT_TRUE(std::equal(values.begin(), values.end(), got.begin()));
  b.resize_keep(300);
  b.resize_keep(800);  // within the allocation
  got = b.download();
  ASSERT_EQ(got.size(), 800u);
  EXPECT_TRUE(std::equal(values.begin(), values.begin() + 300, got.begin()));
  b.fill_bytes(0, 700);  // the tail only
  got = b.download();
  EXPECT_TRUE(std::equal(values.begin(), values.begin() + 300, got.begin()));
  EXPECT_EQ(std::vector<float>(got.begin() + 700, got.end()), std::vector<float>(100, 0.0f));
  DeviceBuffer<float> empty;
  empty.resize_keep(10);  // from nothing
  EXPECT_EQ(empty.size(), 10u);
}

TEST(PrimitivesCuda, ResizeKeepsRowsAndZeroesNewOnes) {
  RETIMEGS_REQUIRE_GPU();
  model::Primitives host = random_primitives(777, 10);
  DevicePrimitives device;
  device.upload(host);
  // Shrink, then grow within the allocation (its tail still holds the old rows) and beyond it.
  for (const std::size_t n : {500u, 777u, 2000u, 1u}) {
    SCOPED_TRACE(testing::Message() << n << " rows");
    host.resize(n);
    device.resize(n);
    ASSERT_EQ(device.size(), n);
    model::Primitives got;
    device.download(got);
    expect_same(got, host);
  }
}

TEST(PrimitivesCuda, ReorderMovesEveryField) {
  RETIMEGS_REQUIRE_GPU();
  model::Primitives host = random_primitives(3001, 20);
  DevicePrimitives device;
  device.upload(host);
  for (std::uint64_t seed : {21u, 22u}) {  // twice: the scratch swapped in by the first serves
    const std::vector<std::int32_t> perm = random_permutation(host.size(), seed);
    host.reorder(perm);
    device.reorder(perm);
    model::Primitives got;
    device.download(got);
    expect_same(got, host);
  }
  EXPECT_THROW(device.reorder(std::vector<std::int32_t>{0, 1}), Error);
}

TEST(PrimitivesCuda, CopyRowsCopiesLiveRowsOntoOthers) {
  RETIMEGS_REQUIRE_GPU();
  const std::size_t n = 2500;
  model::Primitives host = random_primitives(n, 30);
  // Targets: a random set of distinct rows; sources: drawn with repeats from the other rows.
  std::vector<std::int32_t> perm = random_permutation(n, 31);
  const std::vector<std::int32_t> to(perm.begin(), perm.begin() + 700);
  std::mt19937_64 rng(32);
  std::uniform_int_distribution<std::size_t> pick(700, n - 1);
  std::vector<std::int32_t> from(to.size());
  for (std::int32_t& f : from) f = perm[pick(rng)];
  DevicePrimitives device;
  device.upload(host);
  for (std::size_t k = 0; k < to.size(); ++k) host.copy_row(to[k], host, from[k]);
  DeviceBuffer<std::int32_t> d_to, d_from;
  d_to.upload(to);
  d_from.upload(from);
  device.copy_rows(d_to.data(), d_from.data(), to.size());
  model::Primitives got;
  device.download(got);
  expect_same(got, host);
}

// A host group whose state is random: moments, step count, non-default settings and column
// scales (the SH group's shape).
train::Adam random_group(std::size_t rows, int width, std::uint64_t seed) {
  std::vector<float> scale(width, 0.05f);
  std::fill_n(scale.begin(), 3, 1.0f);
  train::Adam adam(rows, width, {0.5, 0.75, 1e-8}, scale);
  adam.m() = test::random_floats(rows * width, -0.1f, 0.1f, seed);
  adam.v() = test::random_floats(rows * width, 1e-4f, 1e-2f, seed + 1);
  adam.step_count() = 13;
  return adam;
}

TEST(AdamStateCuda, AssignAndDownloadRoundTrip) {
  RETIMEGS_REQUIRE_GPU();
  const train::Adam host = random_group(300, 48, 40);
  DeviceAdam device;
  device.assign(host);
  EXPECT_EQ(device.rows(), 300u);
  EXPECT_EQ(device.width(), 48);
  EXPECT_EQ(device.steps(), 13);
  train::Adam back(0, 48);
  device.download(back);
  EXPECT_EQ(back.m(), host.m());
  EXPECT_EQ(back.v(), host.v());
  EXPECT_EQ(back.steps(), 13);
  EXPECT_EQ(back.rows(), 300u);
  train::Adam narrow(0, 3);
  EXPECT_THROW(device.download(narrow), Error);
}

TEST(AdamStateCuda, AssignCarriesTheSettingsAndColumnScales) {
  RETIMEGS_REQUIRE_GPU();
  const std::size_t rows = 200;
  const int width = 48;
  train::Adam host = random_group(rows, width, 50);
  std::vector<float> params = test::random_floats(rows * width, -2.0f, 2.0f, 52);
  const std::vector<float> grads = test::random_floats(rows * width, -1.0f, 1.0f, 53);
  DeviceAdam device;
  device.assign(host);
  DeviceBuffer<float> d_params, d_grads;
  d_params.upload(params);
  d_grads.upload(grads);
  const double lr = 1e-3;
  device.step_and_clear(d_params.data(), d_grads.data(), lr);
  // The host's step from the same state (train::Adam::step_and_clear's loop).
  const std::vector<float> m0 = host.m(), v0 = host.v();
  const train::AdamStepConstants k =
      train::adam_step_constants(host.settings(), lr, host.steps() + 1);
  for (std::size_t i = 0; i < params.size(); ++i)
    train::adam_update(k, host.column_scale()[i % width], grads[i], params[i], host.m()[i],
                       host.v()[i]);
  train::Adam got(0, width);
  device.download(got);
  EXPECT_EQ(got.steps(), 14);
  const std::vector<float> got_params = d_params.download();
  // The moments within a few roundings of each term (the compilers may fuse differently, as
  // test_adam_cuda.cpp states); β1 = 0.5, β2 = 0.75 rather than the defaults move m and v by far
  // more, and the rest bands' 1/20 scale moves the parameters 20 times less.
  const double eps = 4 * FLT_EPSILON;
  for (std::size_t i = 0; i < params.size(); ++i) {
    const double g = grads[i];
    ASSERT_LE(std::abs(double(got.m()[i]) - host.m()[i]),
              eps * (0.5 * std::abs(m0[i]) + 0.5 * std::abs(g)))
        << "m " << i;
    ASSERT_LE(std::abs(double(got.v()[i]) - host.v()[i]), eps * (0.75 * v0[i] + 0.25 * g * g))
        << "v " << i;
    // The parameters: the step moves one by lr · s · m̂ / sqrt(v̂), at most ~0.06 · s here (|m| <
    // 0.55, v > 7.5e-5); the moments' few roundings carry into it at ~1e-7 of that, far below
    // 1e-6 · s, while a wrong β or column scale would move it by ~1e-2 · s.
    const double diff = std::abs(double(got_params[i]) - params[i]);
    ASSERT_LE(diff, 1e-6 * host.column_scale()[i % width] + eps * std::abs(params[i]))
        << "param " << i;
  }
}

TEST(AdamStateCuda, ResizeKeepsRowsAndZeroesNewOnes) {
  RETIMEGS_REQUIRE_GPU();
  const int width = 7;
  train::Adam host = random_group(400, width, 60);
  DeviceAdam device;
  device.assign(host);
  for (const std::size_t rows : {100u, 400u, 1500u}) {  // shrink, grow within and beyond
    SCOPED_TRACE(testing::Message() << rows << " rows");
    host.m().resize(rows * width, 0.0f);  // train::Adam::resize
    host.v().resize(rows * width, 0.0f);
    device.resize(rows);
    ASSERT_EQ(device.rows(), rows);
    EXPECT_EQ(device.m().download(), host.m());
    EXPECT_EQ(device.v().download(), host.v());
  }
}

TEST(AdamStateCuda, ReorderMovesTheMoments) {
  RETIMEGS_REQUIRE_GPU();
  const int width = 4;
  train::Adam host = random_group(1234, width, 70);
  DeviceAdam device;
  device.assign(host);
  const std::vector<std::int32_t> perm = random_permutation(1234, 71);
  model::reorder_rows(host.m(), width, perm);  // train::Adam::reorder
  model::reorder_rows(host.v(), width, perm);
  DeviceBuffer<std::int32_t> d_perm;
  d_perm.upload(perm);
  device.reorder(d_perm.data(), perm.size());
  EXPECT_EQ(device.m().download(), host.m());
  EXPECT_EQ(device.v().download(), host.v());
  EXPECT_THROW(device.reorder(d_perm.data(), 10), Error);
}

}  // namespace
}  // namespace retimegs::cuda
