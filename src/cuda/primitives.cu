// Host <-> device copies of the primitives and their gradients
// (include/retimegs/cuda/primitives.hpp).
#include "retimegs/core/error.hpp"
#include "retimegs/cuda/primitives.hpp"
#include "rows.hpp"

namespace retimegs::cuda {

std::array<DevicePrimitives::Field, DevicePrimitives::kFieldCount> DevicePrimitives::fields() {
  return {{{"mu", &mu, 3},
           {"velocity", &velocity, 9},
           {"log_scale", &log_scale, 3},
           {"q0", &q0, 4},
           {"q1", &q1, 4},
           {"sh", &sh, model::Primitives::kShWidth},
           {"opacity_logit", &opacity_logit, 1},
           {"mu_tau", &mu_tau, 1},
           {"tau_l", &tau_l, 1},
           {"tau_r", &tau_r, 1},
           {"temporal_log_scale", &temporal_log_scale, 1}}};
}

void DevicePrimitives::upload(const model::Primitives& host) {
  const std::size_t n = host.size();
  const auto from = host.fields();
  const auto to = fields();
  for (int f = 0; f < kFieldCount; ++f) {
    if (from[f].values->size() != n * std::size_t(from[f].width))
      fail("primitives to the GPU: field {} holds {} values for {} rows of {}", from[f].name,
           from[f].values->size(), n, from[f].width);
    to[f].values->upload(*from[f].values);
  }
}

void DevicePrimitives::download(model::Primitives& host) const {
  auto& self = const_cast<DevicePrimitives&>(*this);  // fields() hands out the buffers; only read
  const auto from = self.fields();
  const auto to = host.fields();
  for (int f = 0; f < kFieldCount; ++f) {
    to[f].values->resize(from[f].values->size());
    from[f].values->download(to[f].values->data());
  }
}

void DevicePrimitives::resize(std::size_t n) {
  for (const Field& f : fields()) {
    const std::size_t kept = f.values->size();
    f.values->resize_keep(n * std::size_t(f.width));
    f.values->fill_bytes(0, kept);  // the new rows, if any: all-zero bytes are +0.0f
  }
}

void DevicePrimitives::reorder(const std::int32_t* old_from_new, std::size_t count) {
  if (count != size())
    fail("primitives on the GPU: reorder of {} rows by {} indices", size(), count);
  for (const Field& f : fields()) {
    scratch_.resize(f.values->size());
    gather_rows(f.values->data(), scratch_.data(), f.width, old_from_new, count);
    f.values->swap(scratch_);  // the old values' allocation serves the next field
  }
}

void DevicePrimitives::reorder(const std::vector<std::int32_t>& old_from_new) {
  DeviceBuffer<std::int32_t> rows;
  rows.upload(old_from_new);
  reorder(rows.data(), old_from_new.size());
}

void DevicePrimitives::copy_rows(const std::int32_t* to, const std::int32_t* from,
                                 std::size_t count) {
  for (const Field& f : fields()) cuda::copy_rows(f.values->data(), f.width, to, from, count);
}

void DevicePrimitiveGrads::resize_zero(std::size_t n) {
  const std::pair<DeviceBuffer<float>*, int> all[] = {{&v_mu, 3},
                                                      {&v_velocity, 9},
                                                      {&v_log_scale, 3},
                                                      {&v_q0, 4},
                                                      {&v_q1, 4},
                                                      {&v_sh, model::Primitives::kShWidth},
                                                      {&v_opacity_logit, 1},
                                                      {&v_mu_tau, 1},
                                                      {&v_temporal_log_scale, 1}};
  for (const auto& [buffer, width] : all) {
    buffer->resize(n * width);
    buffer->fill_bytes(0);
  }
}

void DevicePrimitiveGrads::download(model::PrimitiveGrads& host) const {
  host.v_mu = v_mu.download();
  host.v_velocity = v_velocity.download();
  host.v_log_scale = v_log_scale.download();
  host.v_q0 = v_q0.download();
  host.v_q1 = v_q1.download();
  host.v_sh = v_sh.download();
  host.v_opacity_logit = v_opacity_logit.download();
  host.v_mu_tau = v_mu_tau.download();
  host.v_temporal_log_scale = v_temporal_log_scale.download();
}

}  // namespace retimegs::cuda
