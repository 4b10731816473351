#include <algorithm>
#include <cmath>
#include <cstdint>
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

// Momentum catch-up: rows active at every step, whose gradient is zero at the steps marked
// untouched. Dense Adam steps them on momentum at every step; the lazy step skips them and applies
// the missed steps in closed form when the row is next touched or at catch_up. With the bias
// corrections at their limit (a long-running group) and a constant rate the two agree to float
// rounding; a row touched at every step is bit for bit dense Adam's.
TEST(Adam, LazyStepsCatchUpToDenseAdam) {
  constexpr int kRows = 3, kWidth = 4, kSteps = 40;
  Adam dense(kRows, kWidth), lazy(kRows, kWidth);
  dense.step_count() = lazy.step_count() = 100000;
  std::mt19937 rng(7);
  std::normal_distribution<float> normal;
  std::vector<float> p_dense(kRows * kWidth);
  for (float& v : p_dense) v = normal(rng);
  std::vector<float> p_lazy = p_dense;
  const std::vector<std::int32_t> rows = {0, 1, 2};
  std::vector<std::int32_t> pending(kRows, 0);
  std::vector<std::int32_t> first(kRows, 0);
  // Row 0 every step; row 1 at steps 0, 3, 4 and 25; row 2 at step 0 only.
  const auto touched_at = [](int r, int step) {
    return r == 0 || step == 0 || (r == 1 && (step == 3 || step == 4 || step == 25));
  };
  for (int step = 0; step < kSteps; ++step) {
    std::vector<float> g(kRows * kWidth, 0.0f);
    std::vector<std::uint8_t> touched(kRows);
    for (int r = 0; r < kRows; ++r) {
      touched[r] = touched_at(r, step);
      if (touched[r])
        for (int k = 0; k < kWidth; ++k) g[r * kWidth + k] = normal(rng);
    }
    std::vector<float> g_lazy = g;
    dense.step(p_dense.data(), g.data(), 0.01);
    lazy.step_lazy(p_lazy.data(), g_lazy.data(), 0.01, rows, touched.data(),
                   {pending.data(), first.data()});
    for (int r = 0; r < kRows; ++r) {
      if (!touched[r] && pending[r] == 0) first[r] = std::int32_t(lazy.steps());
      pending[r] = touched[r] ? 0 : pending[r] + 1;
    }
    for (int k = 0; k < kWidth; ++k) {
      ASSERT_EQ(p_lazy[k], p_dense[k]) << "step " << step;     // row 0: dense, bit for bit
      ASSERT_EQ(g_lazy[kWidth + k], 0.0f) << "step " << step;  // read gradients are cleared
    }
    if (touched[1])  // row 1 caught up at every touch
      for (int k = kWidth; k < 2 * kWidth; ++k) {
        ASSERT_NEAR(p_lazy[k], p_dense[k], 1e-5 * std::abs(p_dense[k]) + 1e-7) << step;
        ASSERT_NEAR(lazy.m()[k], dense.m()[k], 1e-5 * std::abs(dense.m()[k])) << step;
        ASSERT_NEAR(lazy.v()[k], dense.v()[k], 1e-5 * std::abs(dense.v()[k])) << step;
      }
  }
  // Row 2 lags by the 39 steps it missed, and row 1 by 14, until catch_up.
  EXPECT_EQ(pending[2], kSteps - 1);
  const float lag = std::abs(p_lazy[2 * kWidth] - p_dense[2 * kWidth]);
  EXPECT_GT(lag, 1e-3f);
  lazy.catch_up(p_lazy.data(), 0.01, {pending.data(), first.data()});
  for (int k = 0; k < kRows * kWidth; ++k) {
    EXPECT_NEAR(p_lazy[k], p_dense[k], 1e-5 * std::abs(p_dense[k]) + 1e-7) << k;
    EXPECT_NEAR(lazy.m()[k], dense.m()[k], 1e-5 * std::abs(dense.m()[k]) + 1e-12) << k;
    EXPECT_NEAR(lazy.v()[k], dense.v()[k], 1e-5 * std::abs(dense.v()[k]) + 1e-12) << k;
  }
}

// Early in training the bias corrections change from step to step and the catch-up applies them
// as at the first missed step: the result stays within a few percent of dense Adam's move.
TEST(Adam, LazyCatchUpEarlyInTrainingStaysCloseToDense) {
  Adam dense(1, 1), lazy(1, 1);
  float p_dense = 0, p_lazy = 0;
  std::int32_t pending = 0;
  std::int32_t first = 0;
  const std::vector<std::int32_t> rows = {0};
  for (int step = 0; step < 30; ++step) {
    const bool touched = step < 5 || step == 29;
    float g = touched ? 1.0f : 0.0f, g_lazy = g;
    const std::uint8_t flag = touched;
    dense.step(&p_dense, &g, 0.01);
    lazy.step_lazy(&p_lazy, &g_lazy, 0.01, rows, &flag, {&pending, &first});
    if (!touched && pending == 0) first = std::int32_t(lazy.steps());
    pending = touched ? 0 : pending + 1;
  }
  EXPECT_NEAR(p_lazy, p_dense, 0.03 * std::abs(p_dense));
  EXPECT_GT(std::abs(p_lazy), 1.5f * 0.05f);  // well past the 5 touched steps' own moves
}

