#pragma once
// A batch of 3D Gaussians as the renderer consumes them (README.md, Architecture: model produces it
// for a time and a camera, render draws it), and the gradient of a loss with respect to it.
// Structures of arrays, row-major, templated on the scalar so that tests can run the pipeline in
// double.
#include <cstddef>
#include <vector>

#include "retimegs/core/memory.hpp"

namespace retimegs {

template <typename T>
struct GaussiansT {
  int channels = 3;           // C: feature channels per Gaussian (RGB = 3, RGB + 2 flows = 7)
  std::vector<T> means;       // [N, 3] world space
  std::vector<T> log_scales;  // [N, 3] natural log of the standard deviations on the local axes
  std::vector<T> quats;       // [N, 4] (w, x, y, z), any non-zero norm; normalised inside
  std::vector<T> opacities;   // [N] activated, in [0, 1]
  std::vector<T> features;    // [N, C] composited as they are (no activation, no SH)

  GaussiansT() = default;
  GaussiansT(std::size_t n, int c)
      : channels(c), means(3 * n), log_scales(3 * n), quats(4 * n), opacities(n), features(n * c) {}

  // n rows of c channels, keeping the arrays' capacity; values are left for the caller to set.
  void resize(std::size_t n, int c) {
    channels = c;
    means.resize(3 * n), log_scales.resize(3 * n), quats.resize(4 * n), opacities.resize(n);
    features.resize(n * c);
  }

  std::size_t size() const { return opacities.size(); }
};

// Gradient of a scalar loss with respect to GaussiansT (same shapes), plus the 2-D intermediates
// of the projection, exposed so that tests can check each stage on its own.
template <typename T>
struct GaussianGradsT {
  int channels = 3;
  UninitVector<T> v_means;       // [N, 3]
  UninitVector<T> v_log_scales;  // [N, 3]
  UninitVector<T> v_quats;       // [N, 4] with respect to the raw (unnormalised) quaternion
  UninitVector<T> v_opacities;   // [N]
  UninitVector<T> v_features;    // [N, C]
  UninitVector<T> v_means2d;     // [N, 2] intermediate: pixel centre (u, v)
  UninitVector<T> v_conics;      // [N, 3] intermediate: inverse 2-D covariance (a, b, c)
  UninitVector<T> v_depths;      // [N] intermediate: camera z (only the depth render feeds it)

  GaussianGradsT() = default;
  GaussianGradsT(std::size_t n, int c)
      : channels(c),
        v_means(3 * n, T(0)),
        v_log_scales(3 * n, T(0)),
        v_quats(4 * n, T(0)),
        v_opacities(n, T(0)),
        v_features(n * c, T(0)),
        v_means2d(2 * n, T(0)),
        v_conics(3 * n, T(0)),
        v_depths(n, T(0)) {}

  std::size_t size() const { return v_opacities.size(); }
};

using Gaussians = GaussiansT<float>;
using GaussianGrads = GaussianGradsT<float>;

}  // namespace retimegs
