#include "retimegs/train/strategy.hpp"

#include "retimegs/train/relocation.hpp"
#include "retimegs/train/stretch.hpp"

namespace retimegs::train {

McmcStrategy::McmcStrategy(const TrainConfig& config, double scene_extent)
    : config_(config), scene_extent_(scene_extent) {}

DensityChanges McmcStrategy::after_step(int it, double lr_means,
                                        const std::vector<std::int32_t>& active,
                                        model::Model& model, Optimizers& optimizers,
                                        std::mt19937_64& rng) {
  inject_noise(model.primitives, active, lr_means, rng);
  return reshape(it, model, optimizers, rng);
}

bool McmcStrategy::relocates_at(int it) const {
  return it % config_.scaled(config_.relocate_every) == 0 &&
         it > config_.scaled(config_.relocate_start) && it < config_.scaled(config_.relocate_stop);
}

bool McmcStrategy::stretches_at(int it, model::Representation rep) const {
  return rep != model::Representation::kStgs && !config_.ablate.no_stretch &&
         it % config_.scaled(config_.stretch_every) == 0 && it < config_.iters;
}

bool McmcStrategy::reshapes_at(int it) const {
  return relocates_at(it) || stretches_at(it, config_.model_config().representation);
}

DensityChanges McmcStrategy::reshape(int it, model::Model& model, Optimizers& optimizers,
                                     std::mt19937_64& rng) {
  DensityChanges changes;
  model::Primitives& p = model.primitives;
  const model::Representation rep = model.config.representation;
  if (relocates_at(it)) {
    const RelocationScore score = rep == model::Representation::kStgs ? RelocationScore::kOpacity
                                  : config_.relocate_per_duration
                                      ? RelocationScore::kOpacityPerDuration
                                      : RelocationScore::kOpacityTimesDuration;
    const Relocation moved = relocate(p, score, config_.min_opacity, rng);
    const Relocation grown = grow(p, score, config_.cap, config_.growth, config_.min_opacity, rng);
    optimizers.reset_rows(moved.touched);
    optimizers.resize(p.size());
    optimizers.reset_rows(grown.touched);
    changes.relocated = moved.moved, changes.added = grown.added;
  }
  if (stretches_at(it, rep)) {
    const StretchSettings settings{config_.stretch_distance * scene_extent_, config_.stretch_color,
                                   config_.stretch_speed * scene_extent_};
    const StretchResult s = stretch(p, model.config, model.grid, settings, rng);
    changes.stretched = s.stretched, changes.pruned = s.pruned;
  }
  return changes;
}

}  // namespace retimegs::train
