#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/core/parallel.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/render/rasterize.hpp"
#include "retimegs/train/relocation.hpp"

namespace retimegs::train {
namespace {

TEST(Relocation, CorrectionMatchesHandComputedValues) {
  double opacity = 0, factor = 0;
  mcmc_correction(0.3, 1, opacity, factor);
  EXPECT_NEAR(opacity, 0.3, 1e-12);
  EXPECT_NEAR(factor, 1.0, 1e-12);
  // n = 2, σ = 0.5: σ_new = 1 - sqrt(0.5); D = 2 σ_new - σ_new² / sqrt(2).
  mcmc_correction(0.5, 2, opacity, factor);
  const double s = 1 - std::sqrt(0.5);
  EXPECT_NEAR(opacity, s, 1e-12);
  EXPECT_NEAR(factor, 0.5 / (2 * s - s * s / std::sqrt(2.0)), 1e-12);
  // Opacity composition: n copies at σ_new are as opaque as the source.
  mcmc_correction(0.8, 5, opacity, factor);
  EXPECT_NEAR(1 - std::pow(1 - opacity, 5), 0.8, 1e-12);
}

// 300 primitives of one interval in front of a camera, 40 of them nearly transparent (dead).
model::Primitives scene(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  model::Primitives p;
  p.resize(300);
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (int a = 0; a < 3; ++a) p.mu[3 * i + a] = 0.8f * u(rng);
    for (int a = 0; a < 3; ++a) p.log_scale[3 * i + a] = std::log(0.05f);
    p.q0[4 * i] = 1;
    for (int c = 0; c < 3; ++c) p.sh[48 * i + c] = u(rng);
    p.opacity_logit[i] = i < 40 ? -6.0f : 0.5f * u(rng);  // sigmoid(-6) = 0.0025 < 0.01
    p.mu_tau[i] = 1, p.tau_l[i] = 1, p.tau_r[i] = 1;
    p.velocity[9 * i + 3] = 0.05f * u(rng);
  }
  return p;
}

TEST(Relocation, KeepsCountCopiesEveryFieldAndRevivesDeadSlots) {
  model::Primitives p = scene(1);
  p.tau_r[250] = 7;  // a distinctive temporal window, to see that temporal fields are copied
  std::mt19937_64 rng(3);
  const Relocation r = relocate(p, RelocationScore::kOpacityTimesDuration, 0.01, rng);
  EXPECT_EQ(p.size(), 300u);
  EXPECT_EQ(r.moved, 40u);
  for (std::size_t i = 0; i < p.size(); ++i) EXPECT_GT(model::sigmoid(p.opacity_logit[i]), 0.01f);
  // Every dead row is now an exact copy of some (corrected) live row.
  for (int i = 0; i < 40; ++i) {
    bool found = false;
    for (std::size_t j = 40; j < p.size() && !found; ++j)
      found = p.mu[3 * i] == p.mu[3 * j] && p.velocity[9 * i + 3] == p.velocity[9 * j + 3] &&
              p.tau_r[i] == p.tau_r[j] && p.opacity_logit[i] == p.opacity_logit[j];
    EXPECT_TRUE(found) << i;
  }
  // Sampling ∝ σ · (τ_l + τ_r): of two equal-σ rows, the one with a 4x longer support is drawn
  // 4x as often (weights 2 : 8 -> 0.8).
  model::Primitives q;
  q.resize(2);
  q.opacity_logit = {0.0f, 0.0f};
  q.tau_l = {1.0f, 1.0f};
  q.tau_r = {1.0f, 7.0f};
  int long_drawn = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    model::Primitives t = q;
    t.resize(3);
    t.opacity_logit[2] = -10;  // one dead slot
    t.copy_row(2, t, 2);
    std::mt19937_64 r2(trial);
    relocate(t, RelocationScore::kOpacityTimesDuration, 0.01, r2);
    long_drawn += t.tau_r[2] == 7.0f;
  }
  EXPECT_NEAR(long_drawn / 2000.0, 0.8, 0.03);
}

