// The MCMC density strategy: relocation and growth at the documented iterations with fresh Adam
// moments for every replaced or appended row, stretching at its own schedule, noise every step.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include <gtest/gtest.h>

#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/train/strategy.hpp"

namespace retimegs::train {
namespace {

// Unscaled milestones: relocation at 15, 20, 25 (every 5, strictly between 10 and 30);
// stretching at 7, 14, 21 (every 7, before the last iteration 28).
TrainConfig schedule() {
  TrainConfig config;
  config.iters = 28;
  config.scale_schedule = false;
  config.relocate_every = 5, config.relocate_start = 10, config.relocate_stop = 30;
  config.stretch_every = 7;
  return config;
}

// 200 primitives in one window over the whole clip (nothing to stretch), the first 30 dead.
model::Model relocation_model() {
  model::Model m;
  m.grid = {0.0, 1.0, 3};
  model::Primitives& p = m.primitives;
  p.resize(200);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-1, 1);
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (int a = 0; a < 3; ++a) p.mu[3 * i + a] = u(rng);
    for (int a = 0; a < 3; ++a) p.log_scale[3 * i + a] = std::log(0.05f);
    p.q0[4 * i] = 1;
    p.opacity_logit[i] = 0.5f * u(rng);
    p.mu_tau[i] = 1, p.tau_l[i] = 1, p.tau_r[i] = 1;
  }
  return m;
}

bool zero_moments(const Optimizers& optimizers, std::size_t row) {
  for (const auto& [name, adam] : optimizers) {
    const std::size_t width = adam.m().size() / adam.rows();
    for (std::size_t k = row * width; k < (row + 1) * width; ++k)
      if (adam.m()[k] != 0 || adam.v()[k] != 0) return false;
  }
  return true;
}

TEST(McmcStrategy, RelocatesAndGrowsOnScheduleWithFreshMomentsForReplacedRows) {
  TrainConfig config = schedule();
  config.cap = 220;  // growth: 200 -> 210 -> 220, then the cap
  model::Model m = relocation_model();
  model::Primitives& p = m.primitives;
  Optimizers optimizers(p, m.config.representation, config, 1.0, 1.0);
  McmcStrategy strategy(config, 1.0);
  std::mt19937_64 rng(2);
  for (int it = 1; it <= config.iters; ++it) {
    for (int i = 0; i < 30; ++i) p.opacity_logit[i] = -6;  // σ = 0.0025: dead
    // Moments on every row, parameters unchanged (rate 0).
    model::PrimitiveGrads grads(p.size());
    for (auto* g : {&grads.v_mu, &grads.v_velocity, &grads.v_log_scale, &grads.v_q0, &grads.v_q1,
                    &grads.v_sh, &grads.v_opacity_logit})
      std::fill(g->begin(), g->end(), 1.0f);
    std::vector<std::int32_t> all(p.size());
    std::iota(all.begin(), all.end(), 0);
    optimizers.step(p, grads, all, 0, 0);
    const model::Primitives before = p;
    const std::size_t n = p.size();
    const DensityChanges changes = strategy.after_step(it, 1.6e-4, all, m, optimizers, rng);
    for (const auto& [name, adam] : optimizers) ASSERT_EQ(adam.rows(), p.size()) << name;
    EXPECT_EQ(changes.stretched, 0u) << it;
    if (it != 15 && it != 20 && it != 25) {
      EXPECT_EQ(changes.relocated, 0u) << it;
      EXPECT_EQ(changes.added, 0u) << it;
      EXPECT_EQ(p.size(), n) << it;
      for (std::size_t i = 0; i < p.size(); ++i) ASSERT_FALSE(zero_moments(optimizers, i)) << i;
      // Noise moved the dead (faint) primitives.
      EXPECT_NE(p.mu[0], before.mu[0]) << it;
      continue;
    }
    EXPECT_EQ(changes.relocated, 30u) << it;
    EXPECT_EQ(changes.added, std::min<std::size_t>(config.cap, std::size_t(1.05 * n)) - n) << it;
    EXPECT_EQ(p.size(), n + changes.added) << it;
    // Replaced rows (the dead ones, and the corrected sources), appended rows: zero moments.
    // Rows that relocation left alone keep theirs.
    for (std::size_t i = 0; i < p.size(); ++i) {
      const bool replaced = i < 30 || i >= n || p.opacity_logit[i] != before.opacity_logit[i];
      EXPECT_EQ(zero_moments(optimizers, i), replaced) << "iteration " << it << " row " << i;
    }
  }
  EXPECT_EQ(p.size(), config.cap);
}

// Static pairs that merge at t = 4 (grid 0, 2, 4, 6, 8): rows 0 and 1 ([2, 4] and [4, 6]).
model::Model stretch_model() {
  model::Model m;
  m.grid = {0.0, 2.0, 5};
  model::Primitives& p = m.primitives;
  p.resize(2);
  for (int i = 0; i < 2; ++i) {
    p.mu[3 * i + 2] = 3;
    p.sh[model::Primitives::kShWidth * i] = 0.4f;
    p.opacity_logit[i] = 2;
    p.mu_tau[i] = float(3 + 2 * i), p.tau_l[i] = 1, p.tau_r[i] = 1;
    p.q0[4 * i] = 1;
  }
  return m;
}

TEST(McmcStrategy, StretchesOnItsScheduleAndNotForStgsOrTheAblation) {
  TrainConfig config = schedule();
  config.relocate_start = 100;  // no relocation
  for (const int variant : {0, 1, 2}) {
    TrainConfig c = config;
    c.ablate.no_stretch = variant == 1;
    model::Model m = stretch_model();
    if (variant == 2) m.config.representation = model::Representation::kStgs;
    Optimizers optimizers(m.primitives, m.config.representation, c, 1.0, 1.0);
    McmcStrategy strategy(c, 1.0);
    std::mt19937_64 rng(3);
    for (int it = 1; it <= c.iters; ++it) {
      // Undo the last merge (and pruning), so that every round finds the pair again.
      const model::Model fresh = stretch_model();
      m.primitives.tau_l = fresh.primitives.tau_l, m.primitives.tau_r = fresh.primitives.tau_r;
      m.primitives.opacity_logit = fresh.primitives.opacity_logit;
      const DensityChanges changes = strategy.after_step(it, 1.6e-4, {0, 1}, m, optimizers, rng);
      const bool due = variant == 0 && it % 7 == 0 && it < c.iters;
      EXPECT_EQ(changes.stretched, due ? 2u : 0u) << "variant " << variant << " iteration " << it;
      EXPECT_EQ(m.primitives.tau_l[1] > 1, due) << "variant " << variant << " iteration " << it;
      EXPECT_EQ(changes.relocated + changes.added, 0u);
    }
  }
}

}  // namespace
}  // namespace retimegs::train
