#pragma once
// Adam (Kingma & Ba) for one parameter group stored as rows of `width` floats, as torch.optim.Adam
// computes it (bias-corrected moments, ε added to the corrected square root). Rows can be reset
// (MCMC relocation) and appended (growth) with zero state. Optimizers holds one per optimised
// field of the primitives.
//
// Selective steps (gsplat's SelectiveAdam, Taming-3DGS): a step may update only a given set of
// rows, those the step could draw (model::TemporalIndex); the other rows keep their parameters
// and both moments as they are, rather than decaying their moments and moving on momentum alone
// while they are invisible. The bias correction uses the group's step count, which every step
// advances, as gsplat does. A row updated at every step evolves exactly as under dense Adam.
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "retimegs/model/primitives.hpp"
#include "retimegs/train/adam_update.hpp"
#include "retimegs/train/config.hpp"

namespace retimegs::train {

class Adam {
 public:
  Adam() = default;
  // column_scale [width] (optional) multiplies the learning rate per column, e.g. the higher SH
  // bands' 1/20 of the DC rate in one [N, 16, 3] field.
  // (Inline: the CUDA optimiser's tests build host groups without the train library.)
  Adam(std::size_t rows, int width, AdamSettings settings = {},
       std::vector<float> column_scale = {})
      : width_(width),
        settings_(settings),
        column_scale_(column_scale.empty() ? std::vector<float>(width, 1.0f)
                                           : std::move(column_scale)),
        m_(rows * width, 0.0f),
        v_(rows * width, 0.0f) {}

  // params -= lr · s_col · m̂ / (sqrt(v̂) + ε) over the ascending `rows` (nullptr: all rows);
  // params and grads are [rows(), width].
  void step(float* params, const float* grads, double lr,
            const std::vector<std::int32_t>* rows = nullptr);
  // The same step, then the stepped rows' gradients set to zero in the same pass (a training
  // step's gradient buffer is cleared where it was read, without a pass of its own).
  void step_and_clear(float* params, float* grads, double lr,
                      const std::vector<std::int32_t>* rows = nullptr);
  // Zeroes the moments of the given rows (their parameters were replaced).
  void reset_rows(const std::vector<std::int32_t>& rows);
  // Grows (zero state) or shrinks to `rows` rows.
  void resize(std::size_t rows);
  // Moves the rows' moments with their parameters (model::PrimitivesT::reorder).
  void reorder(const std::vector<std::int32_t>& old_from_new);

  std::size_t rows() const { return width_ ? m_.size() / width_ : 0; }
  int width() const { return width_; }
  const AdamSettings& settings() const { return settings_; }
  const std::vector<float>& column_scale() const { return column_scale_; }  // [width]
  std::int64_t steps() const { return steps_; }
  // State, for checkpoints.
  std::vector<float>& m() { return m_; }
  std::vector<float>& v() { return v_; }
  const std::vector<float>& m() const { return m_; }
  const std::vector<float>& v() const { return v_; }
  std::int64_t& step_count() { return steps_; }

 private:
  template <bool kClear, typename G>
  void update(float* params, G* grads, double lr, const std::vector<std::int32_t>* rows);

  int width_ = 0;
  AdamSettings settings_;
  std::vector<float> column_scale_;  // [width]
  std::vector<float> m_, v_;         // [rows, width]
  std::int64_t steps_ = 0;
};

// One Adam per optimised field (model::Primitives::fields() order: mu, velocity, log_scale, q0,
// q1, sh, opacity_logit, and for the STGS baseline mu_tau and temporal_log_scale), each with its
// base learning rate, built once per model: the config's rate, times the scene extent for means
// and velocities, over the frame step Δt for velocities and the rotation rate q1. The SH rest
// bands learn at lr_sh_rest_factor of the DC rate.
class Optimizers {
 public:
  // The field's name names its checkpoint files, adam/<name>_{m,v}.npy.
  struct Group {
    std::string name;
    Adam adam;
  };

  Optimizers() = default;
  Optimizers(const model::Primitives& primitives, model::Representation representation,
             const TrainConfig& config, double scene_extent, double frame_step);

  // One Adam step of every field over the ascending `rows` (the step's active set) at its base
  // rate × decay, and × means_decay too for means and velocities; leaves the rows' gradients of
  // the optimised fields zero.
  void step(model::Primitives& primitives, model::PrimitiveGrads& grads,
            const std::vector<std::int32_t>& rows, double means_decay, double decay);
  // The rate of group `group` (begin() order) in a step with these factors, and the means' rate.
  double rate(std::size_t group, double means_decay, double decay) const;
  double means_rate(double means_decay, double decay) const;
  // Every field: zero moments for `rows`; grow (zero state) or shrink to `rows` rows; rows moved.
  void reset_rows(const std::vector<std::int32_t>& rows);
  void resize(std::size_t rows);
  void reorder(const std::vector<std::int32_t>& old_from_new);

  // The (name, adam) groups, for checkpoints.
  std::vector<Group>::iterator begin() { return groups_.begin(); }
  std::vector<Group>::iterator end() { return groups_.end(); }
  std::vector<Group>::const_iterator begin() const { return groups_.begin(); }
  std::vector<Group>::const_iterator end() const { return groups_.end(); }

 private:
  std::vector<Group> groups_;
  std::vector<double> base_rates_;  // per group
};

}  // namespace retimegs::train