// The MCMC correction preserves the rendered image to first order: relocating onto sources with
// the correction changes the image far less than copying without it.
TEST(Relocation, PreservesTheRenderedImageToFirstOrder) {
  Camera cam;
  cam.name = "c";
  cam.width = 96, cam.height = 72;
  cam.fx = cam.fy = 90, cam.cx = 48, cam.cy = 36;
  cam.world_to_camera = look_at({0, 0, -4}, {0, 0, 0}, {0, -1, 0});
  const model::TimeGrid grid{0.0, 2.0, 2};
  const model::ModelConfig config;
  auto render = [&](const model::Primitives& p) {
    const auto e = model::slice(p, config, grid, 1.0, cam, {});
    return render::rasterize_forward(e.gaussians, cam, nullptr).blend.image;
  };
  auto diff = [](const Image& a, const Image& b) {
    double sum = 0;
    for (std::size_t i = 0; i < a.data.size(); ++i) sum += std::abs(a.data[i] - b.data[i]);
    return sum / double(a.data.size());
  };
  const model::Primitives before = scene(7);
  model::Primitives corrected = before;
  std::mt19937_64 rng(11);
  relocate(corrected, RelocationScore::kOpacityTimesDuration, 0.01, rng);
  // Same draws without the correction: copy the sources as they were.
  model::Primitives naive = before;
  std::mt19937_64 rng2(11);
  model::Primitives scratch = before;
  const Relocation r = relocate(scratch, RelocationScore::kOpacityTimesDuration, 0.01, rng2);
  for (std::size_t k = 0; k < r.moved; ++k)
    naive.copy_row(r.touched[k], before, r.touched[r.moved + k]);
  const Image reference = render(before);
  const double with = diff(render(corrected), reference), without = diff(render(naive), reference);
  EXPECT_LT(with, 0.4 * without) << "with correction " << with << ", without " << without;
  EXPECT_LT(with, 0.01);
}

TEST(Relocation, GrowthTowardTheCap) {
  model::Primitives p = scene(2);
  std::mt19937_64 rng(5);
  const Relocation r = grow(p, RelocationScore::kOpacityTimesDuration, 310, 1.05, 0.01, rng);
  EXPECT_EQ(p.size(), 310u);  // min(cap, floor(1.05 * 300) = 315)
  EXPECT_EQ(r.added, 10u);
  const Relocation none = grow(p, RelocationScore::kOpacityTimesDuration, 310, 1.05, 0.01, rng);
  EXPECT_EQ(none.added, 0u);
  EXPECT_EQ(p.size(), 310u);
}

// Growth draws its sources by the score: of primitives alike but for their duration (1 or 8
// frames), the project's σ·(τ_l+τ_r) draws the long ones 8 times as often, the paper's
// σ/(τ_l+τ_r) the short ones, σ alone both alike.
TEST(Relocation, SourcesAreDrawnByTheScore) {
  const std::pair<RelocationScore, double> expected_short_share[] = {
      {RelocationScore::kOpacityTimesDuration, 1.0 / 9},
      {RelocationScore::kOpacityPerDuration, 8.0 / 9},
      {RelocationScore::kOpacity, 0.5}};
  for (const auto& [score, share] : expected_short_share) {
    model::Primitives p;
    p.resize(2000);
    for (std::size_t i = 0; i < p.size(); ++i) {
      p.q0[4 * i] = 1;
      p.tau_l[i] = p.tau_r[i] = i % 2 ? 4.0f : 0.5f;
    }
    std::mt19937_64 rng(7);
    const Relocation r = grow(p, score, 4000, 2.0, 0.01, rng);
    ASSERT_EQ(r.added, 2000u);
    std::size_t short_ones = 0;
    for (std::size_t i = 2000; i < p.size(); ++i) short_ones += p.tau_l[i] == 0.5f;
    EXPECT_NEAR(double(short_ones) / 2000, share, 0.04) << int(score);
  }
}

// Rows 0..9 (faint) are left out of the set: they do not move.
TEST(Relocation, NoiseMovesOnlyFaintPrimitivesOfTheGivenRows) {
  model::Primitives p = scene(3);
  const model::Primitives before = p;
  std::vector<std::int32_t> rows;
  for (std::size_t i = 10; i < p.size(); ++i) rows.push_back(std::int32_t(i));
  std::mt19937_64 rng(1);
  inject_noise(p, rows, 1.6e-4, rng);
  double faint = 0, solid = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double moved = std::abs(p.mu[3 * i] - before.mu[3 * i]);
    if (i < 10) {
      for (int a = 0; a < 3; ++a) ASSERT_EQ(p.mu[3 * i + a], before.mu[3 * i + a]) << i;
      continue;
    }
    (i < 40 ? faint : solid) += moved;
  }
  EXPECT_GT(faint / 30, 1e-5);
  EXPECT_LT(solid / 260, 1e-9 + 1e-3 * faint / 30);
}

