#include <gtest/gtest.h>

#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/train/stretch.hpp"

namespace retimegs::train {
namespace {

const model::TimeGrid kGrid{0.0, 2.0, 5};  // training times 0, 2, 4, 6, 8

// Row i: interval centre mu_tau, position x, colour dc, velocity along x.
void set_row(model::Primitives& p, int i, float mu_tau, float x, float dc, float speed) {
  p.mu[3 * i] = x, p.mu[3 * i + 1] = 0, p.mu[3 * i + 2] = 3;
  for (int j = 0; j < 3; ++j) p.velocity[9 * i + 3 * j] = speed;
  p.sh[48 * i] = p.sh[48 * i + 1] = p.sh[48 * i + 2] = dc;
  p.opacity_logit[i] = 2;
  p.mu_tau[i] = mu_tau, p.tau_l[i] = 1, p.tau_r[i] = 1;
  p.q0[4 * i] = 1;
}

TEST(Stretch, MergesIdenticalStaticNeighboursAndLeavesMovingOnesAlone) {
  model::Primitives p;
  p.resize(5);
  set_row(p, 0, 3, 0.0f, 0.4f, 0);               // static, interval [2, 4]
  set_row(p, 1, 5, 0.0f, 0.4f, 0);               // the same static content in [4, 6]
  set_row(p, 2, 3, 1.0f, 0.4f, 0.05f);           // moving, [2, 4]: at t = 4 it sits at x = 1.05
  set_row(p, 3, 5, 1.05f - 0.05f, 0.4f, 0.05f);  // its continuation in [4, 6] (x(4) = 1.0 - ... )
  set_row(p, 4, 7, 3.0f, -0.8f, 0);  // static but alone (nothing near it in [4, 6]... or [8])
  const StretchSettings settings{0.05, 0.1, 0.002};
  std::mt19937_64 rng(1);
  const model::ModelConfig config;
  const StretchResult r = stretch(p, config, kGrid, settings, rng);
  EXPECT_EQ(r.pairs, 1u);
  EXPECT_EQ(r.stretched, 2u);
  // Both static ones now span [2, 6]; μ_τ is unchanged.
  EXPECT_FLOAT_EQ(p.mu_tau[0], 3);
  EXPECT_FLOAT_EQ(p.mu_tau[0] - p.tau_l[0], 2);
  EXPECT_FLOAT_EQ(p.mu_tau[0] + p.tau_r[0], 6);
  EXPECT_FLOAT_EQ(p.mu_tau[1] - p.tau_l[1], 2);
  EXPECT_FLOAT_EQ(p.mu_tau[1] + p.tau_r[1], 6);
  // At most one of the merged pair was pruned (made dead), never both.
  const int alive = (p.opacity_logit[0] > 0) + (p.opacity_logit[1] > 0);
  EXPECT_GE(alive, 1);
  EXPECT_EQ(r.pruned, std::size_t(2 - alive));
  // The moving pair and the lone primitive keep their windows and opacity.
  for (int i : {2, 3, 4}) {
    EXPECT_FLOAT_EQ(p.tau_l[i], 1) << i;
    EXPECT_FLOAT_EQ(p.tau_r[i], 1) << i;
    EXPECT_FLOAT_EQ(p.opacity_logit[i], 2) << i;
  }
}

TEST(Stretch, DifferentColoursDoNotMergeAndStretchingProgresses) {
  model::Primitives p;
  p.resize(3);
  set_row(p, 0, 3, 0.0f, 0.4f, 0);
  set_row(p, 1, 5, 0.0f, -0.4f, 0);  // same place, different colour
  set_row(p, 2, 7, 0.0f, 0.4f, 0);
  const StretchSettings settings{0.05, 0.1, 0.002};
  std::mt19937_64 rng(2);
  const model::ModelConfig config;
  EXPECT_EQ(stretch(p, config, kGrid, settings, rng).pairs, 0u);
  // Same colour everywhere: [2,4]+[4,6] and [4,6]+[6,8] merge; a second round extends further.
  p.sh[48] = p.sh[49] = p.sh[50] = 0.4f;
  p.opacity_logit = {5, 5, 5};
  const StretchResult first = stretch(p, config, kGrid, settings, rng);
  EXPECT_EQ(first.pairs, 2u);
  double widest = 0;
  for (int i = 0; i < 3; ++i)
    if (p.opacity_logit[i] > 0) widest = std::max(widest, double(p.tau_l[i] + p.tau_r[i]));
  EXPECT_GE(widest, 4.0);
}

}  // namespace
}  // namespace retimegs::train
