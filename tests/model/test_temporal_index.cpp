// TemporalIndex against brute force over random windows (interval, stretched, narrow, off-centre
// and open-ended ones, sharp and wide γ tails), and slice over its rows against the full scan.
#include <algorithm>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/model/temporal_index.hpp"
#include "retimegs/model/temporal_opacity.hpp"

namespace retimegs::model {
namespace {

const TimeGrid kGrid{1.0, 2.0, 9};  // training times 1, 3, ..., 17

Camera test_camera() {
  Camera cam;
  cam.name = "c";
  cam.width = 40, cam.height = 30;
  cam.fx = cam.fy = 30, cam.cx = 20, cam.cy = 15;
  cam.world_to_camera = look_at({0.3, -0.2, -5.0}, {0, 0, 0}, {0, -1, 0});
  return cam;
}

// n primitives near the origin with windows of five kinds; opacity logits of 20 (σ = 1 in float,
// so that evaluate's cut is the window's own) for even rows, random for odd ones.
Primitives random_primitives(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0, 1);
  const float step = float(kGrid.step), first = float(kGrid.first), last = float(kGrid.last());
  Primitives p;
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      p.mu[3 * i + a] = u(rng) - 0.5f;
      p.log_scale[3 * i + a] = -2.5f + u(rng);
      p.sh[Primitives::kShWidth * i + a] = u(rng) - 0.5f;
    }
    for (int k = 0; k < 9; ++k) p.velocity[9 * i + k] = 0.1f * (u(rng) - 0.5f);
    p.q0[4 * i] = 1;
    p.opacity_logit[i] = i % 2 == 0 ? 20.0f : 8 * (u(rng) - 0.5f);
    const int interval = int(u(rng) * float(kGrid.count - 1));
    switch (i % 5) {
      case 0:  // an interval's primitive
        p.mu_tau[i] = first + step * (float(interval) + 0.5f);
        p.tau_l[i] = p.tau_r[i] = step / 2;
        break;
      case 1:  // stretched, possibly to or past a clip end (open)
        p.mu_tau[i] = first - step + (last - first + 2 * step) * u(rng);
        p.tau_l[i] = 4 * step * u(rng), p.tau_r[i] = 4 * step * u(rng);
        break;
      case 2:  // narrow, anywhere, also between frames and outside the clip
        p.mu_tau[i] = first - 2 * step + (last - first + 4 * step) * u(rng);
        p.tau_l[i] = 0.3f * step * u(rng), p.tau_r[i] = 0.3f * step * u(rng);
        break;
      case 3: {  // edges on training times, or just inside or outside them (within ε)
        const float off = 0.5e-3f * float(int(i / 5 % 3) - 1);
        p.mu_tau[i] = first + step * float(interval + 1);
        p.tau_l[i] = step * float(1 + interval % 2) + off, p.tau_r[i] = step - off;
        break;
      }
      default:  // off-centre: μ_τ far from the support's midpoint
        p.mu_tau[i] = first + (last - first) * u(rng);
        p.tau_l[i] = 0.1f * step * u(rng), p.tau_r[i] = 3 * step * u(rng);
        break;
    }
  }
  return p;
}

