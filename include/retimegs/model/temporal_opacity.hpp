#pragma once
// Temporal opacity σ_τ(t) (docs/method.md, paper Eq. 4-5) and the STGS baseline's Gaussian window.
// Times in scene frame units. retime_window() and temporal_opacity() below apply them to a row of
// a model's primitives: slice, the temporal index and export all go through them.
#include <cmath>
#include <cstddef>
#include <optional>

#include "retimegs/core/hd.hpp"
#include "retimegs/model/primitives.hpp"

namespace retimegs::model {

template <typename T>
RETIMEGS_HD T sigmoid(T x) {
  return T(1) / (T(1) + std::exp(-x));
}

// Which side of a seam an image draws (seam_handover below): kBefore draws the window that ends
// at the seam alone, its edges at the seam open and the next window's primitives that start there
// left out; kAfter the reverse; kNone draws every edge as it is.
enum class SeamSide : int { kBefore = -1, kNone = 0, kAfter = 1 };

// The RetimeGS window of one primitive: support [μ_τ - τ_l, μ_τ + τ_r], edges softened by a
// sigmoid of width γ (frames); an edge within ε of the clip's first / last training time is
// open (ψ ≡ 1) so that end primitives do not fade out at the clip ends. In a merged model an edge
// within ε of a seam is a cross-fade of the seam's own, wider scale (edge_scale): one window's
// side fades out while the next's fades in, their weights summing to one (ψ(x) + ψ(-x) = 1).
// Drawn for one side of the seam at side_seam, an edge within ε of it is open on that side and
// the primitive absent on the other.
template <typename T>
struct RetimeWindow {
  T mu_tau, tau_l, tau_r;
  T t_first, t_last;           // the clip's first and last training times
  T gamma, epsilon;            // frames
  T step = 1;                  // the grid step Δt: seam k is at t_first + seams[k] Δt
  const int* seams = nullptr;  // [seam_count] ModelConfig::seams
  int seam_count = 0;
  T seam_scale = 1;  // frames (seam_scale_frames)
  SeamSide side = SeamSide::kNone;
  T side_seam = 0;  // frames: the seam `side` refers to

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

  // Whether the edge at `edge` is at side_seam while one side is drawn.
  RETIMEGS_HD bool at_side_seam(T edge) const {
    const T d = edge - side_seam;
    return side != SeamSide::kNone && d <= epsilon && -d <= epsilon;
  }
  // The primitive is left out of the side drawn: it starts at the seam and the window before it
  // is drawn, or ends there and the window after it is drawn.
  RETIMEGS_HD bool other_side() const {
    return (side == SeamSide::kBefore && !open_left() && at_side_seam(mu_tau - tau_l)) ||
           (side == SeamSide::kAfter && !open_right() && at_side_seam(mu_tau + tau_r));
  }
  RETIMEGS_HD bool left_open() const { return open_left() || at_side_seam(mu_tau - tau_l); }
  RETIMEGS_HD bool right_open() const { return open_right() || at_side_seam(mu_tau + tau_r); }

  RETIMEGS_HD T operator()(T t) const {
    if (other_side()) return T(0);
    const T a = mu_tau - tau_l, b = mu_tau + tau_r;
    const T left = left_open() ? T(1) : sigmoid((t - a) / edge_scale(a));
    const T right = right_open() ? T(1) : sigmoid((b - t) / edge_scale(b));
    return left * right;
  }
  // d σ_τ / d t (the window itself is not optimised).
  RETIMEGS_HD T d_dt(T t) const {
    if (other_side()) return T(0);
    const T a = mu_tau - tau_l, b = mu_tau + tau_r;
    const T scale_left = edge_scale(a), scale_right = edge_scale(b);
    const bool open_a = left_open(), open_b = right_open();
    const T left = open_a ? T(1) : sigmoid((t - a) / scale_left);
    const T right = open_b ? T(1) : sigmoid((b - t) / scale_right);
    const T d_left = open_a ? T(0) : left * (1 - left) / scale_left;
    const T d_right = open_b ? T(0) : -right * (1 - right) / scale_right;
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

// An image of a merged model at time t near a seam is a cross-fade of two images, not of two sets
// of primitives: the window before the seam drawn alone (SeamSide::kBefore) weighted by
// ψ((seam - t) / F), the window after it alone weighted by the rest, F = seam_scale_frames. Two
// reconstructions of one static world, each at part of its opacity, cover less than either at
// full opacity (two opaque layers at w and 1 - w cover 1 - w (1 - w)): the static world would
// darken beside every seam, where each of the images is whole. Far from a seam, one side is drawn
// alone: its weight is within kHandoverTail of 1. Only the nearest seam hands over: where two
// seams lie closer than 12.5 F (windows under 6 intervals at merge's default fade), the frame
// halfway between them changes by the small weight each seam's far side still has there.
constexpr double kHandoverTail = 1.0 / 512;  // a quarter of an 8-bit level
struct SeamHandover {
  double seam = 0;    // frames: the seam nearest t
  double before = 1;  // the weight of the image before it; 1 - before that of the image after
  bool draws(SeamSide side) const {
    return side == SeamSide::kBefore ? before > kHandoverTail : before < 1 - kHandoverTail;
  }
};
// The handover at time t (frames); none for a model without seams.
inline std::optional<SeamHandover> seam_handover(const ModelConfig& config, const TimeGrid& grid,
                                                 double t) {
  if (config.seams.empty()) return std::nullopt;
  SeamHandover h;
  h.seam = grid.at(config.seams[0]);
  for (const int seam : config.seams)
    if (std::abs(grid.at(seam) - t) < std::abs(h.seam - t)) h.seam = grid.at(seam);
  h.before = sigmoid((h.seam - t) / seam_scale_frames(config, grid));
  return h;
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
