// Cameras synchronised from their motion energy (sync.hpp).
#include "retimegs/ingest/sync.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "retimegs/core/error.hpp"
#include "retimegs/media/resize.hpp"

namespace retimegs::ingest {

namespace {

// A standard deviation at or below this is rounding, not motion (signals are in [0, 1]).
constexpr double kConstant = 1e-9;
// Sub-frame search: a grid of kCoarseStep over the two frames around the best whole lag, then one
// of kFineStep within a coarse step of the best of those (a thousandth of a frame is far below
// what the footage tells).
constexpr double kCoarseStep = 0.01, kFineStep = 0.001;

Image grey_thumbnail(const Image& frame) {
  Image grey(frame.width, frame.height, 1);
  for (std::size_t p = 0; p < frame.pixels(); ++p) {
    float sum = 0;
    for (int ch = 0; ch < frame.channels; ++ch) sum += frame.data[p * frame.channels + ch];
    grey.data[p] = sum / float(frame.channels);
  }
  const double scale =
      std::min(1.0, double(kSyncThumbnailSide) / std::max(frame.width, frame.height));
  return media::resize_area(grey, std::max(1, int(std::lround(frame.width * scale))),
                            std::max(1, int(std::lround(frame.height * scale))));
}

// Pearson's correlation of a(i) and b(i) over i in [first, last]; 0 where either is constant.
template <typename A, typename B>
double correlation(const A& a, const B& b, int first, int last) {
  const int n = last - first + 1;
  if (n < 2) return 0;
  double ma = 0, mb = 0;
  for (int i = first; i <= last; ++i) ma += a(i), mb += b(i);
  ma /= n, mb /= n;
  double ab = 0, aa = 0, bb = 0;
  for (int i = first; i <= last; ++i) {
    const double da = a(i) - ma, db = b(i) - mb;
    ab += da * db, aa += da * da, bb += db * db;
  }
  if (aa <= kConstant * kConstant * n || bb <= kConstant * kConstant * n) return 0;
  return ab / std::sqrt(aa * bb);
}

}  // namespace

void MotionEnergy::add(const Image& frame) {
  Image thumb = grey_thumbnail(frame);
  if (!previous_.empty()) {
    if (thumb.width != previous_.width || thumb.height != previous_.height)
      fail("motion energy: a frame of {}x{} after ones of another size", frame.width, frame.height);
    double sum = 0;
    for (std::size_t p = 0; p < thumb.data.size(); ++p)
      sum += std::abs(double(thumb.data[p]) - previous_.data[p]);
    signal_.push_back(sum / double(thumb.data.size()));
  }
  previous_ = std::move(thumb);
}

std::vector<double> z_normalised(const std::vector<double>& signal) {
  std::vector<double> out(signal.size(), 0.0);
  if (signal.empty()) return out;
  double mean = 0;
  for (double v : signal) mean += v;
  mean /= double(signal.size());
  double var = 0;
  for (double v : signal) var += (v - mean) * (v - mean);
  const double sd = std::sqrt(var / double(signal.size()));
  if (sd <= kConstant) return out;
  for (std::size_t i = 0; i < signal.size(); ++i) out[i] = (signal[i] - mean) / sd;
  return out;
}

double sample_linear(const std::vector<double>& signal, double x) {
  const int last = int(signal.size()) - 1;
  const int i = std::clamp(int(std::floor(x)), 0, std::max(0, last - 1));
  if (last <= 0) return signal.empty() ? 0.0 : signal[0];
  const double f = std::clamp(x - i, 0.0, 1.0);
  return (1 - f) * signal[i] + f * signal[i + 1];
}

double round_to_sync_resolution(double x) {
  return 0.0 + std::round(x / kSyncResolution) * kSyncResolution;  // 0.0 + : no "-0"
}

int default_max_lag(int common_frames) {
  return std::max(1, common_frames / 4);
}

LagEstimate estimate_lag(const std::vector<double>& reference, const std::vector<double>& other,
                         int max_lag) {
  const int nr = int(reference.size()), no = int(other.size());
  if (std::min(nr, no) < kMinSyncSamples)
    fail("--sync auto: needs at least {} frames of every camera (the footage has {})",
         kMinSyncSamples + 1, std::min(nr, no) + 1);
  if (max_lag < 1) fail("--sync-max-lag: {} is not a positive number of frames", max_lag);
  LagEstimate out;
  const std::vector<double> r = z_normalised(reference), o = z_normalised(other);
  const auto constant = [](const std::vector<double>& s) {
    return std::all_of(s.begin(), s.end(), [](double v) { return v == 0; });
  };
  if (constant(r) || constant(o)) {
    out.runner_up = -1;
    out.weak = constant(r) ? "nothing moves in the reference camera's footage"
                           : "nothing moves in its footage";
    return out;
  }

  // Whole lags: other[j] against reference[j + lag] over the j both have.
  const int min_overlap = std::max(kMinSyncSamples, std::min(nr, no) / 2);
  std::vector<std::optional<double>> whole(2 * max_lag + 1);
  int best = 0;
  for (int lag = -max_lag; lag <= max_lag; ++lag) {
    const int first = std::max(0, -lag), last = std::min(no - 1, nr - 1 - lag);
    if (last - first + 1 < min_overlap) continue;
    whole[lag + max_lag] =
        correlation([&](int j) { return r[j + lag]; }, [&](int j) { return o[j]; }, first, last);
    if (!whole[best + max_lag] || *whole[lag + max_lag] > *whole[best + max_lag]) best = lag;
  }
  if (!whole[best + max_lag])
    fail("--sync-max-lag: no lag within ±{} leaves {} frames in common", max_lag, min_overlap);

  // The runner-up: the highest other local maximum, two or more whole lags from the best.
  out.runner_up = -1;
  for (int lag = -max_lag; lag <= max_lag; ++lag) {
    const auto& c = whole[lag + max_lag];
    if (!c || std::abs(lag - best) < 2) continue;
    const auto below = [&](int l) {
      return l < -max_lag || l > max_lag || !whole[l + max_lag] || *whole[l + max_lag] <= *c;
    };
    if (below(lag - 1) && below(lag + 1)) out.runner_up = std::max(out.runner_up, *c);
  }

  // Sub-frame: the lags d in [best - 1, best + 1], both signals resampled half the lag apart,
  // reference[j + d / 2] against other[j - d / 2]: their fractional positions are then f and 1 - f,
  // where linear interpolation smooths them alike (by f (1 - f) times the curvature), so that its
  // smoothing does not pull the peak; over the j that every such d has in both (a fixed set, so
  // that the correlation is continuous in d).
  const double lo = std::max(double(best - 1), double(-max_lag));
  const double hi = std::min(double(best + 1), double(max_lag));
  const int first = int(std::ceil(std::max(-lo / 2, hi / 2)));
  const int last = int(std::floor(std::min(nr - 1 - hi / 2, no - 1 + lo / 2)));
  const auto at = [&](double d) {
    return correlation([&](int j) { return sample_linear(r, j + d / 2); },
                       [&](int j) { return sample_linear(o, j - d / 2); }, first, last);
  };
  const auto search = [&](double from, double to, double step, double start) {
    double arg = start, value = at(start);
    for (int i = 0; from + i * step <= to + 1e-12; ++i)
      if (const double c = at(from + i * step); c > value) value = c, arg = from + i * step;
    return std::pair(arg, value);
  };
  double lag = best, peak = *whole[best + max_lag];
  if (last - first + 1 >= kMinSyncSamples) {
    std::tie(lag, peak) = search(lo, hi, kCoarseStep, best);
    std::tie(lag, peak) =
        search(std::max(lo, lag - kCoarseStep), std::min(hi, lag + kCoarseStep), kFineStep, lag);
  }
  out.lag = lag, out.peak = peak;
  if (peak < kMinSyncPeak)
    out.weak = fmt::format("its peak correlation {:.2f} is below {}", peak, kMinSyncPeak);
  else if (out.runner_up > peak - kMinSyncMargin)
    out.weak =
        fmt::format("the correlation peaks nearly as high ({:.2f}, the best {:.2f}) at another lag",
                    out.runner_up, peak);
  return out;
}

}  // namespace retimegs::ingest
