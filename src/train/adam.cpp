#include "retimegs/train/adam.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <utility>

#include "retimegs/core/error.hpp"

namespace retimegs::train {

namespace {

// An optimised field: where its values and gradient live, and how its base rate follows from the
// config. Retime optimises the first seven, STGS all nine.
struct OptimisedField {
  const char* name;
  std::vector<float> model::Primitives::*values;
  std::vector<float> model::PrimitiveGrads::*grads;
  double TrainConfig::*rate;
  bool times_extent, per_frame_step, means_decay;
  // Only the renders differentiate it (no regulariser): rows without a renderer gradient have
  // none, and the field can step lazily (Adam, momentum catch-up).
  bool lazy;
};

constexpr OptimisedField kOptimised[] = {
    {"mu", &model::Primitives::mu, &model::PrimitiveGrads::v_mu, &TrainConfig::lr_means, true,
     false, true, true},
    {"velocity", &model::Primitives::velocity, &model::PrimitiveGrads::v_velocity,
     &TrainConfig::lr_velocity, true, true, true, true},
    {"log_scale", &model::Primitives::log_scale, &model::PrimitiveGrads::v_log_scale,
     &TrainConfig::lr_scales, false, false, false, false},
    {"q0", &model::Primitives::q0, &model::PrimitiveGrads::v_q0, &TrainConfig::lr_quats, false,
     false, false, true},
    {"q1", &model::Primitives::q1, &model::PrimitiveGrads::v_q1, &TrainConfig::lr_quat_rate, false,
     true, false, true},
    {"sh", &model::Primitives::sh, &model::PrimitiveGrads::v_sh, &TrainConfig::lr_sh0, false, false,
     false, true},
    {"opacity_logit", &model::Primitives::opacity_logit, &model::PrimitiveGrads::v_opacity_logit,
     &TrainConfig::lr_opacities, false, false, false, false},
    {"mu_tau", &model::Primitives::mu_tau, &model::PrimitiveGrads::v_mu_tau,
     &TrainConfig::lr_temporal_center, false, false, false, true},
    {"temporal_log_scale", &model::Primitives::temporal_log_scale,
     &model::PrimitiveGrads::v_temporal_log_scale, &TrainConfig::lr_temporal_scale, false, false,
     false, true}};
constexpr std::size_t kRetimeFields = 7;

int field_width(const model::Primitives& p, const char* name) {
  for (const auto& f : p.fields())
    if (std::strcmp(name, f.name) == 0) return f.width;
  fail("unknown field '{}'", name);
}

}  // namespace

Adam::Adam(std::size_t rows, int width, AdamSettings settings, std::vector<float> column_scale)
    : width_(width),
      settings_(settings),
      column_scale_(column_scale.empty() ? std::vector<float>(width, 1.0f)
                                         : std::move(column_scale)),
      m_(rows * width, 0.0f),
      v_(rows * width, 0.0f) {}

void Adam::step(float* params, const float* grads, double lr,
                const std::vector<std::int32_t>* rows) {
  update<false>(params, grads, lr, rows);
}

void Adam::step_and_clear(float* params, float* grads, double lr,
                          const std::vector<std::int32_t>* rows) {
  update<true>(params, grads, lr, rows);
}

void Adam::step_lazy(float* params, float* grads, double lr, const std::vector<std::int32_t>& rows,
                     const std::uint8_t* touched, Pending pending) {
  update<true>(params, grads, lr, &rows, touched, pending);
}

void Adam::rates(double lr, std::int64_t step, float& step_size, float& inv_sqrt_c2) const {
  const double correction1 = 1.0 - std::pow(settings_.beta1, double(step));
  const double correction2 = 1.0 - std::pow(settings_.beta2, double(step));
  // p -= lr / c1 · m / (sqrt(v) / sqrt(c2) + ε)
  step_size = float(lr / correction1);
  inv_sqrt_c2 = float(1.0 / std::sqrt(correction2));
}

void Adam::catch_up_row(float* params, std::size_t r, double lr, Pending pending) {
  const int k = pending.count[r];
  if (k <= 0) return;
  float step_size = 0, inv_sqrt_c2 = 0;
  rates(lr, pending.first[r], step_size, inv_sqrt_c2);
  const double b1 = settings_.beta1, b2 = settings_.beta2;
  const double ratio = b1 / std::sqrt(b2);
  // Σ_{j=1..k} ratio^j, and the moments' decay over the k steps.
  const float sum = float(ratio * (1 - std::pow(ratio, k)) / (1 - ratio));
  const float decay1 = float(std::pow(b1, k)), decay2 = float(std::pow(b2, k));
  const float eps = float(settings_.epsilon);
  const float* scale = column_scale_.data();
  float* m = &m_[r * width_];
  float* v = &v_[r * width_];
  float* x = &params[r * width_];
#pragma omp simd
  for (int c = 0; c < width_; ++c) {
    x[c] -= step_size * scale[c] * sum * m[c] / (std::sqrt(v[c]) * inv_sqrt_c2 + eps);
    m[c] *= decay1;
    v[c] *= decay2;
  }
}

void Adam::catch_up(float* params, double lr, Pending pending) {
  const std::ptrdiff_t count = std::ptrdiff_t(rows());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t r = 0; r < count; ++r) catch_up_row(params, std::size_t(r), lr, pending);
}

