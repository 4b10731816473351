#include "retimegs/train/adam.hpp"

#include <algorithm>
#include <cstring>

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
};

constexpr OptimisedField kOptimised[] = {
    {"mu", &model::Primitives::mu, &model::PrimitiveGrads::v_mu, &TrainConfig::lr_means, true,
     false, true},
    {"velocity", &model::Primitives::velocity, &model::PrimitiveGrads::v_velocity,
     &TrainConfig::lr_velocity, true, true, true},
    {"log_scale", &model::Primitives::log_scale, &model::PrimitiveGrads::v_log_scale,
     &TrainConfig::lr_scales, false, false, false},
    {"q0", &model::Primitives::q0, &model::PrimitiveGrads::v_q0, &TrainConfig::lr_quats, false,
     false, false},
    {"q1", &model::Primitives::q1, &model::PrimitiveGrads::v_q1, &TrainConfig::lr_quat_rate, false,
     true, false},
    {"sh", &model::Primitives::sh, &model::PrimitiveGrads::v_sh, &TrainConfig::lr_sh0, false, false,
     false},
    {"opacity_logit", &model::Primitives::opacity_logit, &model::PrimitiveGrads::v_opacity_logit,
     &TrainConfig::lr_opacities, false, false, false},
    {"mu_tau", &model::Primitives::mu_tau, &model::PrimitiveGrads::v_mu_tau,
     &TrainConfig::lr_temporal_center, false, false, false},
    {"temporal_log_scale", &model::Primitives::temporal_log_scale,
     &model::PrimitiveGrads::v_temporal_log_scale, &TrainConfig::lr_temporal_scale, false, false,
     false}};
constexpr std::size_t kRetimeFields = 7;

int field_width(const model::Primitives& p, const char* name) {
  for (const auto& f : p.fields())
    if (std::strcmp(name, f.name) == 0) return f.width;
  fail("unknown field '{}'", name);
}

}  // namespace

void Adam::step(float* params, const float* grads, double lr,
                const std::vector<std::int32_t>* rows) {
  update<false>(params, grads, lr, rows);
}

void Adam::step_and_clear(float* params, float* grads, double lr,
                          const std::vector<std::int32_t>* rows) {
  update<true>(params, grads, lr, rows);
}

template <bool kClear, typename G>
void Adam::update(float* params, G* grads, double lr, const std::vector<std::int32_t>* rows) {
  const AdamStepConstants constants = adam_step_constants(settings_, lr, ++steps_);
  const std::size_t count = rows ? rows->size() : this->rows();
  const int width = width_;
  const float* scale = column_scale_.data();
  float* m = m_.data();
  float* v = v_.data();
#pragma omp parallel for schedule(static)
  for (std::size_t j = 0; j < count; ++j) {
    const std::size_t r = rows ? std::size_t((*rows)[j]) : j;
#pragma omp simd
    for (int k = 0; k < width; ++k) {
      const std::size_t i = r * width + k;
      adam_update(constants, scale[k], grads[i], params[i], m[i], v[i]);
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
                      const std::vector<std::int32_t>& rows, double means_decay, double decay) {
  for (std::size_t k = 0; k < groups_.size(); ++k) {
    const OptimisedField& f = kOptimised[k];
    groups_[k].adam.step_and_clear((p.*f.values).data(), (grads.*f.grads).data(),
                                   rate(k, means_decay, decay), &rows);
  }
}

double Optimizers::rate(std::size_t group, double means_decay, double decay) const {
  const double base = base_rates_[group];
  return (kOptimised[group].means_decay ? base * means_decay : base) * decay;
}

double Optimizers::means_rate(double means_decay, double decay) const {
  return base_rates_[0] * means_decay * decay;  // kOptimised[0] is mu
}

void Optimizers::reset_rows(const std::vector<std::int32_t>& rows) {
  for (Group& g : groups_) g.adam.reset_rows(rows);
}

void Optimizers::resize(std::size_t rows) {
  for (Group& g : groups_) g.adam.resize(rows);
}

void Optimizers::reorder(const std::vector<std::int32_t>& old_from_new) {
  for (Group& g : groups_) g.adam.reorder(old_from_new);
}

}  // namespace retimegs::train