TEST(TemporalIndex, ListsExactlyTheVisibleRowsAndTheGroupMembers) {
  const Camera cam = test_camera();
  // γ tails of 0.08, 0.8 and 4.8 frames, and of 1.6e-5 frames, under ε = 1e-3: there a window
  // whose edge lies just outside a training time is a group member with σ_τ ≈ 0 at it.
  for (const double gamma : {0.005, 0.05, 0.3, 1e-6}) {
    ModelConfig config;
    config.gamma = gamma;
    const Primitives p = random_primitives(2000, 11);
    const TemporalIndex index(p, config, kGrid);
    ASSERT_EQ(index.frames(), kGrid.count);
    for (int i = 0; i < kGrid.count; ++i) {
      const double t = kGrid.at(i);
      std::vector<std::int32_t> expected;
      for (std::size_t r = 0; r < p.size(); ++r) {
        const bool visible = retime_window(p, r, config, kGrid)(float(t)) >= float(1.0 / 255.0);
        const bool left = i > 0 && in_group(p, r, config, kGrid, t, Group::kLeft);
        const bool right = i + 1 < kGrid.count && in_group(p, r, config, kGrid, t, Group::kRight);
        if (visible || left || right) expected.push_back(std::int32_t(r));
      }
      const std::vector<std::int32_t>& rows = index.rows_at(i);
      ASSERT_EQ(rows, expected) << "gamma " << gamma << " frame " << i;
      // What slice draws at t is among the rows: every group, plain and compensated.
      std::vector<SliceOptions> renders(1);
      if (i > 0) renders.push_back({Group::kLeft, true, true});
      if (i + 1 < kGrid.count) renders.push_back({Group::kRight, true, true});
      for (const SliceOptions& options : renders)
        for (const std::int32_t r :
             slice(p, config, kGrid, t, cam, options).primitive_from_gaussian)
          ASSERT_TRUE(std::binary_search(rows.begin(), rows.end(), r))
              << "row " << r << " frame " << i << " group " << int(options.group);
      // The sharp windows leave most rows out of each frame; the test's windows are not trivial.
      if (gamma == 0.005) {
        EXPECT_LT(rows.size(), p.size() / 2) << i;
      }
      EXPECT_GT(rows.size(), 0u) << i;
    }
  }
  EXPECT_THROW(TemporalIndex(random_primitives(3, 1), ModelConfig{}, kGrid).rows_at(kGrid.count),
               Error);
}

TEST(TemporalIndex, StgsListsEveryRowAtEveryFrame) {
  ModelConfig config;
  config.representation = Representation::kStgs;
  const Primitives p = random_primitives(50, 2);
  const TemporalIndex index(p, config, kGrid);
  std::vector<std::int32_t> all(p.size());
  for (std::size_t r = 0; r < p.size(); ++r) all[r] = std::int32_t(r);
  for (int i = 0; i < kGrid.count; ++i) EXPECT_EQ(index.rows_at(i), all) << i;
  EXPECT_EQ(index.locality_order(), all);
}

// After reordering by locality_order, frame j's rows are the same primitives and form at most j + 1
// runs of consecutive rows; the order is stable (rows of equal frames keep their order) and a
// second pass leaves it as it is.
TEST(TemporalIndex, LocalityOrderPutsEachFramesRowsInFewRuns) {
  const ModelConfig config;
  Primitives p = random_primitives(2000, 5);
  for (std::size_t i = 0; i < p.size(); ++i) p.sh[Primitives::kShWidth * i + 3] = float(i);  // tag
  const TemporalIndex before(p, config, kGrid);
  const std::vector<std::int32_t> old_from_new = before.locality_order();
  std::vector<std::int32_t> sorted = old_from_new;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t k = 0; k < sorted.size(); ++k) ASSERT_EQ(sorted[k], std::int32_t(k));
  p.reorder(old_from_new);
  const auto tag = [&](std::int32_t row) { return p.sh[Primitives::kShWidth * row + 3]; };
  for (std::size_t k = 0; k < p.size(); ++k)
    ASSERT_EQ(tag(std::int32_t(k)), float(old_from_new[k]));
  const TemporalIndex after(p, config, kGrid);
  std::size_t scattered_runs = 0;
  for (int j = 0; j < kGrid.count; ++j) {
    const std::vector<std::int32_t>& rows = after.rows_at(j);
    std::vector<float> now, then;
    for (const std::int32_t r : rows) now.push_back(tag(r));
    for (const std::int32_t r : before.rows_at(j)) then.push_back(float(r));
    std::sort(now.begin(), now.end());
    EXPECT_EQ(now, then) << j;
    std::size_t runs = rows.empty() ? 0 : 1;
    for (std::size_t k = 1; k < rows.size(); ++k) runs += rows[k] != rows[k - 1] + 1;
    EXPECT_LE(runs, std::size_t(j + 1)) << j;
    const std::vector<std::int32_t>& old_rows = before.rows_at(j);
    for (std::size_t k = 1; k < old_rows.size(); ++k)
      scattered_runs += old_rows[k] != old_rows[k - 1] + 1;
  }
  EXPECT_GT(scattered_runs, std::size_t(10 * kGrid.count));  // the test's rows start scattered
  const std::vector<std::int32_t> again = after.locality_order();
  for (std::size_t k = 0; k < again.size(); ++k) ASSERT_EQ(again[k], std::int32_t(k));
  // Stable: rows with the same frames keep their relative order.
  for (std::size_t k = 1; k < old_from_new.size(); ++k) {
    const auto frames_of = [&](std::int32_t old_row) {
      std::vector<int> frames;
      for (int j = 0; j < kGrid.count; ++j)
        if (std::binary_search(before.rows_at(j).begin(), before.rows_at(j).end(), old_row))
          frames.push_back(j);
      return frames;
    };
    if (frames_of(old_from_new[k]) == frames_of(old_from_new[k - 1])) {
      ASSERT_LT(old_from_new[k - 1], old_from_new[k]) << k;
    }
  }
  EXPECT_THROW(reorder_rows(p.mu, 3, std::vector<std::int32_t>(5)), Error);
}

