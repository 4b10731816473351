#include "retimegs/train/relocation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>

#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/train/noise_formulas.hpp"

namespace retimegs::train {

namespace {

constexpr double kMaxOpacity = 1.0 - 1e-6;  // keep logits finite

double opacity_of(float logit) {
  return model::sigmoid<double>(logit);
}

std::vector<double> sampling_scores(const RelocationFields& rows, RelocationScore kind,
                                    double min_opacity) {
  std::vector<double> score(rows.size, 0.0);
  for (std::size_t i = 0; i < rows.size; ++i) {
    const double sigma = opacity_of(rows.opacity_logit[i]);
    if (sigma <= min_opacity) continue;  // dead rows are never sources
    const double duration = double(rows.tau_l[i]) + double(rows.tau_r[i]);
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

// Copies of the rows `from` onto the rows `to`, with every drawn source's correction for n =
// (times drawn) + 1.
RowMoves copies(const RelocationFields& rows, std::size_t size, std::vector<std::int32_t> to,
                std::vector<std::int32_t> from, double min_opacity) {
  RowMoves moves;
  moves.rows = size;
  std::vector<int> drawn(rows.size, 0);
  for (const auto s : from) ++drawn[s];
  for (std::size_t i = 0; i < rows.size; ++i) {
    if (!drawn[i]) continue;
    double opacity = 0, factor = 1;
    mcmc_correction(opacity_of(rows.opacity_logit[i]), std::min(drawn[i] + 1, kMaxCopies), opacity,
                    factor);
    opacity = std::clamp(opacity, min_opacity, kMaxOpacity);
    moves.sources.push_back(std::int32_t(i));
    moves.source_logit.push_back(float(std::log(opacity / (1 - opacity))));
    moves.source_log_scale_shift.push_back(float(std::log(factor)));
  }
  moves.to = std::move(to);
  moves.from = std::move(from);
  return moves;
}

RowMoves unchanged(std::size_t rows) {
  RowMoves moves;
  moves.rows = rows;
  return moves;
}

Relocation summary(const RowMoves& moves, std::size_t rows_before) {
  Relocation r;
  if (moves.rows > rows_before)
    r.added = moves.to.size();
  else
    r.moved = moves.to.size();
  r.touched = moves.touched();
  return r;
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

RelocationFields relocation_fields(const model::Primitives& p) {
  return {p.opacity_logit.data(), p.tau_l.data(), p.tau_r.data(), p.size()};
}

std::vector<std::int32_t> RowMoves::touched() const {
  std::vector<std::int32_t> touched = to;
  touched.insert(touched.end(), from.begin(), from.end());
  return touched;
}

RowMoves relocation_moves(const RelocationFields& rows, RelocationScore score, double min_opacity,
                          std::mt19937_64& rng) {
  std::vector<std::int32_t> dead;
  for (std::size_t i = 0; i < rows.size; ++i)
    if (opacity_of(rows.opacity_logit[i]) <= min_opacity) dead.push_back(std::int32_t(i));
  if (dead.empty()) return unchanged(rows.size);
  std::vector<std::int32_t> sources =
      sample(sampling_scores(rows, score, min_opacity), dead.size(), rng);
  if (sources.empty()) return unchanged(rows.size);  // nothing alive to copy
  return copies(rows, rows.size, std::move(dead), std::move(sources), min_opacity);
}

RowMoves growth_moves(const RelocationFields& rows, RelocationScore score, std::size_t cap,
                      double growth, double min_opacity, std::mt19937_64& rng) {
  const std::size_t n = rows.size;
  const std::size_t target = std::min(cap, std::size_t(std::floor(growth * double(n))));
  if (target <= n) return unchanged(n);
  std::vector<std::int32_t> sources =
      sample(sampling_scores(rows, score, min_opacity), target - n, rng);
  const std::size_t size = n + sources.size();
  std::vector<std::int32_t> appended(sources.size());
  std::iota(appended.begin(), appended.end(), std::int32_t(n));
  return copies(rows, size, std::move(appended), std::move(sources), min_opacity);
}

void apply(const RowMoves& moves, model::Primitives& p) {
  if (moves.rows != p.size()) p.resize(moves.rows);
  for (std::size_t k = 0; k < moves.sources.size(); ++k) {
    const std::size_t i = std::size_t(moves.sources[k]);
    correct_source(moves.source_logit[k], moves.source_log_scale_shift[k], p.opacity_logit[i],
                   &p.log_scale[3 * i]);
  }
  for (std::size_t k = 0; k < moves.to.size(); ++k) p.copy_row(moves.to[k], p, moves.from[k]);
}

Relocation relocate(model::Primitives& p, RelocationScore score, double min_opacity,
                    std::mt19937_64& rng) {
  const std::size_t n = p.size();
  const RowMoves moves = relocation_moves(relocation_fields(p), score, min_opacity, rng);
  apply(moves, p);
  return summary(moves, n);
}

Relocation grow(model::Primitives& p, RelocationScore score, std::size_t cap, double growth,
                double min_opacity, std::mt19937_64& rng) {
  const std::size_t n = p.size();
  const RowMoves moves = growth_moves(relocation_fields(p), score, cap, growth, min_opacity, rng);
  apply(moves, p);
  return summary(moves, n);
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
    if (opacity_of(p.opacity_logit[i]) < max_opacity &&
        double(p.tau_l[i]) + double(p.tau_r[i]) <= one_interval)
      rows.push_back(std::int32_t(i));
  return rows;
}

}  // namespace retimegs::train
