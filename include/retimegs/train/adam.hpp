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
//
// Momentum catch-up (lazy rows). Within the active set, most rows of a real capture get no
// gradient from the step's camera (culled, off screen). Dense Adam still moves such a row on its
// momentum and decays both moments; streaming its parameters and moments for that costs as much as
// a real update. A lazy field instead counts the active steps a row missed (`pending`) and, when
// the row next has a gradient or the trainer needs every row current (catch_up), applies them in
// closed form: after k steps without gradient from (m, v), dense Adam has m β1^k, v β2^k and has
// moved the parameter by -lr/c1 · Σ_{j=1..k} β1^j m / (β2^(j/2) sqrt(v)/sqrt(c2) + ε)
// = -lr sqrt(c2)/c1 · m/sqrt(v) · Σ_{j=1..k} (β1/sqrt(β2))^j. The catch-up takes the rate of the
// step that applies it and the bias corrections c1, c2 of the first missed step, where the
// geometric weights put most of the move (exact where they are constant over the gap, as after
// the first few thousand steps), and ε at the start of the gap. A row's missed steps are its own
// active steps, so a row that is never active keeps its state, as above.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "retimegs/model/primitives.hpp"
#include "retimegs/train/config.hpp"

namespace retimegs::train {

struct AdamSettings {
  double beta1 = 0.9, beta2 = 0.999;
  double epsilon = 1e-15;  // gsplat's default for Gaussian splats (torch's 1e-8 is too large)
};

class Adam {
 public:
  Adam() = default;
  // column_scale [width] (optional) multiplies the learning rate per column, e.g. the higher SH
  // bands' 1/20 of the DC rate in one [N, 16, 3] field.
  Adam(std::size_t rows, int width, AdamSettings settings = {},
       std::vector<float> column_scale = {});

  // params -= lr · s_col · m̂ / (sqrt(v̂) + ε) over the ascending `rows` (nullptr: all rows);
  // params and grads are [rows(), width].
  void step(float* params, const float* grads, double lr,
            const std::vector<std::int32_t>* rows = nullptr);
  // The same step, then the stepped rows' gradients set to zero in the same pass (a training
  // step's gradient buffer is cleared where it was read, without a pass of its own).
  void step_and_clear(float* params, float* grads, double lr,
                      const std::vector<std::int32_t>* rows = nullptr);
  // Missed steps of lazy rows, kept by the caller (Optimizers) per row: how many, and the step
  // count at the first of them.
  struct Pending {
    const std::int32_t* count;
    const std::int32_t* first;
  };
  // The lazy step: of the `rows`, only those with touched[r] != 0 are read; each first catches up
  // its pending missed steps, then steps with its gradient (which it clears).
  void step_lazy(float* params, float* grads, double lr, const std::vector<std::int32_t>& rows,
                 const std::uint8_t* touched, Pending pending);
  // Applies every row's pending missed steps at rate lr (see above).
  void catch_up(float* params, double lr, Pending pending);
  // Zeroes the moments of the given rows (their parameters were replaced).
  void reset_rows(const std::vector<std::int32_t>& rows);
  // Grows (zero state) or shrinks to `rows` rows.
  void resize(std::size_t rows);
  // Moves the rows' moments with their parameters (model::PrimitivesT::reorder).
  void reorder(const std::vector<std::int32_t>& old_from_new);

  std::size_t rows() const { return width_ ? m_.size() / width_ : 0; }
  std::int64_t steps() const { return steps_; }
  // State, for checkpoints.
  std::vector<float>& m() { return m_; }
  std::vector<float>& v() { return v_; }
  const std::vector<float>& m() const { return m_; }
  const std::vector<float>& v() const { return v_; }
  std::int64_t& step_count() { return steps_; }

 private:
  template <bool kClear, typename G>
  void update(float* params, G* grads, double lr, const std::vector<std::int32_t>* rows,
              const std::uint8_t* touched = nullptr, Pending pending = {});
  // lr / c1 and 1 / sqrt(c2) at step count `step`.
  void rates(double lr, std::int64_t step, float& step_size, float& inv_sqrt_c2) const;
  // Row r's pending missed steps, if any.
  void catch_up_row(float* params, std::size_t r, double lr, Pending pending);

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
  // the optimised fields zero. With `touched` [primitives] (a row had a renderer gradient this
  // step), the fields that only the renders differentiate (every field but the regularised
  // log_scale and opacity_logit) step lazily: the rows not touched only count a missed step.
  void step(model::Primitives& primitives, model::PrimitiveGrads& grads,
            const std::vector<std::int32_t>& rows, double means_decay, double decay,
            const std::vector<std::uint8_t>* touched = nullptr);
  // Brings every row's parameters and moments up to date (the missed steps of lazy rows, at the
  // last step's rates): before anything reads, copies or saves the primitives as a whole.
  void catch_up(model::Primitives& primitives);
  // Rows with missed steps not yet applied.
  std::size_t pending_rows() const;
  // The lazy state, for checkpoints: per row the missed steps and the step count at the first of
  // them (empty before the first lazy step), per group the rate of the last step.
  std::vector<std::int32_t>& pending() { return pending_; }
  std::vector<std::int32_t>& first_missed() { return first_missed_; }
  std::vector<double>& last_rates() { return last_rates_; }
  const std::vector<std::int32_t>& pending() const { return pending_; }
  const std::vector<std::int32_t>& first_missed() const { return first_missed_; }
  const std::vector<double>& last_rates() const { return last_rates_; }
  // The means' rate of a step with these factors.
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
  std::vector<double> last_rates_;  // per group: the rate of the last step
  // [rows] active steps missed by the lazy fields, and the step count at the first of them
  std::vector<std::int32_t> pending_;
  std::vector<std::int32_t> first_missed_;
};

}  // namespace retimegs::train