TEST(Slice, OverTheIndexRowsEqualsTheFullScan) {
  const Camera cam = test_camera();
  ModelConfig config;
  config.gamma = 0.05;
  const Primitives p = random_primitives(600, 5);
  const TemporalIndex index(p, config, kGrid);
  for (int i = 0; i < kGrid.count; ++i) {
    std::vector<SliceOptions> renders = {{Group::kAll, false, i == 0}};
    if (i > 0) renders.push_back({Group::kLeft, true, true});
    if (i + 1 < kGrid.count) renders.push_back({Group::kRight, true, true});
    for (SliceOptions options : renders) {
      const TimeSlice full = slice(p, config, kGrid, kGrid.at(i), cam, options);
      options.rows = &index.rows_at(i);
      const TimeSlice listed = slice(p, config, kGrid, kGrid.at(i), cam, options);
      ASSERT_GT(full.gaussians.size(), 0u);
      EXPECT_EQ(listed.primitive_from_gaussian, full.primitive_from_gaussian) << i;
      EXPECT_EQ(listed.temporal, full.temporal) << i;
      EXPECT_EQ(listed.gaussians.channels, full.gaussians.channels) << i;
      EXPECT_EQ(listed.gaussians.means, full.gaussians.means) << i;
      EXPECT_EQ(listed.gaussians.log_scales, full.gaussians.log_scales) << i;
      EXPECT_EQ(listed.gaussians.quats, full.gaussians.quats) << i;
      EXPECT_EQ(listed.gaussians.opacities, full.gaussians.opacities) << i;
      EXPECT_EQ(listed.gaussians.features, full.gaussians.features) << i;
    }
  }
  // A list that misses a selected row changes the batch; one out of order is refused.
  SliceOptions options;
  const std::vector<std::int32_t> none;
  options.rows = &none;
  EXPECT_EQ(slice(p, config, kGrid, kGrid.at(4), cam, options).gaussians.size(), 0u);
  const std::vector<std::int32_t> unordered = {5, 3};
  options.rows = &unordered;
  EXPECT_THROW(slice(p, config, kGrid, kGrid.at(4), cam, options), Error);
  const std::vector<std::int32_t> beyond = {int(p.size())};
  options.rows = &beyond;
  EXPECT_THROW(slice(p, config, kGrid, kGrid.at(4), cam, options), Error);
}

}  // namespace
}  // namespace retimegs::model