template <bool kClear, typename G>
void Adam::update(float* params, G* grads, double lr, const std::vector<std::int32_t>* rows,
                  const std::uint8_t* touched, Pending pending) {
  ++steps_;
  const float b1 = float(settings_.beta1), b2 = float(settings_.beta2);
  float step_size = 0, inv_sqrt_c2 = 0;
  rates(lr, steps_, step_size, inv_sqrt_c2);
  const float eps = float(settings_.epsilon);
  const std::size_t count = rows ? rows->size() : this->rows();
  const int width = width_;
  const float* scale = column_scale_.data();
  float* m = m_.data();
  float* v = v_.data();
#pragma omp parallel for schedule(static)
  for (std::size_t j = 0; j < count; ++j) {
    const std::size_t r = rows ? std::size_t((*rows)[j]) : j;
    if (touched) {
      if (!touched[r]) continue;
      catch_up_row(params, r, lr, pending);
    }
#pragma omp simd
    for (int k = 0; k < width; ++k) {
      const std::size_t i = r * width + k;
      const float g = grads[i];
      m[i] = b1 * m[i] + (1 - b1) * g;
      v[i] = b2 * v[i] + (1 - b2) * g * g;
      params[i] -= step_size * scale[k] * m[i] / (std::sqrt(v[i]) * inv_sqrt_c2 + eps);
      if constexpr (kClear) grads[i] = 0;
    }
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

void Adam::reorder(const std::vector<std::int32_t>& old_from_new) {
  model::reorder_rows(m_, width_, old_from_new);
  model::reorder_rows(v_, width_, old_from_new);
}

Optimizers::Optimizers(const model::Primitives& p, model::Representation representation,
                       const TrainConfig& config, double scene_extent, double frame_step) {
  const std::size_t count =
      representation == model::Representation::kStgs ? std::size(kOptimised) : kRetimeFields;
  for (std::size_t k = 0; k < count; ++k) {
    const OptimisedField& f = kOptimised[k];
    const int width = field_width(p, f.name);
    std::vector<float> column_scale;
    if (f.values == &model::Primitives::sh) {  // the DC colour is the first 3 of each row
      column_scale.assign(width, float(config.lr_sh_rest_factor));
      std::fill_n(column_scale.begin(), 3, 1.0f);
    }
    groups_.push_back({f.name, Adam(p.size(), width, {}, std::move(column_scale))});
    double rate = config.*f.rate;
    if (f.times_extent) rate *= scene_extent;
    if (f.per_frame_step) rate /= frame_step;
    base_rates_.push_back(rate);
  }
}

void Optimizers::step(model::Primitives& p, model::PrimitiveGrads& grads,
                      const std::vector<std::int32_t>& rows, double means_decay, double decay,
                      const std::vector<std::uint8_t>* touched) {
  if (touched && touched->size() != p.size())
    fail("Adam step: touched flags for {} rows, the model has {}", touched->size(), p.size());
  pending_.resize(p.size(), 0);
  first_missed_.resize(p.size(), 0);
  last_rates_.resize(groups_.size());
  const Adam::Pending pending{pending_.data(), first_missed_.data()};
  for (std::size_t k = 0; k < groups_.size(); ++k) {
    const OptimisedField& f = kOptimised[k];
    const double rate = (f.means_decay ? base_rates_[k] * means_decay : base_rates_[k]) * decay;
    last_rates_[k] = rate;
    float* values = (p.*f.values).data();
    float* g = (grads.*f.grads).data();
    if (touched && f.lazy)
      groups_[k].adam.step_lazy(values, g, rate, rows, touched->data(), pending);
    else
      groups_[k].adam.step_and_clear(values, g, rate, &rows);
  }
  if (!touched) return;
  // Every group counts every step; step counts fit (iterations are at most 1e9).
  const std::int32_t step = std::int32_t(groups_.front().adam.steps());
  const std::ptrdiff_t count = std::ptrdiff_t(rows.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t j = 0; j < count; ++j) {
    const std::size_t r = std::size_t(rows[j]);
    if ((*touched)[r]) {
      pending_[r] = 0;
    } else if (pending_[r]++ == 0) {
      first_missed_[r] = step;
    }
  }
}

void Optimizers::catch_up(model::Primitives& p) {
  if (pending_rows() == 0) return;
  for (std::size_t k = 0; k < groups_.size(); ++k)
    if (kOptimised[k].lazy)
      groups_[k].adam.catch_up((p.*kOptimised[k].values).data(), last_rates_[k],
                               {pending_.data(), first_missed_.data()});
  std::fill(pending_.begin(), pending_.end(), 0);
}

std::size_t Optimizers::pending_rows() const {
  return std::size_t(std::count_if(pending_.begin(), pending_.end(), [](auto k) { return k > 0; }));
}

double Optimizers::means_rate(double means_decay, double decay) const {
  return base_rates_[0] * means_decay * decay;  // kOptimised[0] is mu
}

void Optimizers::reset_rows(const std::vector<std::int32_t>& rows) {
  for (Group& g : groups_) g.adam.reset_rows(rows);
  for (const std::int32_t r : rows)
    if (std::size_t(r) < pending_.size()) pending_[std::size_t(r)] = 0;
}

void Optimizers::resize(std::size_t rows) {
  for (Group& g : groups_) g.adam.resize(rows);
  if (!pending_.empty()) pending_.resize(rows, 0), first_missed_.resize(rows, 0);
}

void Optimizers::reorder(const std::vector<std::int32_t>& old_from_new) {
  for (Group& g : groups_) g.adam.reorder(old_from_new);
  if (pending_.empty()) return;
  model::reorder_rows(pending_, 1, old_from_new);
  model::reorder_rows(first_missed_, 1, old_from_new);
}

}  // namespace retimegs::train
