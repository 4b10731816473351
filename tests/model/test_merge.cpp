// Window models (model/window.hpp) and their merge (model/merge.hpp): the seam of two windows
// draws as the unsplit model does, the window is stored in the file, and the refusals.
#include <cmath>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/model/merge.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/model/window.hpp"
#include "test_util.hpp"

namespace retimegs::model {
namespace {
namespace fs = std::filesystem;

const TimeGrid kClip{0.0, 2.0, 9};  // training times 0, 2, ..., 16
constexpr double kSeam = 8;         // grid index 4

Camera camera() {
  Camera cam;
  cam.name = "c";
  cam.width = 24, cam.height = 20;
  cam.fx = cam.fy = 22, cam.cx = 12, cam.cy = 10;
  cam.world_to_camera = look_at({0.3, -0.2, -5.0}, {0, 0, 0}, {0, -1, 0});
  return cam;
}

// Adds a primitive near the origin with support [from, to] (μ_τ at the centre of its first
// interval, as stretching leaves it).
void add(Primitives& p, double from, double to, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1, 1);
  const std::size_t i = p.size();
  p.resize(i + 1);
  for (int a = 0; a < 3; ++a) p.mu[3 * i + a] = 0.5f * u(rng);
  for (int a = 0; a < 3; ++a) p.log_scale[3 * i + a] = std::log(0.2f);
  p.q0[4 * i] = 1;
  for (int k = 0; k < 3; ++k) p.sh[48 * i + k] = 0.5f * u(rng);
  p.opacity_logit[i] = 1.0f + 0.5f * u(rng);
  p.mu_tau[i] = float(from + 1);
  p.tau_l[i] = 1;
  p.tau_r[i] = float(to - from - 1);
}

struct Fixture {
  Model whole, left, right;  // the unsplit model, and its windows 0..8 and 8..16
};

// One primitive per interval, one stretched over [2, 6] and one over [10, 16] (to the clip end):
// the unsplit model, and the same primitives as the two window models that training would write.
Fixture fixture() {
  std::mt19937 rng(7);
  Fixture f;
  f.whole.grid = kClip;
  f.whole.camera_colors["c"] = {};
  f.left = f.right = f.whole;
  f.left.window = TimeWindow{0, 4};
  f.right.window = TimeWindow{4, 8};
  for (int i = 0; i < 8; ++i) {
    const double from = 2.0 * i;
    std::mt19937 again = rng;
    add(f.whole.primitives, from, from + 2, rng);
    add(from < kSeam ? f.left.primitives : f.right.primitives, from, from + 2, again);
  }
  for (const auto& [from, to] : {std::pair{2.0, 6.0}, std::pair{10.0, 16.0}}) {
    std::mt19937 again = rng;
    add(f.whole.primitives, from, to, rng);
    add(from < kSeam ? f.left.primitives : f.right.primitives, from, to, again);
  }
  return f;
}

// Σ σ_τ(t) over every primitive, as slice applies it (only exact zeros are left out).
double temporal_sum(const Model& m, double t) {
  SliceOptions options;
  options.min_opacity = 0;
  const TimeSlice e = slice(m.primitives, m.config, m.grid, t, camera(), options);
  double sum = 0;
  for (const float v : e.temporal) sum += v;
  return sum;
}

// Times at and around the seam: coarse over the two intervals that meet there, fine across the
// edges' width (γ in frames, 0.08 here).
std::vector<double> seam_times() {
  std::vector<double> times;
  for (double t = 6; t <= 10 + 1e-9; t += 0.125) times.push_back(t);
  for (int k = -10; k <= 10; ++k) times.push_back(kSeam + 0.02 * k);
  return times;
}

TEST(Merge, SeamDrawsLikeTheUnsplitModel) {
  const Fixture f = fixture();
  // As render and eval draw it (playback::load_model): a window model as trained.
  const Model merged = window_view(merge_models({f.right, f.left}, {"right.rgs", "left.rgs"}));
  ASSERT_EQ(merged.primitives.size(), f.whole.primitives.size());
  for (const double t : seam_times())
    EXPECT_NEAR(temporal_sum(merged, t), temporal_sum(f.whole, t), 1e-5) << "t = " << t;
  // The unsplit model meets at 0.5 + 0.5 at the seam. Each window alone (as trained) is open
  // there, so a merge that left the seam's edges open, or held a window twice, would draw 2.
  EXPECT_NEAR(temporal_sum(merged, kSeam), 1.0, 1e-5);
  EXPECT_NEAR(temporal_sum(window_view(f.left), kSeam), 1.0, 1e-5);
  EXPECT_NEAR(temporal_sum(window_view(f.right), kSeam), 1.0, 1e-5);
  EXPECT_NEAR(temporal_sum(window_view(f.left), kSeam) + temporal_sum(window_view(f.right), kSeam),
              2.0, 1e-5);
  // Away from the seam each window alone draws what the unsplit model draws there.
  for (const double t : {1.0, 4.0, 6.5, 7.9})
    EXPECT_NEAR(temporal_sum(window_view(f.left), t), temporal_sum(f.whole, t), 1e-5) << t;
  for (const double t : {8.1, 9.0, 12.0, 16.0})
    EXPECT_NEAR(temporal_sum(window_view(f.right), t), temporal_sum(f.whole, t), 1e-5) << t;
}

TEST(Merge, WindowViewKeepsTheEdgeSharpnessInFrames) {
  const Fixture f = fixture();
  const Model local = window_view(f.left);
  EXPECT_EQ(local.grid.first, 0);
  EXPECT_EQ(local.grid.count, 5);
  EXPECT_NEAR(local.grid.to_frames(local.config.gamma), kClip.to_frames(f.left.config.gamma),
              1e-12);
  const Model back = with_window(local, kClip, f.left.config);
  ASSERT_TRUE(back.window);
  EXPECT_EQ(*back.window, *f.left.window);
  EXPECT_EQ(back.config.gamma, f.left.config.gamma);
  // A window that is the whole clip is no window.
  EXPECT_FALSE(with_window(f.whole, kClip, f.whole.config).window);
  test::expect_error(
      [&] {
        with_window(window_view(f.right), TimeGrid{1.0, 2.0, 9}, {});
      },
      {"not a window"});
}

TEST(Merge, WindowIsStoredInTheModelFile) {
  const fs::path dir = fs::temp_directory_path() / "retimegs_test_merge_file";
  fs::create_directories(dir);
  const Fixture f = fixture();
  write_model(dir / "right.rgs", f.right);
  const Model read = read_model(dir / "right.rgs");
  ASSERT_TRUE(read.window);
  EXPECT_EQ(*read.window, *f.right.window);
  write_model(dir / "whole.rgs", f.whole);
  EXPECT_FALSE(read_model(dir / "whole.rgs").window);
  fs::remove_all(dir);
}

TEST(Merge, RecordsItsSeamsAndStoresThem) {
  const Fixture f = fixture();
  EXPECT_TRUE(f.left.seams.empty());
  // Given in either order, the windows meet at training frame 4 (t = 8).
  const Model m = merge_models({f.right, f.left}, {"b", "a"});
  EXPECT_EQ(m.seams, (std::vector<int>{4}));
  const fs::path dir = fs::temp_directory_path() / "retimegs_test_merge_seams";
  fs::create_directories(dir);
  write_model(dir / "merged.rgs", m);
  EXPECT_EQ(read_model(dir / "merged.rgs").seams, m.seams);
  // A merged model merged again keeps its seams beside the new one.
  Model left = f.left, right = f.right;
  left.window = TimeWindow{0, 2};
  left.seams = {1};
  right.window = TimeWindow{2, 8};
  right.seams = {4, 6};
  EXPECT_EQ(merge_models({left, right}, {"a", "b"}).seams, (std::vector<int>{1, 2, 4, 6}));
  // A seam at the clip's end is no seam: refused when written.
  Model bad = m;
  bad.seams = {8};
  EXPECT_THROW(write_model(dir / "bad.rgs", bad), Error);
  fs::remove_all(dir);
}

TEST(Merge, PartialMergeKeepsItsOuterEndsOpen) {
  // The same two windows as part of a longer clip (to t = 20): merged, they cover 0..16 only.
  Fixture f = fixture();
  f.left.grid.count = f.right.grid.count = 11;
  const Model m = merge_models({f.left, f.right}, {"a", "b"});
  ASSERT_TRUE(m.window);
  EXPECT_EQ(*m.window, (TimeWindow{0, 8}));
  const Model drawn = window_view(m);
  EXPECT_NEAR(temporal_sum(drawn, kSeam), 1.0, 1e-5);  // the seam closed
  // Two primitives end at 16 ([14, 16] and [10, 16]): open there, as trained, each draws 1 (0.5
  // on the clip's grid, where the rest of the clip would meet them).
  EXPECT_NEAR(temporal_sum(drawn, 16.0), 2.0, 1e-5);
  EXPECT_NEAR(temporal_sum(m, 16.0), 1.0, 1e-5);
}

TEST(Merge, RefusesOverlapsGapsAndMismatches) {
  const Fixture f = fixture();
  Model early = f.right;
  early.window = TimeWindow{3, 8};
  test::expect_error(
      [&] {
        merge_models({f.left, early}, {"L.rgs", "R.rgs"});
      },
      {"L.rgs", "R.rgs", "overlap"});
  Model late = f.right;
  late.window = TimeWindow{5, 8};
  test::expect_error(
      [&] {
        merge_models({f.left, late}, {"L.rgs", "R.rgs"});
      },
      {"L.rgs", "R.rgs", "gap"});
  test::expect_error(
      [&] {
        merge_models({f.whole, f.right}, {"W.rgs", "R.rgs"});
      },
      {"W.rgs", "R.rgs", "overlap"});
  Model other_grid = f.right;
  other_grid.grid.count = 10;
  test::expect_error(
      [&] {
        merge_models({f.left, other_grid}, {"L.rgs", "G.rgs"});
      },
      {"L.rgs", "G.rgs", "time grids"});
  Model other_gamma = f.right;
  other_gamma.config.gamma *= 2;
  test::expect_error(
      [&] {
        merge_models({f.left, other_gamma}, {"L.rgs", "C.rgs"});
      },
      {"L.rgs", "C.rgs", "model settings"});
  Model stgs = f.right;
  stgs.config.representation = Representation::kStgs;
  test::expect_error([&] { merge_models({f.left, stgs}, {"L.rgs", "S.rgs"}); }, {"S.rgs"});
}

TEST(Merge, CameraColoursAreIntervalWeightedMeans) {
  const Fixture f = fixture();
  Model a = f.left, b = f.right;
  a.window = TimeWindow{0, 2};  // 2 intervals
  b.window = TimeWindow{2, 8};  // 6 intervals
  a.camera_colors["c"].m = {0.4f, 0, 0};
  b.camera_colors["c"].m = {0.0f, 0.8f, 0};
  const Model m = merge_models({a, b}, {"a", "b"});
  EXPECT_NEAR(m.camera_colors.at("c").m[0], 0.1, 1e-6);
  EXPECT_NEAR(m.camera_colors.at("c").m[1], 0.6, 1e-6);
}

}  // namespace
}  // namespace retimegs::model
