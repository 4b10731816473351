#include "retimegs/train/relocation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/train/noise_formulas.hpp"

namespace retimegs::train {

namespace {

constexpr double kMaxOpacity = 1.0 - 1e-6;  // keep logits finite

double opacity_of(const model::Primitives& p, std::size_t i) {
  return model::sigmoid<double>(p.opacity_logit[i]);
}

std::vector<double> sampling_scores(const model::Primitives& p, RelocationScore kind,
                                    double min_opacity) {
  std::vector<double> score(p.size(), 0.0);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double sigma = opacity_of(p, i);
    if (sigma <= min_opacity) continue;  // dead rows are never sources
    const double duration = double(p.tau_l[i]) + double(p.tau_r[i]);
    score[i] = kind == RelocationScore::kOpacity                ? sigma
               : kind == RelocationScore::kOpacityTimesDuration ? sigma * duration
                                                                : sigma / duration;
  }
  return score;
}

// `count` indices drawn with replacement ∝ weights (all zero: none).
std::vector<std::int32_t> sample(const std::vector<double>& weights, std::size_t count,
                                 std::mt19937_64& rng) {
  std::vector<double> cumulative(weights.size());
  double total = 0;
  for (std::size_t i = 0; i < weights.size(); ++i) cumulative[i] = total += weights[i];
  std::vector<std::int32_t> out;
  if (!(total > 0)) return out;
  std::uniform_real_distribution<double> uniform(0.0, total);
  for (std::size_t k = 0; k < count; ++k) {
    const auto it = std::upper_bound(cumulative.begin(), cumulative.end(), uniform(rng));
    out.push_back(std::int32_t(std::min<std::size_t>(it - cumulative.begin(), weights.size() - 1)));
  }
  return out;
}

// Applies the correction to every drawn source: n = (times drawn) + 1.
void correct_sources(model::Primitives& p, const std::vector<std::int32_t>& sources,
                     double min_opacity) {
  std::vector<int> drawn(p.size(), 0);
  for (const auto s : sources) ++drawn[s];
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!drawn[i]) continue;
    double opacity = 0, factor = 1;
    mcmc_correction(opacity_of(p, i), std::min(drawn[i] + 1, kMaxCopies), opacity, factor);
    opacity = std::clamp(opacity, min_opacity, kMaxOpacity);
    p.opacity_logit[i] = float(std::log(opacity / (1 - opacity)));
    for (int a = 0; a < 3; ++a) p.log_scale[3 * i + a] += float(std::log(factor));
  }
}

}  // namespace

void mcmc_correction(double opacity, int n, double& new_opacity, double& scale_factor) {
  new_opacity = 1.0 - std::pow(1.0 - opacity, 1.0 / n);
  double denominator = 0, binomial_row[kMaxCopies] = {1.0};  // C(i-1, k), row by row
  for (int i = 1; i <= n; ++i) {
    if (i > 1)
      for (int k = i - 1; k > 0; --k) binomial_row[k] += binomial_row[k - 1];
    for (int k = 0; k < i; ++k)
      denominator += binomial_row[k] * ((k % 2) ? -1.0 : 1.0) * std::pow(new_opacity, k + 1) /
                     std::sqrt(double(k + 1));
  }
  scale_factor = opacity / denominator;
}

Relocation relocate(model::Primitives& p, RelocationScore score, double min_opacity,
                    std::mt19937_64& rng) {
  Relocation result;
  std::vector<std::int32_t> dead;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (opacity_of(p, i) <= min_opacity) dead.push_back(std::int32_t(i));
  if (dead.empty()) return result;
  const std::vector<std::int32_t> sources =
      sample(sampling_scores(p, score, min_opacity), dead.size(), rng);
  if (sources.empty()) return result;  // nothing alive to copy
  correct_sources(p, sources, min_opacity);
  for (std::size_t k = 0; k < dead.size(); ++k) p.copy_row(dead[k], p, sources[k]);
  result.moved = dead.size();
  result.touched = dead;
  result.touched.insert(result.touched.end(), sources.begin(), sources.end());
  return result;
}

Relocation grow(model::Primitives& p, RelocationScore score, std::size_t cap, double growth,
                double min_opacity, std::mt19937_64& rng) {
  Relocation result;
  const std::size_t n = p.size();
  const std::size_t target = std::min(cap, std::size_t(std::floor(growth * double(n))));
  if (target <= n) return result;
  const std::vector<std::int32_t> sources =
      sample(sampling_scores(p, score, min_opacity), target - n, rng);
  if (sources.empty()) return result;
  correct_sources(p, sources, min_opacity);
  p.resize(n + sources.size());
  for (std::size_t k = 0; k < sources.size(); ++k) p.copy_row(n + k, p, sources[k]);
  result.added = sources.size();
  result.touched = sources;
  return result;
}

void inject_noise(model::Primitives& p, const std::vector<std::int32_t>& rows, double lr_means,
                  std::mt19937_64& rng) {
  const std::uint64_t key = rng();
  const std::ptrdiff_t count = std::ptrdiff_t(rows.size());
  // Rows are distinct and their draws depend on (key, row) alone: any order, any thread.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t j = 0; j < count; ++j) {
    const std::size_t i = std::size_t(rows[j]);
    noise_row(key, i, lr_means, p.opacity_logit[i], &p.q0[4 * i], &p.log_scale[3 * i],
              &p.mu[3 * i]);
  }
}

std::vector<std::int32_t> faint_short_rows(const model::Primitives& p, const model::TimeGrid& grid,
                                           double max_opacity) {
  // One interval, with room for the float rounding of a window set to exactly one.
  const double one_interval = grid.step * (1 + 1e-4);
  std::vector<std::int32_t> rows;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (opacity_of(p, i) < max_opacity && double(p.tau_l[i]) + double(p.tau_r[i]) <= one_interval)
      rows.push_back(std::int32_t(i));
  return rows;
}

}  // namespace retimegs::train
