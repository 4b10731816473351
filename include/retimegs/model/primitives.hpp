#pragma once
// The 4D primitives of RetimeGS (docs/method.md) in a structure of arrays, the training time grid,
// and the model-level settings that fix how a primitive becomes a 3D Gaussian at time t.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace retimegs::model {

// The training frames t_1 < ... < t_T, evenly spaced: t_i = first + i * step, i = 0..count-1.
// Times are in scene frame units (frame k is at t = k).
struct TimeGrid {
  double first = 0;
  double step = 1;  // Δt
  int count = 2;

  double last() const { return first + step * (count - 1); }
  double at(int i) const { return first + step * i; }
  // γ is given in normalised clip time (docs/method.md): γ_frames = γ (t_T - t_1).
  double to_frames(double normalised) const { return normalised * (last() - first); }
};

// Training frames first..last (indices into a TimeGrid, first < last): the part of a long clip a
// window model was trained on (train --window, model/window.hpp).
struct TimeWindow {
  int first = 0, last = 1;
  bool operator==(const TimeWindow&) const = default;
};

enum class Representation {
  kRetime,  // boundary-aware sigmoid window, Catmull-Rom (or linear) trajectory
  kStgs,    // SpacetimeGaussians baseline: 1-D Gaussian window, cubic polynomial motion
};

enum class TrajectoryKind { kCatmullRom, kLinear };  // kLinear: the "linear" ablation

struct ModelConfig {
  Representation representation = Representation::kRetime;
  TrajectoryKind trajectory = TrajectoryKind::kCatmullRom;
  double gamma = 0.005;   // temporal-opacity sharpness, normalised clip time (paper §A)
  double epsilon = 1e-3;  // frames: a window edge within ε of the clip end is "open"
  int sh_degree = 3;      // active SH degree (training raises it gradually)
  // A merged model (model/merge.hpp): the training frames where one window's primitives hand over
  // to the next's, ascending (empty for a model trained in one run), and the sigmoid scale of a
  // closed edge at a seam, in training intervals (0: γ, as at every other edge). Settings, not
  // provenance: σ_τ reads them (RetimeWindow::edge_scale).
  std::vector<int> seams;
  double seam_fade = 0;
};

// Rows of `width` values of `values` in the order old_from_new (new row k is old row
// old_from_new[k]); throws Error unless old_from_new has one entry per row.
template <typename T>
void reorder_rows(std::vector<T>& values, int width, const std::vector<std::int32_t>& old_from_new);

// One row per primitive. Optimised fields first, then the window that only stretching changes.
//   Retime: x(t) from μ and v1, v2, v3 (Catmull-Rom control points, docs/method.md),
//           σ_τ(t) from (μ_τ, τ_l, τ_r).
//   STGS:   x(t) = μ + b1 Δ + b2 Δ² + b3 Δ³ with Δ = t - μ_τ and (b1, b2, b3) stored in
//           `velocity`; σ_τ(t) = exp(-((t - μ_τ) / exp(temporal_log_scale))²) with μ_τ learnable.
// Templated on the scalar so that gradient tests run in double; the model itself is float.
template <typename T>
struct PrimitivesT {
  static constexpr int kShCoeffs = 16;  // degree-3 storage; the active degree is a config choice
  static constexpr int kShWidth = 3 * kShCoeffs;  // floats per row of `sh`: RGB per coefficient

  std::vector<T> mu;                  // [N, 3] pseudo-mean
  std::vector<T> velocity;            // [N, 3, 3] v1, v2, v3 (STGS: b1, b2, b3)
  std::vector<T> log_scale;           // [N, 3]
  std::vector<T> q0;                  // [N, 4] (w, x, y, z)
  std::vector<T> q1;                  // [N, 4] rate: q(t) = normalize(q0 + q1 (t - μ_τ))
  std::vector<T> sh;                  // [N, 16, 3]
  std::vector<T> opacity_logit;       // [N] σ = sigmoid
  std::vector<T> mu_tau;              // [N] temporal centre (optimised only by STGS)
  std::vector<T> tau_l, tau_r;        // [N] window half-widths (Retime; not optimised)
  std::vector<T> temporal_log_scale;  // [N] STGS temporal scale (log); unused by Retime

