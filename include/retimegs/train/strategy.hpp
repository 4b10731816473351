#pragma once
// What gsplat's MCMCStrategy.step_post_backward and LichtFeld-Studio's IStrategy do: the training
// step computes gradients and calls the optimiser; when to relocate, grow, add noise or stretch,
// and what that does to the optimiser's state, lives in one place with its own tests.
#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

#include "retimegs/model/model_file.hpp"
#include "retimegs/train/adam.hpp"
#include "retimegs/train/config.hpp"
#include "retimegs/train/relocation.hpp"

namespace retimegs::train {

// What one call changed, for the training log.
struct DensityChanges {
  std::size_t relocated = 0, added = 0, stretched = 0, pruned = 0;
};

// Rows that relocation and growth act on where they live: the host's (McmcStrategy::reshape) or
// the CUDA step's. The moves are decided on the host from three fields of every row.
class RelocatableRows {
 public:
  virtual ~RelocatableRows() = default;
  // The rows' opacity logits and window halves as they are now.
  virtual RelocationFields fields() = 0;
  // The moves applied to the rows, and the touched rows' optimiser state restarted (zero
  // moments, as appended rows have).
  virtual void apply(const RowMoves& moves) = 0;
};

class DensityStrategy {
 public:
  virtual ~DensityStrategy() = default;
  // Runs after the optimiser step of `iteration` (counted from 1), whose means' learning rate was
  // `lr_means` and whose active set (model::TemporalIndex) was the ascending `active` rows. Keeps
  // `optimizers` sized to the primitives.
  virtual DensityChanges after_step(int iteration, double lr_means,
                                    const std::vector<std::int32_t>& active, model::Model& model,
                                    Optimizers& optimizers, std::mt19937_64& rng) = 0;
};

// The MCMC schedule of RetimeGS (docs/method.md), milestones in TrainConfig::scaled units:
//   every step: noise on the step's faint active primitives (inject_noise), scaled by the means'
//     learning rate;
//   every relocate_every steps strictly between relocate_start and relocate_stop: relocation of
//     the dead primitives, then growth towards the cap; every row whose parameters were replaced
//     or appended restarts with zero Adam moments, like a fresh parameter;
//   every stretch_every steps before the last (not for STGS, nor with the no_stretch ablation):
//     dynamic stretching. It changes only the windows, which are not optimised, and the opacity
//     of the primitives it prunes; their moments are reset when relocation reuses the slot.
// The order (noise, relocation, growth, stretching) fixes the draws from the generator.
class McmcStrategy final : public DensityStrategy {
 public:
  McmcStrategy(const TrainConfig& config, double scene_extent);

  DensityChanges after_step(int iteration, double lr_means, const std::vector<std::int32_t>& active,
                            model::Model& model, Optimizers& optimizers,
                            std::mt19937_64& rng) override;

  // after_step's parts for a step whose arrays live elsewhere (the CUDA step): the noise, with
  // its key drawn from the generator first, runs there every step; the rest is due at some
  // iterations only and runs here on a host copy of the model and optimisers.
  bool reshapes_at(int iteration) const;
  // Relocation, growth and stretching as after_step does them after its noise.
  DensityChanges reshape(int iteration, model::Model& model, Optimizers& optimizers,
                         std::mt19937_64& rng);
  // reshape's parts: relocation then growth, on rows that may live elsewhere; stretching, which
  // reads and writes whole rows, on the host's.
  bool relocates_at(int iteration) const;
  bool stretches_at(int iteration, model::Representation representation) const;
  DensityChanges relocate_and_grow(RelocatableRows& rows, model::Representation representation,
                                   std::mt19937_64& rng) const;

 private:
  TrainConfig config_;
  double scene_extent_;
};

}  // namespace retimegs::train
