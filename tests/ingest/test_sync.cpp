// The synchronisation estimator of `import videos --sync auto` (ingest/sync.hpp) on signals whose
// shift is known.
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/ingest/sync.hpp"

namespace retimegs::ingest {
namespace {

// A smooth motion-energy-like curve: bumps of 1.5 to 3 frames' width at random times, over a
// slow swell, the events a clip's motion energy shows (things starting and stopping).
struct Smooth {
  std::vector<double> centre, width, height;
  explicit Smooth(unsigned seed, double length) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    for (int i = 0; i < int(length / 4); ++i) {
      centre.push_back(u(rng) * length);
      width.push_back(1.5 + 1.5 * u(rng));
      height.push_back(0.5 + u(rng));
    }
  }
  double operator()(double t) const {
    double v = 0.2 * std::sin(0.15 * t);
    for (std::size_t i = 0; i < centre.size(); ++i)
      v += height[i] * std::exp(-0.5 * std::pow((t - centre[i]) / width[i], 2));
    return v;
  }
  // Samples j = 0..n-1 at times j + shift.
  std::vector<double> samples(int n, double shift) const {
    std::vector<double> s;
    for (int j = 0; j < n; ++j) s.push_back((*this)(j + shift));
    return s;
  }
};

// other[j] = f(j + d) against reference[j] = f(j): the lag is d, fractions included, for shifts
// between whole frames and halves (where a bias of interpolation toward whole frames would show).
TEST(Sync, RecoversFractionalShiftsOfSmoothSignals) {
  const double shifts[] = {0.5, 0.3, -0.4, 0.1, 1.25, -2.7, 3.5, 0};
  double worst = 0;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    const Smooth f(seed, 48);
    const std::vector<double> reference = f.samples(40, 0);
    for (double d : shifts) {
      const LagEstimate e = estimate_lag(reference, f.samples(40, d), 10);
      EXPECT_NEAR(e.lag, d, 0.03) << "seed " << seed;
      EXPECT_GT(e.peak, 0.99) << "seed " << seed << " shift " << d;
      EXPECT_EQ(e.weak, "") << "seed " << seed << " shift " << d;
      worst = std::max(worst, std::abs(e.lag - d));
    }
  }
  RecordProperty("worst_lag_error", std::to_string(worst));
}

// The same on a clip as short as a test rig's (24 values: 25 frames) with noise of 2 % of the
// bumps' height added to each value: within a tenth of a frame.
TEST(Sync, RecoversFractionalShiftsOfShortNoisySignals) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 0.02);
  double worst = 0;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const Smooth f(seed + 100, 32);
    std::vector<double> reference = f.samples(24, 0);
    for (double d : {0.5, 0.3, -0.4}) {
      std::vector<double> other = f.samples(24, d);
      for (double& v : other) v += noise(rng);
      const LagEstimate e = estimate_lag(reference, other, 6);
      EXPECT_NEAR(e.lag, d, 0.1) << "seed " << seed;
      worst = std::max(worst, std::abs(e.lag - d));
    }
  }
  RecordProperty("worst_lag_error", std::to_string(worst));
}

// Pearson's correlation ignores gain and offset: a camera that sees the motion twice as large,
// over a brighter background, has the same lag.
TEST(Sync, LagIgnoresScaleAndOffset) {
  const Smooth f(3, 48);
  std::vector<double> other = f.samples(40, -1.6);
  for (double& v : other) v = 0.3 + 2 * v;
  const LagEstimate e = estimate_lag(f.samples(40, 0), other, 10);
  EXPECT_NEAR(e.lag, -1.6, 0.02);
  EXPECT_GT(e.peak, 0.99);
}

// Shifts beyond the bound are not found: the lag stays within ±max_lag.
TEST(Sync, LagStaysWithinTheBound) {
  const Smooth f(4, 48);
  const LagEstimate e = estimate_lag(f.samples(40, 0), f.samples(40, 6), 3);
  EXPECT_LE(std::abs(e.lag), 3.0);
}

// Footage where nothing moves: the lag is 0 and the estimate says why it is not to be trusted,
// for the camera's own footage and for the reference's.
TEST(Sync, StaticFootageIsWeak) {
  const Smooth f(5, 48);
  const std::vector<double> moving = f.samples(40, 0), still(40, 0.002);
  LagEstimate e = estimate_lag(moving, still, 10);
  EXPECT_EQ(e.lag, 0);
  EXPECT_EQ(e.weak, "nothing moves in its footage");
  e = estimate_lag(still, moving, 10);
  EXPECT_EQ(e.weak, "nothing moves in the reference camera's footage");
}

