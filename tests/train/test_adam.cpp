#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/train/adam.hpp"

namespace retimegs::train {
namespace {

TEST(Adam, MatchesHandComputedSteps) {
  // Two steps of torch.optim.Adam(lr=0.1, betas=(0.9, 0.999), eps=1e-8) on p = [1, -2], by hand:
  //   t=1, g=[0.5, -1]: m = 0.1 g, v = 0.001 g², m̂ = g, v̂ = g²  ->  p -= 0.1 g / (|g| + eps)
  //   t=2, g=[-0.25, 2]: m = 0.9 m1 + 0.1 g, v = 0.999 v1 + 0.001 g², m̂ = m / 0.19,
  //   v̂ = v / (1 - 0.999²)
  AdamSettings settings;
  settings.epsilon = 1e-8;
  Adam adam(1, 2, settings);
  float p[2] = {1.0f, -2.0f};
  const float g1[2] = {0.5f, -1.0f}, g2[2] = {-0.25f, 2.0f};
  adam.step(p, g1, 0.1);
  double expected[2] = {1.0 - 0.1, -2.0 + 0.1};
  for (int i = 0; i < 2; ++i) EXPECT_NEAR(p[i], expected[i], 1e-6);
  adam.step(p, g2, 0.1);
  for (int i = 0; i < 2; ++i) {
    const double m = 0.9 * 0.1 * g1[i] + 0.1 * g2[i];
    const double v = 0.999 * 0.001 * g1[i] * g1[i] + 0.001 * g2[i] * g2[i];
    const double m_hat = m / (1 - 0.9 * 0.9), v_hat = v / (1 - 0.999 * 0.999);
    expected[i] -= 0.1 * m_hat / (std::sqrt(v_hat) + 1e-8);
    EXPECT_NEAR(p[i], expected[i], 1e-6) << i;
  }
  EXPECT_EQ(adam.steps(), 2);
}

TEST(Adam, ResetRowsAndGrowthStartFromZeroState) {
  Adam adam(3, 2);
  float p[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  const float g[8] = {1, 1, 1, 1, 1, 1, 1, 1};
  adam.step(p, g, 0.01);
  adam.reset_rows({1});
  EXPECT_EQ(adam.m()[2], 0.0f);
  EXPECT_EQ(adam.v()[3], 0.0f);
  EXPECT_NE(adam.m()[0], 0.0f);
  adam.resize(4);
  EXPECT_EQ(adam.rows(), 4u);
  EXPECT_EQ(adam.m()[7], 0.0f);
  // A reset row moves like a fresh parameter would at this step count: lr·(g(1-β1)/c1) / ...
  const float before = p[2];
  adam.step(p, g, 0.01);
  EXPECT_LT(p[2], before);
}

// Reordering the moments with the rows: a group stepped, reordered, then stepped on reordered
// gradients holds, bit for bit, the reordered state of a group stepped throughout in the old order.
TEST(Adam, ReorderMovesEachRowsMomentsWithIt) {
  constexpr int kRows = 5, kWidth = 2;
  const std::vector<std::int32_t> old_from_new = {3, 0, 4, 2, 1};
  std::mt19937 rng(4);
  std::normal_distribution<float> normal;
  std::vector<float> g1(kRows * kWidth), g2(kRows * kWidth), p(kRows * kWidth);
  for (float& v : g1) v = normal(rng);
  for (float& v : g2) v = normal(rng);
  for (float& v : p) v = normal(rng);
  Adam kept(kRows, kWidth), moved(kRows, kWidth);
  std::vector<float> p_kept = p, p_moved = p;
  kept.step(p_kept.data(), g1.data(), 0.01);
  moved.step(p_moved.data(), g1.data(), 0.01);
  moved.reorder(old_from_new);
  model::reorder_rows(p_moved, kWidth, old_from_new);
  std::vector<float> g2_moved = g2;
  model::reorder_rows(g2_moved, kWidth, old_from_new);
  kept.step(p_kept.data(), g2.data(), 0.01);
  moved.step(p_moved.data(), g2_moved.data(), 0.01);
  for (int k = 0; k < kRows; ++k)
    for (int a = 0; a < kWidth; ++a) {
      const std::size_t from = std::size_t(old_from_new[k]) * kWidth + a, to = k * kWidth + a;
      EXPECT_EQ(p_moved[to], p_kept[from]) << k;
      EXPECT_EQ(moved.m()[to], kept.m()[from]) << k;
      EXPECT_EQ(moved.v()[to], kept.v()[from]) << k;
    }
}

// step_and_clear is step, then the stepped rows' gradients zero; other rows' gradients stay.
TEST(Adam, StepAndClearIsStepThenZeroGradientRows) {
  constexpr int kRows = 4, kWidth = 3;
  Adam a(kRows, kWidth), b(kRows, kWidth);
  std::vector<float> pa(kRows * kWidth, 1.0f), pb = pa, g(kRows * kWidth);
  for (int k = 0; k < kRows * kWidth; ++k) g[k] = 0.1f * float(k + 1);
  const std::vector<std::int32_t> rows = {0, 2};
  std::vector<float> consumed = g;
  a.step(pa.data(), g.data(), 0.01, &rows);
  b.step_and_clear(pb.data(), consumed.data(), 0.01, &rows);
  EXPECT_EQ(pa, pb);
  EXPECT_EQ(a.m(), b.m());
  EXPECT_EQ(a.v(), b.v());
  for (int r = 0; r < kRows; ++r)
    for (int k = 0; k < kWidth; ++k)
      EXPECT_EQ(consumed[r * kWidth + k], r % 2 == 0 ? 0.0f : g[r * kWidth + k]) << r;
}

// Selective steps over 6 rows of width 3: rows 0 and 3 are in every step's set, rows 1 and 4 in
// every other one, row 5 in none. Rows in every set evolve bit for bit as under dense Adam; a row
// outside a step's set keeps its parameters and both moments; the step count is the group's.
TEST(Adam, SelectiveStepsLeaveRowsOutsideTheSetAsTheyAre) {
  constexpr int kRows = 6, kWidth = 3;
  Adam dense(kRows, kWidth), selective(kRows, kWidth);
  std::vector<float> p_dense(kRows * kWidth), p_selective;
  std::mt19937 rng(3);
  std::normal_distribution<float> normal;
  for (float& v : p_dense) v = normal(rng);
  p_selective = p_dense;
  for (int step = 0; step < 20; ++step) {
    std::vector<float> g(kRows * kWidth);
    for (float& v : g) v = normal(rng);
    const std::vector<std::int32_t> rows =
        step % 2 == 0 ? std::vector<std::int32_t>{0, 1, 3, 4} : std::vector<std::int32_t>{0, 3};
    const std::vector<float> p_before = p_selective, m_before = selective.m(),
                             v_before = selective.v();
    dense.step(p_dense.data(), g.data(), 0.01);
    selective.step(p_selective.data(), g.data(), 0.01, &rows);
    for (int r = 0; r < kRows; ++r) {
      const bool in_set = std::find(rows.begin(), rows.end(), r) != rows.end();
      for (int k = r * kWidth; k < (r + 1) * kWidth; ++k) {
        if (r == 0 || r == 3) {
          ASSERT_EQ(p_selective[k], p_dense[k]) << "step " << step << " row " << r;
          ASSERT_EQ(selective.m()[k], dense.m()[k]) << "step " << step << " row " << r;
          ASSERT_EQ(selective.v()[k], dense.v()[k]) << "step " << step << " row " << r;
        }
        if (!in_set) {
          ASSERT_EQ(p_selective[k], p_before[k]) << "step " << step << " row " << r;
          ASSERT_EQ(selective.m()[k], m_before[k]) << "step " << step << " row " << r;
          ASSERT_EQ(selective.v()[k], v_before[k]) << "step " << step << " row " << r;
        } else {
          ASSERT_NE(p_selective[k], p_before[k]) << "step " << step << " row " << r;
        }
      }
    }
  }
  EXPECT_EQ(selective.steps(), 20);
  // Rows 1 and 4 took 10 of the 20 steps: their moments differ from dense Adam's.
  EXPECT_NE(selective.m()[kWidth], dense.m()[kWidth]);
  for (int k = 5 * kWidth; k < 6 * kWidth; ++k) EXPECT_EQ(selective.m()[k], 0.0f);
}

}  // namespace
}  // namespace retimegs::train
