#include "retimegs/model/slice.hpp"

#include <algorithm>
#include <cmath>

#include <omp.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/pinhole.hpp"
#include "retimegs/model/slice_formulas.hpp"
#include "retimegs/model/temporal_opacity.hpp"

namespace retimegs::model {

namespace {

// Below this many candidate rows the selection runs on one thread (waking the others costs more).
constexpr std::size_t kParallelCandidates = 4096;

// The camera centre in T, where the view directions of the SH colours start.
template <typename T>
void set_eye(const Camera& camera, T eye[3]) {
  const Eigen::Vector3d e = camera.center();
  for (int a = 0; a < 3; ++a) eye[a] = T(e[a]);
}

// Index of training time t, or -1 when t is not on the grid.
int grid_index(const TimeGrid& grid, double t) {
  const double i = std::round((t - grid.first) / grid.step);
  if (i < 0 || i >= grid.count || std::abs(grid.at(int(i)) - t) > 1e-6) return -1;
  return int(i);
}

}  // namespace

template <typename T>
bool in_group(const PrimitivesT<T>& p, std::size_t i, const ModelConfig& config,
              const TimeGrid& grid, double t, Group group) {
  if (group == Group::kAll) return true;
  if (config.representation == Representation::kStgs)
    fail("group renders are not defined for the STGS baseline");
  const int index = grid_index(grid, t);
  const RetimeWindow<T> w = retime_window(p, i, config, grid);
  if (group == Group::kLeft) return w.covers(T(grid.at(index - 1)), T(t));
  return w.covers(T(t), T(grid.at(index + 1)));
}

template <typename T>
SliceParams<T> slice_params(const ModelConfig& config, const TimeGrid& grid, double t_in,
                            const Camera& camera, Group group, bool compensate, bool flow_features,
                            double min_opacity, SeamSide side, double side_seam) {
  if (!std::isfinite(t_in)) fail("slice: time {} is not finite", t_in);
  SliceParams<T> s;
  if (group != Group::kAll) {
    if (config.representation == Representation::kStgs)
      fail("group renders are not defined for the STGS baseline");
    const int index = grid_index(grid, t_in);
    if (index < 0 || (group == Group::kLeft && index == 0) ||
        (group == Group::kRight && index == grid.count - 1))
      fail("slice: the {} group is not defined at t = {} (training times {}..{} step {})",
           group == Group::kLeft ? "left" : "right", t_in, grid.first, grid.last(), grid.step);
    // in_group's interval: kLeft [t_{i-1}, t_i], kRight [t_i, t_{i+1}].
    s.group_from = group == Group::kLeft ? T(grid.at(index - 1)) : T(t_in);
    s.group_to = group == Group::kLeft ? T(t_in) : T(grid.at(index + 1));
  }
  s.representation = config.representation;
  s.trajectory = config.trajectory;
  s.sh_degree = config.sh_degree;
  s.channels = 3 + (flow_features ? kFlowChannels : 0);
  s.t = T(t_in), s.step = T(grid.step);
  s.t_first = T(grid.first), s.t_last = T(grid.last());
  s.gamma = T(grid.to_frames(config.gamma)), s.epsilon = T(config.epsilon);
  if (config.seams.size() > std::size_t(kMaxSeams))
    fail("slice: {} seams, more than {}", config.seams.size(), kMaxSeams);
  std::copy(config.seams.begin(), config.seams.end(), s.seams);
  s.seam_count = int(config.seams.size());
  s.seam_scale = T(seam_scale_frames(config, grid));
  s.side = side, s.side_seam = T(side_seam);
  set_eye(camera, s.eye);
  s.pinhole = PinholeT<T>(camera);
  s.group = group;
  s.compensate = compensate, s.flow_features = flow_features;
  s.min_opacity = T(min_opacity);
  s.cut_positive = min_opacity > 0;
  return s;
}

template <typename T>
TimeSliceT<T> slice(const PrimitivesT<T>& p, const ModelConfig& config, const TimeGrid& grid,
                    double t, const Camera& camera, const SliceOptions& options) {
  TimeSliceT<T> out;
  slice(p, config, grid, t, camera, options, out);
  return out;
}

template <typename T>
void slice(const PrimitivesT<T>& primitives, const ModelConfig& config, const TimeGrid& grid,
           double t_in, const Camera& camera, const SliceOptions& options, TimeSliceT<T>& out,
           const ShadedT<T>* shaded) {
  const SliceParams<T> s =
      slice_params<T>(config, grid, t_in, camera, options.group, options.compensate,
                      options.flow_features, options.min_opacity, options.side, options.side_seam);
  const PrimitiveArrays<T> p = primitive_arrays<T>(primitives);
  const std::size_t n = primitives.size();

  // Select the rows in primitive order: each chunk of the candidates compacts its selected rows to
  // its own start, then the chunks are concatenated in order, so the batch is the serial scan's
  // for any thread count. The rows are then filled in parallel.
  const std::vector<std::int32_t>* rows = options.rows;
  const std::size_t candidates = rows ? rows->size() : n;
  std::vector<std::int32_t>& selected = out.primitive_from_gaussian;
  std::vector<T>& temporal = out.temporal;  // [selected]
  selected.resize(candidates);
  temporal.resize(candidates);
  const int chunks = omp_get_max_threads();
  std::vector<std::size_t> kept(chunks, 0);  // [chunks] rows selected in each chunk
  std::size_t unordered = candidates;        // the first row list entry out of order, if any
#pragma omp parallel for schedule(static, 1) \
    reduction(min                            \
              : unordered) if (candidates >= kParallelCandidates)
  for (int chunk = 0; chunk < chunks; ++chunk) {
    const std::size_t begin = candidates * chunk / chunks, end = candidates * (chunk + 1) / chunks;
    std::size_t to = begin;
    for (std::size_t k = begin; k < end; ++k) {
      const std::size_t i = rows ? std::size_t((*rows)[k]) : k;
      if (rows && (i >= n || (k > 0 && i <= std::size_t((*rows)[k - 1])))) {
        unordered = std::min(unordered, k);  // one thread may run several chunks
        break;
      }
      T w;
      if (select_primitive(s, p, i, w)) {
        selected[to] = std::int32_t(i);
        temporal[to++] = w;
      }
    }
    kept[chunk] = to - begin;
  }
  if (unordered < candidates)
    fail("slice: row list entry {} ({}) is not ascending within the {} primitives", unordered,
         (*rows)[unordered], n);
  std::size_t m = 0;
  for (int chunk = 0; chunk < chunks; ++chunk) {
    const std::size_t begin = candidates * chunk / chunks;
    std::copy_n(selected.begin() + begin, kept[chunk], selected.begin() + m);
    std::copy_n(temporal.begin() + begin, kept[chunk], temporal.begin() + m);
    m += kept[chunk];
  }
  selected.resize(m);
  temporal.resize(m);

  out.gaussians.resize(m, s.channels);
  GaussiansT<T>& gaussians = out.gaussians;
  const GaussianArrays<T> g = {gaussians.means.data(), gaussians.log_scales.data(),
                               gaussians.quats.data(), gaussians.opacities.data(),
                               gaussians.features.data()};
#pragma omp parallel for schedule(static)
  for (std::size_t row = 0; row < m; ++row) {
    const std::size_t i = selected[row];
    slice_row(s, p, i, temporal[row], shaded ? &shaded->rgb[3 * i] : nullptr, g, row);
  }
}

template <typename T>
void slice_backward(const PrimitivesT<T>& primitives, const ModelConfig& config,
                    const TimeGrid& grid, double t_in, const Camera& camera,
                    const SliceOptions& options, const TimeSliceT<T>& sliced,
                    const GaussianGradsT<T>& v_gaussians, PrimitiveGradsT<T>& grads,
                    ShadedT<T>* shaded) {
  SliceParams<T> s =
      slice_params<T>(config, grid, t_in, camera, Group::kAll, options.compensate,
                      options.flow_features, options.min_opacity, options.side, options.side_seam);
  s.channels = sliced.gaussians.channels;
  const PrimitiveArrays<T> p = primitive_arrays<T>(primitives);
  const PrimitiveGradArrays<T> v_p = gradient_arrays<T>(grads);
  const GaussianGradArrays<T> vg = {v_gaussians.v_means.data(), v_gaussians.v_log_scales.data(),
                                    v_gaussians.v_quats.data(), v_gaussians.v_opacities.data(),
                                    v_gaussians.v_features.data()};
  const std::size_t m = sliced.primitive_from_gaussian.size();
  // Every primitive appears at most once in a batch: rows write disjoint gradient slots.
#pragma omp parallel for schedule(static)
  for (std::size_t row = 0; row < m; ++row) {
    if (!has_gradient(vg, row, s.channels)) continue;
    const std::size_t i = sliced.primitive_from_gaussian[row];
    slice_row_backward(s, p, i, sliced.temporal[row], vg, row, v_p,
                       shaded ? &shaded->v_rgb[3 * i] : nullptr);
  }
}

template <typename T>
double slice_time_vjp(const PrimitivesT<T>& primitives, const ModelConfig& config,
                      const TimeGrid& grid, double t_in, const Camera& camera,
                      const SliceOptions& options, const TimeSliceT<T>& sliced,
                      const GaussianGradsT<T>& v_gaussians) {
  SliceParams<T> s =
      slice_params<T>(config, grid, t_in, camera, Group::kAll, options.compensate,
                      options.flow_features, options.min_opacity, options.side, options.side_seam);
  s.channels = sliced.gaussians.channels;
  const PrimitiveArrays<T> p = primitive_arrays<T>(primitives);
  const GaussianGradArrays<T> vg = {v_gaussians.v_means.data(), v_gaussians.v_log_scales.data(),
                                    v_gaussians.v_quats.data(), v_gaussians.v_opacities.data(),
                                    v_gaussians.v_features.data()};
  const std::ptrdiff_t m = std::ptrdiff_t(sliced.primitive_from_gaussian.size());
  // Fixed chunks summed in their order, so that the total does not depend on the threads' timing.
  constexpr std::ptrdiff_t kChunk = 4096;
  std::vector<double> partial(std::size_t((m + kChunk - 1) / kChunk), 0.0);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t chunk = 0; chunk < std::ptrdiff_t(partial.size()); ++chunk) {
    T v_sh[PrimitivesT<T>::kShWidth];
    double sum = 0;
    for (std::ptrdiff_t row = chunk * kChunk; row < std::min(m, (chunk + 1) * kChunk); ++row) {
      if (!has_gradient(vg, std::size_t(row), s.channels)) continue;
      sum += double(slice_row_time_vjp(s, p, std::size_t(sliced.primitive_from_gaussian[row]), vg,
                                       std::size_t(row), v_sh));
    }
    partial[std::size_t(chunk)] = sum;
  }
  double total = 0;
  for (const double value : partial) total += value;
  return total;
}