// The optimiser of a model: the regularised fields (log_scale, opacity_logit) step densely, bit for
// bit as without touched flags; the others lazily, and after catch_up every field agrees with the
// dense optimiser's to float rounding (bias corrections at their limit, constant rates). Rows: 0
// has a renderer gradient at every step, 1 at every third, 2 only at the first; row 3 is not in
// the active set.
TEST(Optimizers, LazyFieldsCatchUpAndRegularisedFieldsStepDensely) {
  constexpr std::size_t kRows = 4;
  std::mt19937 rng(11);
  std::normal_distribution<float> normal;
  model::Primitives p;
  p.resize(kRows);
  for (const auto& f : p.fields())
    for (float& v : *f.values) v = normal(rng);
  TrainConfig config;
  Optimizers dense(p, model::Representation::kRetime, config, 2.0, 0.5), lazy = dense;
  for (Optimizers* o : {&dense, &lazy})
    for (auto& group : *o) group.adam.step_count() = 100000;
  model::Primitives p_dense = p, p_lazy = p;
  const std::vector<std::int32_t> rows = {0, 1, 2};
  for (int step = 0; step < 30; ++step) {
    std::vector<std::uint8_t> touched = {1, std::uint8_t(step % 3 == 0), std::uint8_t(step == 0),
                                         0};
    model::PrimitiveGrads g(kRows);
    for (std::size_t r = 0; r < 3; ++r) {
      // The regularisers reach every active row; the renders only the touched ones.
      for (int a = 0; a < 3; ++a) g.v_log_scale[3 * r + a] = normal(rng);
      g.v_opacity_logit[r] = normal(rng);
      if (!touched[r]) continue;
      for (auto* field : {&g.v_mu, &g.v_velocity, &g.v_q0, &g.v_q1, &g.v_sh}) {
        const std::size_t width = field->size() / kRows;
        for (std::size_t k = r * width; k < (r + 1) * width; ++k) (*field)[k] = normal(rng);
      }
    }
    model::PrimitiveGrads g_lazy = g;
    dense.step(p_dense, g, rows, 1.0, 1.0);
    lazy.step(p_lazy, g_lazy, rows, 1.0, 1.0, &touched);
    ASSERT_EQ(p_lazy.log_scale, p_dense.log_scale) << step;
    ASSERT_EQ(p_lazy.opacity_logit, p_dense.opacity_logit) << step;
    for (int f = 0; f < 6; ++f) {  // row 0 in every field
      const auto field = p.fields()[f];
      const int w = field.width;
      const auto& a = *p_lazy.fields()[f].values;
      const auto& b = *p_dense.fields()[f].values;
      ASSERT_TRUE(std::equal(a.begin(), a.begin() + w, b.begin())) << field.name << " " << step;
    }
    for (const auto* field : {&g_lazy.v_mu, &g_lazy.v_sh, &g_lazy.v_log_scale})
      ASSERT_TRUE(std::all_of(field->begin(), field->end(), [](float v) { return v == 0; }));
  }
  EXPECT_EQ(lazy.pending_rows(), 2u);  // rows 1 (missed steps 28, 29) and 2
  EXPECT_NE(p_lazy.sh[2 * model::Primitives::kShWidth],
            p_dense.sh[2 * model::Primitives::kShWidth]);
  lazy.catch_up(p_lazy);
  EXPECT_EQ(lazy.pending_rows(), 0u);
  for (int f = 0; f < model::Primitives::kFieldCount; ++f) {
    const auto& a = *p_lazy.fields()[f].values;
    const auto& b = *p_dense.fields()[f].values;
    for (std::size_t k = 0; k < a.size(); ++k)
      EXPECT_NEAR(a[k], b[k], 1e-5 * std::abs(b[k]) + 1e-6) << p.fields()[f].name << " " << k;
  }
  // Row 3 was never active: as it started.
  for (int f = 0; f < model::Primitives::kFieldCount; ++f) {
    const int w = p.fields()[f].width;
    const auto& a = *p_lazy.fields()[f].values;
    const auto& b = *p.fields()[f].values;
    EXPECT_TRUE(std::equal(a.begin() + 3 * w, a.begin() + 4 * w, b.begin() + 3 * w));
  }
}

}  // namespace
}  // namespace retimegs::train
