#pragma once
// Adam (Kingma & Ba) for one parameter group stored as rows of `width` floats, as torch.optim.Adam
// computes it (bias-corrected moments, ε added to the corrected square root). Rows can be reset
// (MCMC relocation) and appended (growth) with zero state.
#include <cstddef>
#include <cstdint>
#include <vector>

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

  // params -= lr · s_col · m̂ / (sqrt(v̂) + ε) over all rows; params and grads are [rows, width].
  void step(float* params, const float* grads, double lr);
  // Zeroes the moments of the given rows (their parameters were replaced).
  void reset_rows(const std::vector<std::int32_t>& rows);
  // Grows (zero state) or shrinks to `rows` rows.
  void resize(std::size_t rows);

  std::size_t rows() const { return width_ ? m_.size() / width_ : 0; }
  std::int64_t steps() const { return steps_; }
  // State, for checkpoints.
  std::vector<float>& m() { return m_; }
  std::vector<float>& v() { return v_; }
  const std::vector<float>& m() const { return m_; }
  const std::vector<float>& v() const { return v_; }
  std::int64_t& step_count() { return steps_; }

 private:
  int width_ = 0;
  AdamSettings settings_;
  std::vector<float> column_scale_;  // [width]
  std::vector<float> m_, v_;         // [rows, width]
  std::int64_t steps_ = 0;
};

}  // namespace retimegs::train