// Sensor noise alone (no motion in common): a low peak, named in the warning.
TEST(Sync, UncorrelatedFootageIsWeak) {
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.01, 0.001);
  std::vector<double> a(64), b(64);
  for (double& v : a) v = noise(rng);
  for (double& v : b) v = noise(rng);
  const LagEstimate e = estimate_lag(a, b, 16);
  EXPECT_LT(e.peak, kMinSyncPeak);
  EXPECT_NE(e.weak.find("peak correlation"), std::string::npos) << e.weak;
}

// A motion that repeats every 4 frames, searched over ±8: the correlation peaks as high at the
// lags a period apart, which the estimate says.
TEST(Sync, PeriodicMotionIsAmbiguous) {
  std::vector<double> reference, other;
  for (int j = 0; j < 40; ++j) {
    reference.push_back(std::sin(2 * M_PI * j / 4.0 + 0.3));
    other.push_back(std::sin(2 * M_PI * (j + 1.0) / 4.0 + 0.3));
  }
  const LagEstimate e = estimate_lag(reference, other, 8);
  EXPECT_GT(e.runner_up, e.peak - kMinSyncMargin);
  EXPECT_NE(e.weak.find("at another lag"), std::string::npos) << e.weak;
}

TEST(Sync, TooShortOrNoBoundIsAnError) {
  const Smooth f(6, 48);
  EXPECT_THROW(estimate_lag(f.samples(3, 0), f.samples(40, 0), 1), Error);
  EXPECT_THROW(estimate_lag(f.samples(40, 0), f.samples(40, 0), 0), Error);
}

TEST(Sync, ZNormalisedHasZeroMeanAndUnitDeviation) {
  const std::vector<double> z = z_normalised({1, 2, 3, 4, 10});
  double mean = 0, var = 0;
  for (double v : z) mean += v;
  for (double v : z) var += v * v;
  EXPECT_NEAR(mean, 0, 1e-12);
  EXPECT_NEAR(var / 5, 1, 1e-12);
  EXPECT_EQ(z_normalised({3, 3, 3}), std::vector<double>(3, 0.0));
}

TEST(Sync, SampleLinearInterpolatesBetweenSamples) {
  const std::vector<double> s = {0, 2, 6};
  EXPECT_DOUBLE_EQ(sample_linear(s, 0.25), 0.5);
  EXPECT_DOUBLE_EQ(sample_linear(s, 1.5), 4);
  EXPECT_DOUBLE_EQ(sample_linear(s, 2), 6);
}

// The energy between two frames is the mean absolute difference of their grey thumbnails: a
// uniform brightening by 0.3 gives 0.3 whatever the size; a quarter of the image changing by 0.4
// gives 0.1 (area averaging keeps the mean).
TEST(Sync, MotionEnergyIsTheMeanAbsoluteDifference) {
  MotionEnergy energy;
  Image a(200, 100, 3, 0.2f), b(200, 100, 3, 0.5f), c = b;
  for (int y = 0; y < 50; ++y)
    for (int x = 0; x < 100; ++x)
      for (int ch = 0; ch < 3; ++ch) c.at(y, x, ch) = 0.9f;
  energy.add(a);
  energy.add(b);
  energy.add(c);
  energy.add(c);
  ASSERT_EQ(energy.signal().size(), 3u);
  EXPECT_NEAR(energy.signal()[0], 0.3, 1e-6);
  EXPECT_NEAR(energy.signal()[1], 0.1, 1e-6);
  EXPECT_EQ(energy.signal()[2], 0);
  EXPECT_THROW(energy.add(Image(100, 100, 3)), Error);
}

}  // namespace
}  // namespace retimegs::ingest

namespace retimegs::ingest {
namespace {

// Offsets are written to kSyncResolution: a camera found a hundredth of a frame from the
// reference keeps its clock exactly (on the training grid), halves round away from zero.
TEST(Sync, OffsetsRoundToTheResolution) {
  EXPECT_EQ(round_to_sync_resolution(0.03), 0.0);
  EXPECT_EQ(round_to_sync_resolution(-0.049), 0.0);
  EXPECT_FALSE(std::signbit(round_to_sync_resolution(-0.01)));
  EXPECT_NEAR(round_to_sync_resolution(0.435), 0.4, 1e-12);
  EXPECT_NEAR(round_to_sync_resolution(-0.46), -0.5, 1e-12);
  EXPECT_NEAR(round_to_sync_resolution(2.976), 3.0, 1e-12);
  EXPECT_EQ(round_to_sync_resolution(3.0), 3.0);
}

}  // namespace
}  // namespace retimegs::ingest
