#include "retimegs/model/temporal_index.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "retimegs/core/error.hpp"
#include "retimegs/model/temporal_opacity.hpp"

namespace retimegs::model {

namespace {

// Frames lo..hi (empty when lo > hi).
struct FrameRange {
  int lo = 0, hi = -1;
  bool empty() const { return lo > hi; }
  bool contains(int frame) const { return lo <= frame && frame <= hi; }
};

// The smallest range holding both.
FrameRange hull(const FrameRange& a, const FrameRange& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  return {std::min(a.lo, b.lo), std::max(a.hi, b.hi)};
}

// The frames where `holds` is true, given that they form one run (or none) and that the run, if
// any, contains the time `centre`: the frames next to `centre` (one further on each side, so that
// rounding in the frame position cannot skip the run) are tried, then the run is walked out.
template <typename Holds>
FrameRange frames_around(double centre, const TimeGrid& grid, const Holds& holds) {
  const double k = std::clamp((centre - grid.first) / grid.step, -2.0, double(grid.count) + 1);
  const int first = std::clamp(int(std::floor(k)) - 1, 0, grid.count - 1);
  const int last = std::clamp(int(std::ceil(k)) + 1, 0, grid.count - 1);
  FrameRange run{grid.count, -1};
  for (int j = first; j <= last; ++j)
    if (holds(j)) run.lo = std::min(run.lo, j), run.hi = std::max(run.hi, j);
  if (run.empty()) return {};
  while (run.lo > 0 && holds(run.lo - 1)) --run.lo;
  while (run.hi + 1 < grid.count && holds(run.hi + 1)) ++run.hi;
  return run;
}

}  // namespace

template <typename T>
TemporalIndex::TemporalIndex(const WindowFields<T>& p, const ModelConfig& config,
                             const TimeGrid& grid, double min_opacity)
    : frames_(grid.count), size_(p.size) {
  const std::size_t n = p.size;
  if (config.representation == Representation::kStgs) {
    every_row_ = true;
    rows_.assign(1, std::vector<std::int32_t>(n));
    std::iota(rows_[0].begin(), rows_[0].end(), 0);
    return;
  }
  // Per row: the frames where σ_τ reaches min_opacity, and the frames inside the support (up to
  // ε), whose runs of two or more are where the row is in the left or right group.
  std::vector<FrameRange> visible(n), support(n);
  const double inf = std::numeric_limits<double>::infinity();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) {
    const RetimeWindow<T> w = retime_window<T>(p.mu_tau[i], p.tau_l[i], p.tau_r[i], config, grid);
    // Both edges closed: σ_τ is symmetric about the support's midpoint, its mode. One edge open:
    // σ_τ is monotone, its mode at that end. Both open: σ_τ ≡ 1. (Rounding in T cannot split
    // the run: near 1/255 adjacent training times' σ_τ differ by a factor of about e^(Δt/γ),
    // far beyond one rounding step for any γ below the clip's length.)
    const double midpoint = double(w.mu_tau) + 0.5 * (double(w.tau_r) - double(w.tau_l));
    const double mode = w.open_left() == w.open_right() ? midpoint : w.open_left() ? -inf : inf;
    visible[i] = frames_around(
        mode, grid, [&](int j) { return double(w(T(grid.at(j)))) >= double(T(min_opacity)); });
    const FrameRange inside = frames_around(
        midpoint, grid, [&](int j) { return w.covers(T(grid.at(j)), T(grid.at(j))); });
    if (inside.hi > inside.lo) support[i] = inside;
  }
  // The rows of each frame in ascending order: count, then fill. Each row visits the frames of
  // its two ranges' hull, which is their union unless they leave a gap.
  const auto for_each_frame = [&](std::size_t i, const auto& body) {
    const FrameRange all = hull(visible[i], support[i]);
    for (int j = all.lo; j <= all.hi; ++j)
      if (visible[i].contains(j) || support[i].contains(j)) body(j);
  };
  std::vector<std::size_t> counts(grid.count, 0);
  for (std::size_t i = 0; i < n; ++i) for_each_frame(i, [&](int j) { ++counts[j]; });
  rows_.resize(grid.count);
  for (int j = 0; j < grid.count; ++j) rows_[j].reserve(counts[j]);
  for (std::size_t i = 0; i < n; ++i)
    for_each_frame(i, [&](int j) { rows_[j].push_back(std::int32_t(i)); });
}

const std::vector<std::int32_t>& TemporalIndex::rows_at(int frame) const {
  if (frame < 0 || frame >= frames_)
    fail("temporal index: frame {} is not among the {} training frames", frame, frames_);
  return rows_[every_row_ ? 0 : frame];
}

std::vector<std::int32_t> TemporalIndex::locality_order() const {
  std::vector<std::int32_t> old_from_new(size_);
  std::iota(old_from_new.begin(), old_from_new.end(), 0);
  if (every_row_) return old_from_new;
  const int none = frames_;  // sorts after every frame
  std::vector<int> first(size_, none), last(size_, none);
  for (int j = 0; j < frames_; ++j)
    for (const std::int32_t i : rows_[j]) {
      if (first[i] == none) first[i] = j;
      last[i] = j;
    }
  std::stable_sort(old_from_new.begin(), old_from_new.end(), [&](std::int32_t a, std::int32_t b) {
    return std::pair(first[a], last[a]) < std::pair(first[b], last[b]);
  });
  return old_from_new;
}

template TemporalIndex::TemporalIndex(const WindowFields<float>&, const ModelConfig&,
                                      const TimeGrid&, double);
template TemporalIndex::TemporalIndex(const WindowFields<double>&, const ModelConfig&,
                                      const TimeGrid&, double);

}  // namespace retimegs::model
