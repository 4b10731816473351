#include "retimegs/model/merge.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>

#include <fmt/format.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/interrupt.hpp"
#include "retimegs/core/limits.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/model/trajectory.hpp"

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

// How far a seam's fade shows an edge's primitive beyond the seam, in the seam's sigmoid scales
// (ψ(-2) = 0.12), and how far it may move there, in its largest axis, to count as staying put.
constexpr double kFadeReach = 2;
constexpr double kStillShare = 0.5;

// Whether primitive i stays in place between times `edge` and `beyond`: its mean moves less than
// kStillShare of its largest axis (merge.hpp).
bool stays_put(const Primitives& p, std::size_t i, const ModelConfig& config, const TimeGrid& grid,
               double edge, double beyond) {
  const auto place = [&](double t, float x[3]) {
    apply_trajectory(trajectory_at(config.representation, config.trajectory, p.mu_tau[i], float(t),
                                   float(grid.step)),
                     &p.mu[3 * i], &p.velocity[9 * i], x);
  };
  float there[3], later[3];
  place(edge, there);
  place(beyond, later);
  double moved2 = 0;
  float largest = p.log_scale[3 * i];
  for (int a = 0; a < 3; ++a) {
    moved2 += double(later[a] - there[a]) * (later[a] - there[a]);
    largest = std::max(largest, p.log_scale[3 * i + a]);
  }
  return std::sqrt(moved2) < kStillShare * std::exp(double(largest));
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
  }

  Model merged;
  const Model& first = windows[order.front()];
  merged.grid = grid;
  merged.config = first.config;
  merged.config.seams.clear();
  merged.config.seam_fade = seam_fade.value_or(kDefaultSeamFade);
  merged.training_config = first.training_config;
  // Each window's rows between its hand-overs: a row beyond one is dropped (the neighbour's
  // reconstruction covers that time) and a support that crosses one ends there, where the seam's
  // fade hands over. Only the support changes; the trajectory keeps its μ_τ, which may then lie
  // outside the support (a negative half-width). An edge that already ended at the seam moves 2ε
  // off it, beyond RetimeWindow::edge_scale's reach, unless its primitive stays put: it keeps γ,
  // since the fade would draw its trajectory where it was never trained (merge.hpp).
  const double epsilon = first.config.epsilon;
  const double inf = std::numeric_limits<double>::infinity();
  const bool fading = merged.config.seam_fade > 0;
  const double reach = kFadeReach * seam_scale_frames(merged.config, grid);
  std::size_t total = 0, row = 0;
  for (const Model& m : windows) total += m.primitives.size();
  merged.primitives.resize(total);
  for (std::size_t k = 0; k < order.size(); ++k) {
    const double from = k > 0 ? grid.at(handovers[k - 1]) : -inf;
    const double to = k + 1 < order.size() ? grid.at(handovers[k]) : inf;
    const Primitives& p = windows[order[k]].primitives;
    for (std::size_t i = 0; i < p.size(); ++i) {
      throw_if_interrupted_every(i);
      const double mu_tau = p.mu_tau[i];
      const double lo = mu_tau - p.tau_l[i], hi = mu_tau + p.tau_r[i];
      if (hi <= from + epsilon || lo >= to - epsilon) continue;
      merged.primitives.copy_row(row, p, i);
      if (lo < from - epsilon)
        merged.primitives.tau_l[row] = float(mu_tau - from);
      else if (fading && lo <= from + epsilon &&
               !stays_put(p, i, merged.config, grid, from, from - reach))
        merged.primitives.tau_l[row] = float(mu_tau - (from + 2 * epsilon));
      if (hi > to + epsilon)
        merged.primitives.tau_r[row] = float(to - mu_tau);
      else if (fading && hi >= to - epsilon &&
               !stays_put(p, i, merged.config, grid, to, to + reach))
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
  // Pose corrections, by the colour maps' rule: per camera, the interval-weighted mean of the ω and
  // of the τ of the windows that refined it. Corrections are small (a few pixels, under a degree),
  // where the mean of the axis-angle vectors is the mean rotation to first order; a mean of
  // vectors shorter than π is shorter than π, as check_camera_pose asks.
  std::map<std::string, std::pair<std::array<double, 6>, double>> pose_sums;  // ω, τ; weight
  for (const Model& m : windows) {
    const TimeWindow w = window_of(m);
    const double weight = w.last - w.first;
    for (const auto& [camera, pose] : m.camera_poses) {
      auto& [sum, total_weight] = pose_sums[camera];
      for (int k = 0; k < 3; ++k) {
        sum[k] += weight * pose.rotation[k];
        sum[3 + k] += weight * pose.translation[k];
      }
      total_weight += weight;
    }
  }
  for (const auto& [camera, entry] : pose_sums) {
    CameraPose& pose = merged.camera_poses[camera];
    for (int k = 0; k < 3; ++k) {
      pose.rotation[k] = entry.first[k] / entry.second;
      pose.translation[k] = entry.first[3 + k] / entry.second;
    }
  }
  // Clock corrections likewise: per camera, the interval-weighted mean of the windows' δ.
  std::map<std::string, std::pair<double, double>> clock_sums;  // Σ weight δ, Σ weight
  for (const Model& m : windows) {
    const TimeWindow w = window_of(m);
    for (const auto& [camera, delta] : m.camera_clocks) {
      clock_sums[camera].first += (w.last - w.first) * delta;
      clock_sums[camera].second += w.last - w.first;
    }
  }
  for (const auto& [camera, entry] : clock_sums)
    merged.camera_clocks[camera] = entry.first / entry.second;
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
