#pragma once
// Which primitives a training step at t_i can touch: the rows whose temporal window reaches t_i,
// so that a step costs what is visible at its time, not what the model holds (training
// throughput). Built once per change of the windows (relocation copies them, stretching widens
// them); the rows of each training frame are listed in ascending order.
#include <cstdint>
#include <vector>

#include "retimegs/model/primitives.hpp"
#include "retimegs/model/slice.hpp"

namespace retimegs::model {

// The fields the index reads, row by row: each row's window (μ_τ, τ_l, τ_r).
template <typename T>
struct WindowFields {
  const T* mu_tau = nullptr;
  const T* tau_l = nullptr;
  const T* tau_r = nullptr;
  std::size_t size = 0;
};

class TemporalIndex {
 public:
  TemporalIndex() = default;
  // Retime: frame i lists every row with σ_τ(t_i) >= min_opacity (the slice cut: σ ≤ 1, so a
  // row below it is left out of every plain render at t_i) and every member of the left or right
  // group at t_i (compensated group renders draw them whatever their σ_τ). The window is
  // log-concave, hence unimodal in t: each row's frames are found by walking out from its mode,
  // so building costs O(N + entries), not O(N × frames). σ_τ is computed in T exactly as slice
  // computes it. STGS optimises μ_τ and the temporal scale every step, so every row is active at
  // every frame.
  template <typename T>
  TemporalIndex(const PrimitivesT<T>& primitives, const ModelConfig& config, const TimeGrid& grid,
                double min_opacity = SliceOptions{}.min_opacity)
      : TemporalIndex(WindowFields<T>{primitives.mu_tau.data(), primitives.tau_l.data(),
                                      primitives.tau_r.data(), primitives.size()},
                      config, grid, min_opacity) {}
  // The same from the window fields alone (rows that live elsewhere: the CUDA step's).
  template <typename T>
  TemporalIndex(const WindowFields<T>& windows, const ModelConfig& config, const TimeGrid& grid,
                double min_opacity = SliceOptions{}.min_opacity);

  // The ascending rows that can take part in any render at training time grid.at(frame).
  // Throws Error for a frame outside the grid.
  const std::vector<std::int32_t>& rows_at(int frame) const;
  int frames() const { return frames_; }

  // A row order in which every frame's rows form few dense runs: old_from_new, the rows stably
  // sorted by the first, then the last frame that lists them (rows no frame lists last). A step
  // reads and writes its active rows' fields, gradients and optimiser moments; scattered rows cost
  // a cache line per field each, sorted rows stream. With the rows in this order, frame j's rows
  // are at most j + 1 runs. The identity for STGS, whose every row is active at every frame.
  std::vector<std::int32_t> locality_order() const;

 private:
  int frames_ = 0;
  std::size_t size_ = 0;                         // rows indexed
  bool every_row_ = false;                       // STGS: one list, all rows, for every frame
  std::vector<std::vector<std::int32_t>> rows_;  // [frames] (one when every_row_)
};

}  // namespace retimegs::model