template <typename T>
void shade(const PrimitivesT<T>& primitives, const ModelConfig& config, const TimeGrid& grid,
           double t_in, const Camera& camera, const std::vector<std::int32_t>& rows,
           ShadedT<T>& out) {
  const SliceParams<T> s =
      slice_params<T>(config, grid, t_in, camera, Group::kAll, false, false, 0.0);
  const PrimitiveArrays<T> p = primitive_arrays<T>(primitives);
  out.rgb.resize(3 * primitives.size());
  out.v_rgb.resize(3 * primitives.size());
  const std::ptrdiff_t count = std::ptrdiff_t(rows.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < count; ++k) {
    const std::size_t i = std::size_t(rows[k]);
    shade_row(s, p, i, &out.rgb[3 * i], &out.v_rgb[3 * i]);
  }
}

template <typename T>
void shade_backward(const PrimitivesT<T>& primitives, const ModelConfig& config,
                    const TimeGrid& grid, double t_in, const Camera& camera,
                    const std::vector<std::int32_t>& rows, const ShadedT<T>& shaded,
                    PrimitiveGradsT<T>& grads) {
  const SliceParams<T> s =
      slice_params<T>(config, grid, t_in, camera, Group::kAll, false, false, 0.0);
  const PrimitiveArrays<T> p = primitive_arrays<T>(primitives);
  const PrimitiveGradArrays<T> v_p = gradient_arrays<T>(grads);
  const std::ptrdiff_t count = std::ptrdiff_t(rows.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < count; ++k) {
    const std::size_t i = std::size_t(rows[k]);
    shade_row_backward(s, p, i, &shaded.v_rgb[3 * i], v_p);
  }
}

