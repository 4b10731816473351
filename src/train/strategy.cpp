#include "retimegs/train/strategy.hpp"

#include "retimegs/train/relocation.hpp"
#include "retimegs/train/stretch.hpp"

namespace retimegs::train {

namespace {

// The host's rows and their optimisers.
class HostRows final : public RelocatableRows {
 public:
  HostRows(model::Primitives& primitives, Optimizers& optimizers)
      : primitives_(primitives), optimizers_(optimizers) {}
  RelocationFields fields() override { return relocation_fields(primitives_); }
  void apply(const RowMoves& moves) override {
    train::apply(moves, primitives_);
    optimizers_.resize(primitives_.size());
    optimizers_.reset_rows(moves.touched());
  }

 private:
  model::Primitives& primitives_;
  Optimizers& optimizers_;
};

}  // namespace

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

DensityChanges McmcStrategy::relocate_and_grow(RelocatableRows& rows, model::Representation rep,
                                               std::mt19937_64& rng) const {
  const RelocationScore score = rep == model::Representation::kStgs ? RelocationScore::kOpacity
                                : config_.relocate_per_duration
                                    ? RelocationScore::kOpacityPerDuration
                                    : RelocationScore::kOpacityTimesDuration;
  DensityChanges changes;
  const RowMoves moved = relocation_moves(rows.fields(), score, config_.min_opacity, rng);
  rows.apply(moved);
  const RowMoves grown =
      growth_moves(rows.fields(), score, config_.cap, config_.growth, config_.min_opacity, rng);
  rows.apply(grown);
  changes.relocated = moved.to.size(), changes.added = grown.to.size();
  return changes;
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
    HostRows rows(p, optimizers);
    changes = relocate_and_grow(rows, rep, rng);
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