// The noise is counter-based: one key drawn from the generator per call, the same perturbation
// for any thread count, and per row Σ ε with ε ~ N(0, I): for faint axis-aligned primitives of
// scales s, Δμ / (k s²) is standard normal per axis (mean, variance, tails, no correlation).
TEST(Relocation, NoiseIsThreadInvariantAndStandardNormal) {
  constexpr int kRows = 40000;
  constexpr double kLr = 1.6e-4, kLogit = -10.0, kScales[3] = {0.1, 0.2, 0.3};
  model::Primitives p;
  p.resize(kRows);
  std::vector<std::int32_t> rows;
  for (int i = 0; i < kRows; ++i) {
    p.q0[4 * i] = 1;
    for (int a = 0; a < 3; ++a) p.log_scale[3 * i + a] = float(std::log(kScales[a]));
    p.opacity_logit[i] = float(kLogit);
    rows.push_back(i);
  }
  const int threads_before = max_threads();
  std::vector<model::Primitives> moved;
  std::vector<std::mt19937_64> generators;
  for (const int threads : {1, 2, 3}) {
    set_threads(threads);
    moved.push_back(p);
    generators.emplace_back(9);
    inject_noise(moved.back(), rows, kLr, generators.back());
  }
  set_threads(threads_before);
  std::mt19937_64 one_draw(9);
  one_draw();
  for (std::size_t k = 1; k < moved.size(); ++k) {
    EXPECT_EQ(moved[k].mu, moved[0].mu) << k;
    EXPECT_EQ(generators[k], one_draw) << k;
  }
  const double sigma = 1 / (1 + std::exp(-kLogit));
  const double gate = 1 / (1 + std::exp(100 * (sigma - 0.005)));
  const double k = gate * kLr * 5e5;
  double mean[3] = {}, square[3] = {}, cross[3] = {};
  int tails = 0;
  for (int i = 0; i < kRows; ++i) {
    double eps[3];
    for (int a = 0; a < 3; ++a) {
      eps[a] = moved[0].mu[3 * i + a] / (k * kScales[a] * kScales[a]);
      mean[a] += eps[a] / kRows;
      square[a] += eps[a] * eps[a] / kRows;
      tails += std::abs(eps[a]) > 2;
    }
    for (int a = 0; a < 3; ++a) cross[a] += eps[a] * eps[(a + 1) % 3] / kRows;
  }
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(mean[a], 0, 0.025) << a;  // 5 standard errors
    EXPECT_NEAR(square[a], 1, 0.04) << a;
    EXPECT_NEAR(cross[a], 0, 0.025) << a;
  }
  EXPECT_NEAR(tails / (3.0 * kRows), 0.0455, 0.005);  // P(|ε| > 2)
}

// The end of training's clean-up takes exactly the rows below the opacity whose window spans at
// most one interval of the grid (Δt = 2 frames here); a window widened by stretching, or an
// opacity at or above the bound, keeps a row.
TEST(Relocation, FaintShortRowsAreTheFaintOnesOfOneInterval) {
  const model::TimeGrid grid{0.0, 2.0, 5};
  struct Row {
    double opacity, tau_l, tau_r;
    bool pruned;
  };
  const Row rows[] = {{0.01, 1.0, 1.0, true},   {0.049, 0.0, 2.0, true},  {0.049, 2.0, 0.0, true},
                      {0.051, 1.0, 1.0, false}, {0.01, 1.0, 3.0, false},  {0.01, 3.0, 1.0, false},
                      {0.9, 1.0, 1.0, false},   {0.0001, 0.5, 0.5, true}, {0.01, 1.0, 1.001, false},
                      {0.3, 8.0, 0.0, false}};
  model::Primitives p;
  p.resize(std::size(rows));
  std::vector<std::int32_t> expected;
  for (std::size_t i = 0; i < std::size(rows); ++i) {
    p.opacity_logit[i] = float(std::log(rows[i].opacity / (1 - rows[i].opacity)));
    p.tau_l[i] = float(rows[i].tau_l), p.tau_r[i] = float(rows[i].tau_r);
    if (rows[i].pruned) expected.push_back(std::int32_t(i));
  }
  EXPECT_EQ(faint_short_rows(p, grid, 0.05), expected);
  EXPECT_TRUE(faint_short_rows(p, grid, 0.0).empty());
}

}  // namespace
}  // namespace retimegs::train
