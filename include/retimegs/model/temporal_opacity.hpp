#pragma once
// Temporal opacity σ_τ(t) (docs/method.md, paper Eq. 4-5) and the STGS baseline's Gaussian window.
// Times in scene frame units. retime_window() and temporal_opacity() below apply them to a row of
// a model's primitives: slice, the temporal index and export all go through them.
#include <cmath>
#include <cstddef>

#include "retimegs/core/hd.hpp"
#include "retimegs/model/primitives.hpp"

namespace retimegs::model {

template <typename T>
RETIMEGS_HD T sigmoid(T x) {
  return T(1) / (T(1) + std::exp(-x));
}

// The RetimeGS window of one primitive: support [μ_τ - τ_l, μ_τ + τ_r], edges softened by a
// sigmoid of width γ (frames); an edge within ε of the clip's first / last training time is
// open (ψ ≡ 1) so that end primitives do not fade out at the clip ends. In a merged model an edge
// within ε of a seam is a cross-fade of the seam's own, wider scale (edge_scale): one window's
// side fades out while the next's fades in, their weights summing to one (ψ(x) + ψ(-x) = 1).
template <typename T>
struct RetimeWindow {
  T mu_tau, tau_l, tau_r;
  T t_first, t_last;           // the clip's first and last training times
  T gamma, epsilon;            // frames
  T step = 1;                  // the grid step Δt: seam k is at t_first + seams[k] Δt
  const int* seams = nullptr;  // [seam_count] ModelConfig::seams
  int seam_count = 0;
  T seam_scale = 1;  // frames (seam_scale_frames)

  // The sigmoid scale of a closed edge at time `edge`: the seam's at a seam, γ elsewhere.
  RETIMEGS_HD T edge_scale(T edge) const {
    for (int k = 0; k < seam_count; ++k) {
      const T d = edge - (t_first + T(seams[k]) * step);
      if (d <= epsilon && -d <= epsilon) return seam_scale;
    }
    return gamma;
  }

  RETIMEGS_HD bool open_left() const { return mu_tau - tau_l <= t_first + epsilon; }
  RETIMEGS_HD bool open_right() const { return mu_tau + tau_r >= t_last - epsilon; }
  // Whether the support covers [a, b] (up to ε): the group membership test of docs/method.md.
  RETIMEGS_HD bool covers(T a, T b) const {
    return mu_tau - tau_l <= a + epsilon && mu_tau + tau_r >= b - epsilon;
  }

  RETIMEGS_HD T operator()(T t) const {
    const T a = mu_tau - tau_l, b = mu_tau + tau_r;
    const T left = open_left() ? T(1) : sigmoid((t - a) / edge_scale(a));
    const T right = open_right() ? T(1) : sigmoid((b - t) / edge_scale(b));
    return left * right;
  }
  // d σ_τ / d t (the window itself is not optimised).
  RETIMEGS_HD T d_dt(T t) const {
    const T a = mu_tau - tau_l, b = mu_tau + tau_r;
    const T scale_left = edge_scale(a), scale_right = edge_scale(b);
    const T left = open_left() ? T(1) : sigmoid((t - a) / scale_left);
    const T right = open_right() ? T(1) : sigmoid((b - t) / scale_right);
    const T d_left = open_left() ? T(0) : left * (1 - left) / scale_left;
    const T d_right = open_right() ? T(0) : -right * (1 - right) / scale_right;
    return d_left * right + left * d_right;
  }
};

// SpacetimeGaussians: σ_τ(t) = exp(-((t - μ_τ) / s)²), s = exp(log_scale); gradients with
// respect to μ_τ and log_scale are accumulated into v_mu_tau, v_log_scale (scaled by v).
template <typename T>
RETIMEGS_HD T stgs_temporal_opacity(T mu_tau, T log_scale, T t) {
  const T d = (t - mu_tau) * std::exp(-log_scale);
  return std::exp(-d * d);
}
template <typename T>
RETIMEGS_HD void stgs_temporal_opacity_vjp(T mu_tau, T log_scale, T t, T v, T& v_mu_tau,
                                           T& v_log_scale) {
  const T d = (t - mu_tau) * std::exp(-log_scale);
  const T value = std::exp(-d * d);
  // dσ/dd = -2 d σ;  dd/dμ_τ = -1/s;  dd/dlog_scale = -d
  v_mu_tau += v * (-2 * d * value) * (-std::exp(-log_scale));
  v_log_scale += v * (-2 * d * value) * (-d);
}

// The RetimeGS window of primitive i under the model's settings, in S: the primitives' own scalar
// (evaluate), or double where a float model is read without rounding its window to float (export).
// The scale in frames of a closed edge at one of the model's seams: seam_fade training intervals,
// or γ where the model sets none.
inline double seam_scale_frames(const ModelConfig& config, const TimeGrid& grid) {
  return config.seam_fade > 0 ? config.seam_fade * grid.step : grid.to_frames(config.gamma);
}

template <typename S, typename T>
RetimeWindow<S> retime_window(T mu_tau, T tau_l, T tau_r, const ModelConfig& config,
                              const TimeGrid& grid) {
  return {S(mu_tau),
          S(tau_l),
          S(tau_r),
          S(grid.first),
          S(grid.last()),
          S(grid.to_frames(config.gamma)),
          S(config.epsilon),
          S(grid.step),
          config.seams.data(),
          int(config.seams.size()),
          S(seam_scale_frames(config, grid))};
}
template <typename T, typename S = T>
RetimeWindow<S> retime_window(const PrimitivesT<T>& p, std::size_t i, const ModelConfig& config,
                              const TimeGrid& grid) {
  return retime_window<S>(p.mu_tau[i], p.tau_l[i], p.tau_r[i], config, grid);
}

// σ_τ(t) of primitive i, in the scalar of t: the STGS Gaussian or the RetimeGS window, as the
// model's representation says.
template <typename T, typename S>
S temporal_opacity(const PrimitivesT<T>& p, std::size_t i, const ModelConfig& config,
                   const TimeGrid& grid, S t) {
  if (config.representation == Representation::kStgs)
    return stgs_temporal_opacity(S(p.mu_tau[i]), S(p.temporal_log_scale[i]), t);
  return retime_window<T, S>(p, i, config, grid)(t);
}

}  // namespace retimegs::model
