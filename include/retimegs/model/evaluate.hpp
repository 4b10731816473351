#pragma once
// evaluate(t, camera): the 4D primitives at time t as a batch of ordinary 3D Gaussians for the
// renderer (core/gaussians.hpp), with colours from the SH at each view direction and, on request,
// the per-primitive flow features and group membership of triple rendering (DESIGN.md §2), and the
// backward pass: the chain rule from the Gaussians' gradient into every optimised parameter.
#include <cstdint>
#include <vector>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/gaussians.hpp"
#include "retimegs/model/primitives.hpp"
#include "retimegs/model/temporal_opacity.hpp"

namespace retimegs::model {

// Which primitives take part (DESIGN.md §2 "Groups"). kLeft / kRight need t = t_i, a training
// time: kLeft = active on [t_{i-1}, t_i], kRight = active on [t_i, t_{i+1}].
enum class Group { kAll, kLeft, kRight };

constexpr int kFlowChannels = 4;  // forward (u, v), backward (u, v) in pixels
// Where the flow features sit in a render with flow_features: right after RGB.
constexpr int kForwardFlowChannel = 3, kBackwardFlowChannel = 5;

struct EvaluateOptions {
  Group group = Group::kAll;
  // Divide each primitive's temporal opacity by its own σ_τ(t) ("compensated", for group renders).
  bool compensate = false;
  // Append kFlowChannels features after RGB: the projected control-point displacements to the
  // next and the previous training frame (L rule at p2 when t >= μ_τ, R rule at p1 otherwise).
  bool flow_features = false;
  // Primitives whose opacity σ·σ_τ falls below this are left out; 1/255 is exact for the
  // renderer, which skips alpha below one 8-bit step anyway. Gradient tests set 0.
  double min_opacity = 1.0 / 255.0;
  // The ascending rows to consider (nullptr: all rows). The batch is the full scan's, byte for
  // byte, whenever the list holds every row the full scan selects (TemporalIndex::rows_at).
  const std::vector<std::int32_t>* rows = nullptr;
};

template <typename T>
struct EvaluatedT {
  GaussiansT<T> gaussians;                            // [M] rows, channels 3 or 3 + kFlowChannels
  std::vector<std::int32_t> primitive_from_gaussian;  // [M]
  std::vector<T> temporal;  // [M] σ_τ(t) as applied (1 when compensated)
};
using Evaluated = EvaluatedT<float>;

// Throws Error when a group is requested at a time that is not an interior/end training time.
template <typename T>
EvaluatedT<T> evaluate(const PrimitivesT<T>& primitives, const ModelConfig& config,
                       const TimeGrid& grid, double t, const Camera& camera,
                       const EvaluateOptions& options);
// The same batch written into `out`, whose arrays keep their capacity: a caller that evaluates
// every step (the Trainer) reuses one EvaluatedT per render instead of allocating it.
template <typename T>
void evaluate(const PrimitivesT<T>& primitives, const ModelConfig& config, const TimeGrid& grid,
              double t, const Camera& camera, const EvaluateOptions& options, EvaluatedT<T>& out);

// Accumulates (+=) into `grads` (sized to the primitives) the gradient that flows back from
// `v_gaussians` (the renderer's gradient of the batch `evaluated`). Rows whose renderer gradient
// is all zero (the Gaussians the render culled or that reached no pixel) add exactly zero and are
// skipped.
template <typename T>
void evaluate_backward(const PrimitivesT<T>& primitives, const ModelConfig& config,
                       const TimeGrid& grid, double t, const Camera& camera,
                       const EvaluateOptions& options, const EvaluatedT<T>& evaluated,
                       const GaussianGradsT<T>& v_gaussians, PrimitiveGradsT<T>& grads);

// The RetimeGS window of primitive i under the model's settings, in T, as evaluate applies it.
template <typename T>
RetimeWindow<T> retime_window(const PrimitivesT<T>& p, std::size_t i, const ModelConfig& config,
                              const TimeGrid& grid) {
  return {p.mu_tau[i],      p.tau_l[i],     p.tau_r[i],
          T(grid.first),    T(grid.last()), T(grid.to_frames(config.gamma)),
          T(config.epsilon)};
}

// Whether primitive i belongs to `group` at time t (always true for kAll).
template <typename T>
bool in_group(const PrimitivesT<T>& primitives, std::size_t i, const ModelConfig& config,
              const TimeGrid& grid, double t, Group group);

}  // namespace retimegs::model
