#include "retimegs/model/merge.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <map>
#include <numeric>

#include <fmt/format.h>

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
                   std::optional<double> seam_fade) {
  if (windows.empty()) fail("merge: no models given");
  if (seam_fade) check_seam_fade(*seam_fade, "merge: seam fade");
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
  // Where consecutive windows hand over: the middle of the training frames both trained (rounded
  // down to a training frame), their shared boundary frame where they only touch. Since each
  // window starts and ends after the previous one, the seams ascend and each window keeps the
  // frames between its two, which it trained.
  std::vector<int> handovers;
  std::vector<bool> overlapping;
  for (std::size_t k = 0; k + 1 < order.size(); ++k) {
    const std::size_t a = order[k], b = order[k + 1];
    const TimeWindow wa = window_of(windows[a]), wb = window_of(windows[b]);
    const auto frames = [&](const TimeWindow& w) {
      return fmt::format("frames {}..{}", grid.at(w.first), grid.at(w.last));
    };
    if (wb.first > wa.last)
      fail(
          "merge: {} ({}) and {} ({}) leave a gap: consecutive windows share at least their "
          "boundary frame",
          names[a], frames(wa), names[b], frames(wb));
    if (wb.first == wa.first || wb.last <= wa.last)
      fail("merge: {} ({}) and {} ({}) overlap: one window holds the other", names[a], frames(wa),
           names[b], frames(wb));
    handovers.push_back((wb.first + wa.last) / 2);
    overlapping.push_back(wb.first < wa.last);
  }

  Model merged;
  const Model& first = windows[order.front()];
  merged.grid = grid;
  merged.config = first.config;
  merged.config.seams.clear();
  const bool any_overlap =
      std::find(overlapping.begin(), overlapping.end(), true) != overlapping.end();
  merged.config.seam_fade =
      seam_fade.value_or(any_overlap ? kDefaultOverlapSeamFade : kDefaultSeamFade);
  merged.training_config = first.training_config;
  // Each window's rows between its hand-overs: a row beyond one is dropped (the neighbour's
  // reconstruction covers that time) and a support that crosses one ends there, where the seam's
  // fade hands over. Only the support changes; the trajectory keeps its μ_τ, which may then lie
  // outside the support (a negative half-width). Where the windows overlap, an edge that already
  // ended at the seam moves 2ε off it, beyond RetimeWindow::edge_scale's reach: it keeps γ, since
  // the fade would draw its trajectory where it was never trained (merge.hpp).
  const double epsilon = first.config.epsilon;
  const double inf = std::numeric_limits<double>::infinity();
  std::size_t total = 0, row = 0;
  for (const Model& m : windows) total += m.primitives.size();
  merged.primitives.resize(total);
  for (std::size_t k = 0; k < order.size(); ++k) {
    const double from = k > 0 ? grid.at(handovers[k - 1]) : -inf;
    const double to = k + 1 < order.size() ? grid.at(handovers[k]) : inf;
    const bool nudge_from = k > 0 && overlapping[k - 1];
    const bool nudge_to = k + 1 < order.size() && overlapping[k];
    const Primitives& p = windows[order[k]].primitives;
    for (std::size_t i = 0; i < p.size(); ++i) {
      throw_if_interrupted_every(i);
      const double mu_tau = p.mu_tau[i];
      const double lo = mu_tau - p.tau_l[i], hi = mu_tau + p.tau_r[i];
      if (hi <= from + epsilon || lo >= to - epsilon) continue;
      merged.primitives.copy_row(row, p, i);
      if (lo < from - epsilon)
        merged.primitives.tau_l[row] = float(mu_tau - from);
      else if (nudge_from && lo <= from + epsilon)
        merged.primitives.tau_l[row] = float(mu_tau - (from + 2 * epsilon));
      if (hi > to + epsilon)
        merged.primitives.tau_r[row] = float(to - mu_tau);
      else if (nudge_to && hi >= to - epsilon)
        merged.primitives.tau_r[row] = float((to - 2 * epsilon) - mu_tau);
      ++row;
    }
  }
  merged.primitives.resize(row);
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
  // Seams: the hand-overs and each window's own (a merged model merged again) between them, where
  // its rows are kept.
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (k > 0) merged.config.seams.push_back(handovers[k - 1]);
    for (const int seam : windows[order[k]].config.seams)
      if ((k == 0 || seam > handovers[k - 1]) && (k + 1 == order.size() || seam < handovers[k]))
        merged.config.seams.push_back(seam);
  }
  if (merged.config.seams.size() > std::size_t(kMaxSeams))
    fail("merge: {} seams, more than {} (at most {} windows)", merged.config.seams.size(),
         kMaxSeams, kMaxSeams + 1);
  const TimeWindow span{window_of(first).first, window_of(windows[order.back()]).last};
  if (span.first > 0 || span.last < grid.count - 1) merged.window = span;
  return merged;
}

}  // namespace retimegs::model