#define RETIMEGS_INSTANTIATE(T)                                                                  \
  template SliceParams<T> slice_params<T>(const ModelConfig&, const TimeGrid&, double,           \
                                          const Camera&, Group, bool, bool, double, SeamSide,    \
                                          double);                                               \
  template bool in_group<T>(const PrimitivesT<T>&, std::size_t, const ModelConfig&,              \
                            const TimeGrid&, double, Group);                                     \
  template TimeSliceT<T> slice<T>(const PrimitivesT<T>&, const ModelConfig&, const TimeGrid&,    \
                                  double, const Camera&, const SliceOptions&);                   \
  template void slice<T>(const PrimitivesT<T>&, const ModelConfig&, const TimeGrid&, double,     \
                         const Camera&, const SliceOptions&, TimeSliceT<T>&, const ShadedT<T>*); \
  template void slice_backward<T>(const PrimitivesT<T>&, const ModelConfig&, const TimeGrid&,    \
                                  double, const Camera&, const SliceOptions&,                    \
                                  const TimeSliceT<T>&, const GaussianGradsT<T>&,                \
                                  PrimitiveGradsT<T>&, ShadedT<T>*);                             \
  template double slice_time_vjp<T>(const PrimitivesT<T>&, const ModelConfig&, const TimeGrid&,  \
                                    double, const Camera&, const SliceOptions&,                  \
                                    const TimeSliceT<T>&, const GaussianGradsT<T>&);             \
  template void shade<T>(const PrimitivesT<T>&, const ModelConfig&, const TimeGrid&, double,     \
                         const Camera&, const std::vector<std::int32_t>&, ShadedT<T>&);          \
  template void shade_backward<T>(const PrimitivesT<T>&, const ModelConfig&, const TimeGrid&,    \
                                  double, const Camera&, const std::vector<std::int32_t>&,       \
                                  const ShadedT<T>&, PrimitiveGradsT<T>&);
RETIMEGS_INSTANTIATE(float)
RETIMEGS_INSTANTIATE(double)
#undef RETIMEGS_INSTANTIATE

}  // namespace retimegs::model
