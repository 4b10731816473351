#pragma once
// slice(t, camera): the 4D primitives at time t as a batch of ordinary 3D Gaussians for the
// renderer (core/gaussians.hpp), with colours from the SH at each view direction and, on request,
// the per-primitive flow features and group membership of triple rendering (docs/method.md), and
// the backward pass: the chain rule from the Gaussians' gradient into every optimised parameter.
#include <cstdint>
#include <vector>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/gaussians.hpp"
#include "retimegs/model/primitives.hpp"
#include "retimegs/model/slice_formulas.hpp"  // Group, kFlowChannels, the per-row math
#include "retimegs/model/temporal_opacity.hpp"

namespace retimegs::model {

struct SliceOptions {
  Group group = Group::kAll;
  // Divide each primitive's temporal opacity by its own σ_τ(t) ("compensated", for group renders).
  bool compensate = false;
  // Append kFlowChannels features after RGB: the projected control-point displacements to the
  // next and the previous training frame (L rule at p2 when t >= μ_τ, R rule at p1 otherwise).
  bool flow_features = false;
  // Primitives whose opacity σ·σ_τ falls below this are left out; 1/255 is exact for the
  // renderer, which skips alpha below one 8-bit step anyway. Gradient tests set 0.
  double min_opacity = 1.0 / 255.0;
  // One side of a seam (RetimeWindow::side): what playback draws near a merged model's seams.
  SeamSide side = SeamSide::kNone;
  double side_seam = 0;  // frames
  // The ascending rows to consider (nullptr: all rows). The batch is the full scan's, byte for
  // byte, whenever the list holds every row the full scan selects (TemporalIndex::rows_at).
  const std::vector<std::int32_t>* rows = nullptr;
};

// The SH colours of one time and camera, shared by a training step's renders: its triple render
// draws every primitive at the same position, hence view direction, in each pass. shade() fills
// `rgb` on the given rows and clears their `v_rgb`; slice given them copies each colour instead
// of evaluating the SH, slice_backward adds each colour's gradient into v_rgb instead of
// differentiating the SH, and shade_backward then differentiates the SH once per row: the same
// gradient as per render, since the SH's VJP is linear in the colour's gradient.
template <typename T>
struct ShadedT {
  std::vector<T> rgb, v_rgb;  // [N, 3]; valid on the rows shade() was given
};
using Shaded = ShadedT<float>;

template <typename T>
struct TimeSliceT {
  GaussiansT<T> gaussians;                            // [M] rows, channels 3 or 3 + kFlowChannels
  std::vector<std::int32_t> primitive_from_gaussian;  // [M]
  std::vector<T> temporal;  // [M] σ_τ(t) as applied (1 when compensated)
};
using TimeSlice = TimeSliceT<float>;

// Throws Error when a group is requested at a time that is not an interior/end training time.
template <typename T>
TimeSliceT<T> slice(const PrimitivesT<T>& primitives, const ModelConfig& config,
                    const TimeGrid& grid, double t, const Camera& camera,
                    const SliceOptions& options);
// The same batch written into `out`, whose arrays keep their capacity: a caller that evaluates
// every step (the training step) reuses one TimeSliceT per render instead of allocating it.
// `shaded`, when given, holds the colours at (t, camera) of every row the batch can select.
template <typename T>
void slice(const PrimitivesT<T>& primitives, const ModelConfig& config, const TimeGrid& grid,
           double t, const Camera& camera, const SliceOptions& options, TimeSliceT<T>& out,
           const ShadedT<T>* shaded = nullptr);

// Accumulates (+=) into `grads` (sized to the primitives) the gradient that flows back from
// `v_gaussians` (the renderer's gradient of the batch `sliced`). Rows whose renderer gradient
// is all zero (the Gaussians the render culled or that reached no pixel) add exactly zero and are
// skipped. With `shaded` (as given to evaluate) the colours' gradient is added into
// shaded->v_rgb, for shade_backward, instead of being taken through the SH.
template <typename T>
void slice_backward(const PrimitivesT<T>& primitives, const ModelConfig& config,
                    const TimeGrid& grid, double t, const Camera& camera,
                    const SliceOptions& options, const TimeSliceT<T>& sliced,
                    const GaussianGradsT<T>& v_gaussians, PrimitiveGradsT<T>& grads,
                    ShadedT<T>* shaded = nullptr);

// d loss / d t of a batch drawn at time t (slice's arguments, and the renderer's gradient
// `v_gaussians` of the batch `sliced`): what a camera's clock offset is refined by (docs/method.md,
// "Camera clock refinement"). Rows sum in a fixed order, in double: the same on every run.
template <typename T>
double slice_time_vjp(const PrimitivesT<T>& primitives, const ModelConfig& config,
                      const TimeGrid& grid, double t, const Camera& camera,
                      const SliceOptions& options, const TimeSliceT<T>& sliced,
                      const GaussianGradsT<T>& v_gaussians);

// The SH colour at (t, camera) of each of the ascending `rows` into out.rgb, and zero into their
// out.v_rgb; `out` is sized to the primitives, keeping its other rows.
template <typename T>
void shade(const PrimitivesT<T>& primitives, const ModelConfig& config, const TimeGrid& grid,
           double t, const Camera& camera, const std::vector<std::int32_t>& rows, ShadedT<T>& out);
// Accumulates (+=) into `grads` the gradient of the rows' colours, shaded.v_rgb, through the SH
// and the view direction; rows whose v_rgb is zero are skipped.
template <typename T>
void shade_backward(const PrimitivesT<T>& primitives, const ModelConfig& config,
                    const TimeGrid& grid, double t, const Camera& camera,
                    const std::vector<std::int32_t>& rows, const ShadedT<T>& shaded,
                    PrimitiveGradsT<T>& grads);

// The settings of a slice at time t seen from `camera` in T (model/slice_formulas.hpp), as slice,
// slice_backward, shade and their CUDA versions use them. Throws Error (slice's messages) when t is
// not finite or when a group is requested at a time that is not an interior/end training time.
template <typename T>
SliceParams<T> slice_params(const ModelConfig& config, const TimeGrid& grid, double t,
                            const Camera& camera, Group group, bool compensate, bool flow_features,
                            double min_opacity, SeamSide side = SeamSide::kNone,
                            double side_seam = 0);

// Whether primitive i belongs to `group` at time t (always true for kAll).
template <typename T>
bool in_group(const PrimitivesT<T>& primitives, std::size_t i, const ModelConfig& config,
              const TimeGrid& grid, double t, Group group);

}  // namespace retimegs::model
