#include "retimegs/model/merge.hpp"

#include <algorithm>
#include <array>
#include <map>
#include <numeric>

#include "retimegs/core/error.hpp"
#include "retimegs/core/interrupt.hpp"
#include "retimegs/core/limits.hpp"

namespace retimegs::model {

namespace {

TimeWindow window_of(const Model& m) {
  return m.window.value_or(TimeWindow{0, m.grid.count - 1});
}

bool same_grid(const TimeGrid& a, const TimeGrid& b) {
  return a.first == b.first && a.step == b.step && a.count == b.count;
}

bool same_config(const ModelConfig& a, const ModelConfig& b) {
  return a.representation == b.representation && a.trajectory == b.trajectory &&
         a.gamma == b.gamma && a.epsilon == b.epsilon && a.sh_degree == b.sh_degree;
}

}  // namespace

Model merge_models(const std::vector<Model>& windows, const std::vector<std::string>& names,
                   double seam_fade) {
  if (windows.empty()) fail("merge: no models given");
  check_seam_fade(seam_fade, "merge: seam fade");
  if (names.size() != windows.size())
    fail("merge: {} models but {} names", windows.size(), names.size());
  for (std::size_t k = 0; k < windows.size(); ++k) {
    if (windows[k].config.representation == Representation::kStgs)
      fail("merge: {} is a SpacetimeGaussians baseline model; only RetimeGS windows merge",
           names[k]);
    const TimeGrid& a = windows[0].grid;
    const TimeGrid& b = windows[k].grid;
    if (!same_grid(a, b))
      fail(
          "merge: {} and {} have different time grids ({} frames from t = {} step {} vs {} from "
          "{} step {}): windows of one clip share its grid",
          names[0], names[k], a.count, a.first, a.step, b.count, b.first, b.step);
    if (!same_config(windows[0].config, windows[k].config))
      fail(
          "merge: {} and {} have different model settings (representation, trajectory, gamma, "
          "epsilon or SH degree)",
          names[0], names[k]);
  }
  std::vector<std::size_t> order(windows.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    return window_of(windows[x]).first < window_of(windows[y]).first;
  });
  const TimeGrid& grid = windows[0].grid;
  for (std::size_t k = 0; k + 1 < order.size(); ++k) {
    const std::size_t a = order[k], b = order[k + 1];
    const TimeWindow wa = window_of(windows[a]), wb = window_of(windows[b]);
    if (wb.first != wa.last)
      fail(
          "merge: {} (frames {}..{}) and {} (frames {}..{}) {}: consecutive windows share their "
          "boundary frame",
          names[a], grid.at(wa.first), grid.at(wa.last), names[b], grid.at(wb.first),
          grid.at(wb.last), wb.first < wa.last ? "overlap" : "leave a gap");
  }

  Model merged;
  const Model& first = windows[order.front()];
  merged.grid = grid;
  merged.config = first.config;
  merged.config.seams.clear();
  merged.config.seam_fade = seam_fade;
  merged.training_config = first.training_config;
  std::size_t total = 0;
  for (const Model& m : windows) total += m.primitives.size();
  merged.primitives.resize(total);
  std::size_t row = 0;
  for (const std::size_t k : order) {
    const Primitives& p = windows[k].primitives;
    for (std::size_t i = 0; i < p.size(); ++i) {
      throw_if_interrupted_every(i);
      merged.primitives.copy_row(row++, p, i);
    }
  }
  // Colour maps: per camera, the interval-weighted mean over the windows that learned one.
  std::map<std::string, std::pair<std::array<double, 6>, double>> sums;  // m, c; total weight
  for (const Model& m : windows) {
    const TimeWindow w = window_of(m);
    const double weight = w.last - w.first;
    for (const auto& [camera, color] : m.camera_colors) {
      auto& [sum, total_weight] = sums[camera];
      for (int c = 0; c < 3; ++c) {
        sum[c] += weight * color.m[c];
        sum[3 + c] += weight * color.c[c];
      }
      total_weight += weight;
    }
  }
  for (const auto& [camera, entry] : sums) {
    CameraColor& color = merged.camera_colors[camera];
    for (int c = 0; c < 3; ++c) {
      color.m[c] = float(entry.first[c] / entry.second);
      color.c[c] = float(entry.first[3 + c] / entry.second);
    }
  }
  // Seams: each window's own (a merged model merged again) and where consecutive windows meet.
  for (std::size_t k = 0; k < order.size(); ++k) {
    const Model& m = windows[order[k]];
    if (k > 0) merged.config.seams.push_back(window_of(m).first);
    merged.config.seams.insert(merged.config.seams.end(), m.config.seams.begin(),
                               m.config.seams.end());
  }
  if (merged.config.seams.size() > std::size_t(kMaxSeams))
    fail("merge: {} seams, more than {} (at most {} windows)", merged.config.seams.size(),
         kMaxSeams, kMaxSeams + 1);
  const TimeWindow span{window_of(first).first, window_of(windows[order.back()]).last};
  if (span.first > 0 || span.last < grid.count - 1) merged.window = span;
  return merged;
}

}  // namespace retimegs::model
