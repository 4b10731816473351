#include "retimegs/model/window.hpp"

#include <cmath>

#include "retimegs/core/error.hpp"

namespace retimegs::model {

TimeGrid window_grid(const TimeGrid& clip, const TimeWindow& window) {
  if (!(window.first >= 0 && window.first < window.last && window.last < clip.count))
    fail("window {}..{} is not a run of the clip's {} training frames", window.first, window.last,
         clip.count);
  return {clip.at(window.first), clip.step, window.last - window.first + 1};
}

ModelConfig window_config(const ModelConfig& clip_config, const TimeGrid& clip,
                          const TimeGrid& window) {
  ModelConfig config = clip_config;
  config.gamma = clip_config.gamma * (clip.last() - clip.first) / (window.last() - window.first);
  // Seams index training frames: the window's grid starts `offset` frames into the clip's.
  const int offset = int(std::lround((window.first - clip.first) / clip.step));
  for (int& seam : config.seams) seam -= offset;
  return config;
}

Model window_view(const Model& model) {
  if (!model.window) return model;
  Model local = model;
  local.grid = window_grid(model.grid, *model.window);
  local.config = window_config(model.config, model.grid, local.grid);
  local.window.reset();
  return local;
}

Model with_window(Model local, const TimeGrid& clip, const ModelConfig& clip_config) {
  const double first = (local.grid.first - clip.first) / clip.step;
  const int i = int(std::lround(first));
  if (local.grid.step != clip.step || std::abs(first - i) > 1e-9 || i < 0 ||
      i + local.grid.count > clip.count || local.grid.count < 2)
    fail(
        "a model trained on {} training frames from t = {} (step {}) is not a window of the clip's "
        "{} frames from t = {} (step {})",
        local.grid.count, local.grid.first, local.grid.step, clip.count, clip.first, clip.step);
  const TimeWindow window{i, i + local.grid.count - 1};
  local.grid = clip;
  const int sh_degree = local.config.sh_degree;  // the degree training reached
  local.config = clip_config;
  local.config.sh_degree = sh_degree;
  if (window.first > 0 || window.last < clip.count - 1) local.window = window;
  return local;
}

}  // namespace retimegs::model
