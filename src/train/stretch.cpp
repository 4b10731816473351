#include "retimegs/train/stretch.hpp"

#include <cmath>

#include "retimegs/model/sh.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/model/trajectory.hpp"
#include "retimegs/train/neighbors.hpp"

namespace retimegs::train {

namespace {

double max_speed(const model::Primitives& p, std::size_t i) {
  double speed = 0;
  for (int j = 0; j < 3; ++j) {
    const float* v = &p.velocity[9 * i + 3 * j];
    speed =
        std::max(speed, std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]));
  }
  return speed;
}

// One side of a training frame t_b for the stretching criterion: the primitives whose support
// ends at t_b, or those whose support starts there.
struct StretchSide {
  std::vector<float> xyz;     // [N, 3]: positions at t_b
  std::vector<double> color;  // [N, 3]: base colours (SH DC x C0: only differences count)
  std::vector<double> speed;  // [N]: the largest speed of each (world units per frame)
};

// The stretching criterion at one training frame: each `ending` item is matched with its nearest
// `starting` item (by position at t_b, among all of them) when that lies within max_distance, both
// are no faster than max_speed, and their base colours differ by at most max_color in every
// channel. Returns, per ending item, the index of its partner in `starting` or -1; several ending
// items may share a partner.
std::vector<std::int32_t> match_at_frame(const StretchSide& ending, const StretchSide& starting,
                                         const StretchSettings& settings) {
  const std::size_t n = ending.speed.size();
  std::vector<std::int32_t> partner(n, -1);
  if (starting.speed.empty()) return partner;
  const PointIndex index(starting.xyz);
  for (std::size_t a = 0; a < n; ++a) {
    if (ending.speed[a] > settings.max_speed) continue;
    float d2;
    std::uint32_t c;
    if (index.knn(&ending.xyz[3 * a], 1, &c, &d2) < 1 ||
        d2 > settings.max_distance * settings.max_distance)
      continue;
    if (starting.speed[c] > settings.max_speed) continue;
    double color = 0;
    for (int ch = 0; ch < 3; ++ch)
      color = std::max(color, std::abs(ending.color[3 * a + ch] - starting.color[3 * c + ch]));
    if (color <= settings.max_color) partner[a] = std::int32_t(c);
  }
  return partner;
}

}  // namespace

StretchResult stretch(model::Primitives& p, const model::ModelConfig& config,
                      const model::TimeGrid& grid, const StretchSettings& settings,
                      std::mt19937_64& rng) {
  StretchResult result;
  const std::size_t n = p.size();
  const double tolerance = 1e-3 * grid.step;
  std::vector<int> matched_by(n, 0);
  std::vector<std::vector<std::int32_t>> partners(n);
  // Supports as they were before this round (a primitive may stretch at both ends).
  std::vector<double> lo(n), hi(n);
  for (std::size_t i = 0; i < n; ++i)
    lo[i] = double(p.mu_tau[i]) - p.tau_l[i], hi[i] = double(p.mu_tau[i]) + p.tau_r[i];
  const float step = float(grid.step);

  for (int b = 1; b + 1 < grid.count; ++b) {
    const double tb = grid.at(b);
    std::vector<std::int32_t> ending, starting;
    for (std::size_t i = 0; i < n; ++i) {
      if (model::sigmoid(p.opacity_logit[i]) < model::sigmoid(settings.dead_logit + 1)) continue;
      if (std::abs(hi[i] - tb) < tolerance) ending.push_back(std::int32_t(i));
      if (std::abs(lo[i] - tb) < tolerance) starting.push_back(std::int32_t(i));
    }
    if (ending.empty() || starting.empty()) continue;
    auto side = [&](const std::vector<std::int32_t>& items) {
      StretchSide out;
      out.xyz.resize(3 * items.size());
      for (std::size_t k = 0; k < items.size(); ++k) {
        const std::int32_t i = items[k];
        model::apply_trajectory(model::trajectory_at(config.representation, config.trajectory,
                                                     p.mu_tau[i], float(tb), step),
                                &p.mu[3 * i], &p.velocity[9 * i], &out.xyz[3 * k]);
        for (int ch = 0; ch < 3; ++ch)
          out.color.push_back(model::kShC0 * double(p.sh[model::Primitives::kShWidth * i + ch]));
        out.speed.push_back(max_speed(p, i));
      }
      return out;
    };
    const std::vector<std::int32_t> partner =
        match_at_frame(side(ending), side(starting), settings);
    for (std::size_t k = 0; k < ending.size(); ++k) {
      if (partner[k] < 0) continue;
      const std::int32_t a = ending[k], c = starting[partner[k]];
      // Union of the two supports for both (μ_τ stays).
      const double from = std::min(lo[a], lo[c]), to = std::max(hi[a], hi[c]);
      for (const std::int32_t i : {a, c}) {
        p.tau_l[i] = std::max(p.tau_l[i], float(p.mu_tau[i] - from));
        p.tau_r[i] = std::max(p.tau_r[i], float(to - p.mu_tau[i]));
      }
      ++matched_by[c], ++matched_by[a];
      partners[a].push_back(c), partners[c].push_back(a);
      ++result.pairs;
    }
  }
  std::vector<char> pruned(n, 0);
  std::uniform_real_distribution<double> uniform(0, 1);
  for (std::size_t i = 0; i < n; ++i) {
    if (!matched_by[i]) continue;
    ++result.stretched;
    const double draw = uniform(rng);  // drawn for every matched primitive: determinism
    bool partner_alive = false;
    for (const auto j : partners[i]) partner_alive |= !pruned[j];
    if (partner_alive && draw < 1.0 - 1.0 / (matched_by[i] + 1)) {
      pruned[i] = 1;
      p.opacity_logit[i] = float(settings.dead_logit);
      ++result.pruned;
    }
  }
  return result;
}

}  // namespace retimegs::train
