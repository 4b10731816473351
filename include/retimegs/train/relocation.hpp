#pragma once
// MCMC relocation and growth (3DGS-MCMC Eq. 9 as gsplat's MCMCStrategy implements it;
// docs/method.md) adapted to 4D primitives: dead slots (σ <= min_opacity) take copies of live
// primitives drawn ∝ a sampling score (RelocationScore), with the opacity / scale correction that
// keeps the rendered image unchanged to first order; every parameter is copied, the temporal ones
// too.
//
// The project's score departs from the paper's (σ / (τ_l + τ_r)). 3DGS-MCMC treats the
// primitives as samples of the scene's opacity and draws new ones where that mass is; in space-time
// a primitive's mass is σ times the time it is visible, and a slot spent on static content serves
// every frame it spans while a slot spent on one interval serves that interval only. Dividing by
// the duration, with a CPU-sized budget, leaves static backgrounds to a few large Gaussians (fog);
// see README, `retimegs train`.
#include <cstdint>
#include <random>
#include <vector>

#include "retimegs/core/hd.hpp"
#include "retimegs/model/primitives.hpp"

namespace retimegs::train {

// What a live primitive's chance to be copied is proportional to.
enum class RelocationScore {
  kOpacity,               // σ: the STGS baseline
  kOpacityTimesDuration,  // σ · (τ_l + τ_r), its opacity mass over time: the project's
  kOpacityPerDuration,    // σ / (τ_l + τ_r): the paper's (relocate_per_duration)
};

constexpr int kMaxCopies = 51;  // gsplat n_max: ratios are clamped to [1, 51]

struct Relocation {
  std::vector<std::int32_t> touched;  // rows whose parameters changed (sources and targets)
  std::size_t moved = 0;              // dead rows that received a copy
  std::size_t added = 0;              // rows appended by growth
};

// The three fields relocation and growth decide from, row by row: opacity logit, τ_l and τ_r.
struct RelocationFields {
  const float* opacity_logit = nullptr;
  const float* tau_l = nullptr;
  const float* tau_r = nullptr;
  std::size_t size = 0;
};

// Those of host rows.
RelocationFields relocation_fields(const model::Primitives& primitives);

// What relocation or growth does to the rows, decided from RelocationFields alone, so that the
// rows may live elsewhere (the CUDA step applies it to device rows). In order: the model is
// resized to `rows` (growth appends zero rows), each drawn source's opacity logit is set and
// its three log scales shifted (the correction for the copies it gets), then row from[k] is
// copied onto row to[k]. The to rows are distinct and never a source.
struct RowMoves {
  std::size_t rows = 0;
  std::vector<std::int32_t> sources;                        // distinct, ascending
  std::vector<float> source_logit, source_log_scale_shift;  // [sources]
  std::vector<std::int32_t> to, from;
  // Rows whose optimiser state restarts: the targets, then the sources once per copy.
  std::vector<std::int32_t> touched() const;
};

// A drawn source's correction for its copies (RowMoves): its opacity logit set, each of its three
// log scales shifted. Both devices apply it.
RETIMEGS_HD inline void correct_source(float logit, float log_scale_shift, float& opacity_logit,
                                       float* log_scale) {
  opacity_logit = logit;
  for (int a = 0; a < 3; ++a) log_scale[a] += log_scale_shift;
}

// Every dead row (σ <= min_opacity) takes a copy of a live one sampled with replacement ∝ score.
RowMoves relocation_moves(const RelocationFields& rows, RelocationScore score, double min_opacity,
                          std::mt19937_64& rng);
// Rows appended so that the count becomes min(cap, floor(growth · N)), each a copy of a live row
// sampled ∝ score.
RowMoves growth_moves(const RelocationFields& rows, RelocationScore score, std::size_t cap,
                      double growth, double min_opacity, std::mt19937_64& rng);
// The moves applied to host rows.
void apply(const RowMoves& moves, model::Primitives& primitives);

// σ_new = 1 - (1 - σ)^(1/n) and the scale factor σ / D (docs/method.md) for a source drawn so that
// it and its copies number n in total.
void mcmc_correction(double opacity, int n, double& new_opacity, double& scale_factor);

// Moves every dead primitive (σ <= min_opacity) onto a live one sampled with replacement ∝ score.
Relocation relocate(model::Primitives& primitives, RelocationScore score, double min_opacity,
                    std::mt19937_64& rng);

// Appends copies so that the count becomes min(cap, floor(growth · N)), sources sampled ∝ score.
Relocation grow(model::Primitives& primitives, RelocationScore score, std::size_t cap,
                double growth, double min_opacity, std::mt19937_64& rng);

// 3DGS-MCMC noise: μ += Σ ε · sigmoid(-100 (σ - 0.005)) · lr_means · 5e5, Σ = R diag(e^s)² Rᵀ,
// on the ascending `rows` only: a training step perturbs the primitives visible at its time, those
// its image loss and Adam step see. ε ~ N(0, I₃) is counter-based, a function of (key, row) with
// one 64-bit key drawn from `rng` per call (splitmix64 and Box–Muller), so that the rows are
// perturbed in parallel with the same result for any thread count.
void inject_noise(model::Primitives& primitives, const std::vector<std::int32_t>& rows,
                  double lr_means, std::mt19937_64& rng);

// The primitives for the end of training's clean-up, ascending: those fainter than max_opacity
// whose window [μ_τ - τ_l, μ_τ + τ_r] spans at most one training interval (never stretched). Such
// a primitive draws a faint patch for one interval and nothing else: relocation reuses slots only
// below min_opacity, noise pushes the faint ones around, and faint pieces that drifted off a fast
// object cross the static background between two training frames (the flicker that
// eval --stability measures). Opaque and long-lived primitives, static content among them, are
// never among them.
std::vector<std::int32_t> faint_short_rows(const model::Primitives& primitives,
                                           const model::TimeGrid& grid, double max_opacity);

}  // namespace retimegs::train
