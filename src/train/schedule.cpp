#include "retimegs/train/schedule.hpp"

#include <algorithm>
#include <cmath>

namespace retimegs::train {

std::vector<RenderPass> render_passes(const TrainConfig& config,
                                      model::Representation representation, int i, int frames,
                                      bool flow, bool on_grid) {
  if (!on_grid) return {{model::Group::kAll, false, true, false}};
  if (representation == model::Representation::kStgs || i == 0 || i + 1 >= frames)
    return {{model::Group::kAll, false, true, flow}};
  const bool image = !config.ablate.no_triple;
  if (!image && !flow) return {{model::Group::kAll, false, true, false}};
  return {{model::Group::kAll, false, true, false},
          {model::Group::kLeft, true, image, flow},
          {model::Group::kRight, true, image, flow}};
}

double flow_weight(const TrainConfig& config, model::Representation representation, int it) {
  if (config.ablate.no_flow_loss || representation == model::Representation::kStgs) return 0;
  // The fraction s of the exponential decay done at `it`.
  const int milestone = config.scaled(config.flow_decay_until);
  double s = std::min(1.0, double(it) / milestone);
  if (config.flow_hold)
    s = it <= milestone || config.iters <= milestone
            ? 0.0
            : double(it - milestone) / double(config.iters - milestone);
  return std::exp(std::log(config.flow_weight_start) +
                  s * (std::log(config.flow_weight_end) - std::log(config.flow_weight_start)));
}

double lr_factor(const TrainConfig& config, int it) {
  const int start = config.scaled(config.lr_decay_start);
  if (it <= start || config.iters <= start) return 1.0;
  return std::pow(config.lr_decay_final, double(it - start) / double(config.iters - start));
}

double means_decay(const TrainConfig& config, int it) {
  return std::pow(config.lr_means_final, double(it) / config.iters);
}

int sh_degree(const TrainConfig& config, int it) {
  return std::min(config.max_sh_degree, it / config.scaled(config.sh_degree_every));
}

}  // namespace retimegs::train
