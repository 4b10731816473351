#include "retimegs/train/adam.hpp"

#include <cmath>
#include <utility>

namespace retimegs::train {

Adam::Adam(std::size_t rows, int width, AdamSettings settings, std::vector<float> column_scale)
    : width_(width),
      settings_(settings),
      column_scale_(column_scale.empty() ? std::vector<float>(width, 1.0f)
                                         : std::move(column_scale)),
      m_(rows * width, 0.0f),
      v_(rows * width, 0.0f) {}

void Adam::step(float* params, const float* grads, double lr) {
  ++steps_;
  const float b1 = float(settings_.beta1), b2 = float(settings_.beta2);
  const double correction1 = 1.0 - std::pow(settings_.beta1, double(steps_));
  const double correction2 = 1.0 - std::pow(settings_.beta2, double(steps_));
  // p -= lr / c1 · m / (sqrt(v) / sqrt(c2) + ε)
  const float step_size = float(lr / correction1);
  const float inv_sqrt_c2 = float(1.0 / std::sqrt(correction2));
  const float eps = float(settings_.epsilon);
  const std::size_t rows = this->rows();
  const int width = width_;
  const float* scale = column_scale_.data();
  float* m = m_.data();
  float* v = v_.data();
#pragma omp parallel for schedule(static)
  for (std::size_t r = 0; r < rows; ++r)
#pragma omp simd
    for (int k = 0; k < width; ++k) {
      const std::size_t i = r * width + k;
      const float g = grads[i];
      m[i] = b1 * m[i] + (1 - b1) * g;
      v[i] = b2 * v[i] + (1 - b2) * g * g;
      params[i] -= step_size * scale[k] * m[i] / (std::sqrt(v[i]) * inv_sqrt_c2 + eps);
    }
}

void Adam::reset_rows(const std::vector<std::int32_t>& rows) {
  for (const std::int32_t r : rows)
    for (int k = 0; k < width_; ++k)
      m_[std::size_t(r) * width_ + k] = v_[std::size_t(r) * width_ + k] = 0;
}

void Adam::resize(std::size_t rows) {
  m_.resize(rows * width_, 0.0f);
  v_.resize(rows * width_, 0.0f);
}

}  // namespace retimegs::train
