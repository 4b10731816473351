#pragma once
// Dynamic stretching (docs/method.md, paper §3.3.3): at every training frame t_b, primitives whose
// support ends at t_b are matched with their nearest neighbour (position at t_b) among those whose
// support starts there. A pair with similar base colour (SH degree 0) and near-zero velocity gets
// the union of both supports (μ_τ stays; τ_l, τ_r grow), so static content ends up represented by
// long-lived primitives. Each primitive is then pruned with probability 1 − 1/(k + 1), k = how
// many others matched it; a pruned primitive is made dead (σ below the relocation threshold) and
// relocation reuses its slot. A primitive all of whose partners were pruned is kept, so a merged
// pair never vanishes entirely.
#include <cstdint>
#include <random>
#include <vector>

#include "retimegs/model/primitives.hpp"

namespace retimegs::train {

struct StretchSettings {
  double max_distance;      // world units
  double max_color;         // max |Δ RGB| of the DC colours
  double max_speed;         // world units per frame, for every velocity v1, v2, v3
  double dead_logit = -10;  // σ ≈ 4.5e-5: invisible and below any relocation threshold
};

struct StretchResult {
  std::size_t pairs = 0, stretched = 0, pruned = 0;
};

StretchResult stretch(model::Primitives& primitives, const model::ModelConfig& config,
                      const model::TimeGrid& grid, const StretchSettings& settings,
                      std::mt19937_64& rng);

}  // namespace retimegs::train