  std::size_t size() const { return opacity_logit.size(); }

  // Every field with its row width, for code that treats all fields alike (resize, copy, I/O).
  template <typename V>
  struct FieldT {
    const char* name;
    V* values;
    int width;
  };
  using Field = FieldT<std::vector<T>>;
  using ConstField = FieldT<const std::vector<T>>;
  static constexpr int kFieldCount = 11;

  std::array<Field, kFieldCount> fields() { return fields_of<Field>(*this); }
  std::array<ConstField, kFieldCount> fields() const { return fields_of<ConstField>(*this); }

  void resize(std::size_t n) {
    for (Field f : fields()) f.values->resize(n * f.width, T(0));
  }
  // Copies row `from` of `source` into row `to` of this (every field).
  void copy_row(std::size_t to, const PrimitivesT& source, std::size_t from) {
    const auto src = source.fields();
    const auto dst = fields();
    for (int i = 0; i < kFieldCount; ++i)
      std::copy_n(src[i].values->data() + from * src[i].width, src[i].width,
                  dst[i].values->data() + to * dst[i].width);
  }
  // Puts the rows in the order old_from_new (a permutation of the rows): new row k is old row
  // old_from_new[k].
  void reorder(const std::vector<std::int32_t>& old_from_new) {
    for (Field f : fields()) reorder_rows(*f.values, f.width, old_from_new);
  }

 private:
  template <typename F, typename Self>
  static std::array<F, kFieldCount> fields_of(Self& p) {
    return {{{"mu", &p.mu, 3},
             {"velocity", &p.velocity, 9},
             {"log_scale", &p.log_scale, 3},
             {"q0", &p.q0, 4},
             {"q1", &p.q1, 4},
             {"sh", &p.sh, kShWidth},
             {"opacity_logit", &p.opacity_logit, 1},
             {"mu_tau", &p.mu_tau, 1},
             {"tau_l", &p.tau_l, 1},
             {"tau_r", &p.tau_r, 1},
             {"temporal_log_scale", &p.temporal_log_scale, 1}}};
  }
};
using Primitives = PrimitivesT<float>;

// Gradients of the optimised fields (same shapes). STGS also optimises mu_tau and
// temporal_log_scale; Retime leaves them zero.
template <typename T>
struct PrimitiveGradsT {
  std::vector<T> v_mu, v_velocity, v_log_scale, v_q0, v_q1, v_sh, v_opacity_logit, v_mu_tau,
      v_temporal_log_scale;

  PrimitiveGradsT() = default;
  explicit PrimitiveGradsT(std::size_t n) { resize(n); }
  // Keeps the first n rows as they are; added rows are zero.
  void resize(std::size_t n) {
    for (const auto& [values, width] : fields()) values->resize(n * width, T(0));
  }

 private:
  std::array<std::pair<std::vector<T>*, int>, 9> fields() {
    return {{{&v_mu, 3},
             {&v_velocity, 9},
             {&v_log_scale, 3},
             {&v_q0, 4},
             {&v_q1, 4},
             {&v_sh, PrimitivesT<T>::kShWidth},
             {&v_opacity_logit, 1},
             {&v_mu_tau, 1},
             {&v_temporal_log_scale, 1}}};
  }
};
using PrimitiveGrads = PrimitiveGradsT<float>;

// Throws Error naming `what`, the field and the row of the first size mismatch or non-finite value,
// or of an empty temporal window (τ_l + τ_r < 0; one half-width alone may be negative where a
// merge ended a support at a seam before its μ_τ, model/merge.hpp).
void check_primitives(const Primitives& primitives, const std::string& what);

}  // namespace retimegs::model
