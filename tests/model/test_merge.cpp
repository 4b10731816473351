// Window models (model/window.hpp) and their merge (model/merge.hpp): the seam of two windows
// draws as the unsplit model does, the window is stored in the file, and the refusals.
#include <cmath>
#include <filesystem>
#include <optional>
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

// Sets primitive i's velocity to `speed` world units per frame along x (v1 = v2 = v3).
void move(Primitives& p, std::size_t i, float speed) {
  for (int j = 0; j < 3; ++j) p.velocity[9 * i + 3 * j] = speed;
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
  // As render and eval draw it (playback::load_model): a window model as trained. Without a fade
  // (seam fade 0) the seam's edges are γ's, as every edge of the unsplit model.
  const Model merged =
      window_view(merge_models({f.right, f.left}, {"right.rgs", "left.rgs"}, /*seam_fade=*/0));
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

// The rows of the fixture's primitives over [6, 8] (window 0's last) and [8, 10] (window 1's
// first).
std::pair<std::size_t, std::size_t> seam_rows(const Model& m) {
  std::size_t before = 0, after = 0;
  for (std::size_t i = 0; i < m.primitives.size(); ++i) {
    if (m.primitives.mu_tau[i] == 7 && m.primitives.tau_r[i] == 1) before = i;
    if (m.primitives.mu_tau[i] == 9 && m.primitives.tau_r[i] == 1) after = i;
  }
  return {before, after};
}

TEST(Merge, SeamCrossFadesOverItsOwnScale) {
  const Fixture f = fixture();
  const double fade = 0.25, scale = fade * kClip.step;  // frames
  for (const Model& merged :
       {merge_models({f.left, f.right}, {"a", "b"}, fade),
        // A partial merge, drawn on its own grid (window_view): the seam moves with the grid.
        window_view(merge_models({f.left, f.right}, {"a", "b"}, fade))}) {
    EXPECT_EQ(merged.config.seam_fade, fade);
    const auto [before, after] = seam_rows(merged);
    for (double t = 7; t <= 9 + 1e-9; t += 0.125) {
      const double a = temporal_opacity(merged.primitives, before, merged.config, merged.grid, t);
      const double b = temporal_opacity(merged.primitives, after, merged.config, merged.grid, t);
      // Each side follows the seam's sigmoid, not γ's, and the two sum to one: at the seam each
      // is 0.5, as without a fade.
      EXPECT_NEAR(a, 1 / (1 + std::exp((t - kSeam) / scale)), 1e-4) << "t = " << t;
      EXPECT_NEAR(a + b, 1.0, 1e-4) << "t = " << t;
      // As slice draws it (SliceParams: the CPU and CUDA slices' settings).
      EXPECT_NEAR(temporal_sum(merged, t), 1.0, 1e-4) << "t = " << t;
    }
    // Edges away from the seam keep γ: the primitive over [6, 8] is at 0.5 at t = 6.
    EXPECT_NEAR(temporal_opacity(merged.primitives, before, merged.config, merged.grid, 6.0), 0.5,
                0.02);
  }
}

// Where windows touch, the edges at the seam are all edges their windows trained up to; the fade
// shows each beyond the seam. A primitive that stays put there keeps the fade (the static world
// cross-fades); a moving one keeps γ, since the fade would draw it on a path never trained.
TEST(Merge, OnlyWhatStaysPutFadesAtASeam) {
  Fixture f = fixture();
  // Over the fade's reach (two of its scales: 2 frames), window 0's primitive of [6, 8] moves
  // 0.04, a fifth of its axis (0.2): it stays put; window 1's of [8, 10] moves 10 axes.
  move(f.left.primitives, 3, 0.02f);
  move(f.right.primitives, 0, 1.0f);
  const Model merged = merge_models({f.left, f.right}, {"a", "b"});
  EXPECT_EQ(merged.config.seam_fade, kDefaultSeamFade);
  const double scale = kDefaultSeamFade * kClip.step;
  const auto [before, after] = seam_rows(merged);
  const Primitives& p = merged.primitives;
  for (const double t : {7.0, 7.5, kSeam, 8.5, 9.0})
    EXPECT_NEAR(temporal_opacity(p, before, merged.config, merged.grid, t),
                1 / (1 + std::exp((t - kSeam) / scale)), 1e-4)
        << "t = " << t;
  // The moving one starts 2ε after the seam, with γ (0.08 frames here): nothing of it shows at
  // the held-out frame before the seam, where the fade would show 12 % of it.
  EXPECT_LT(temporal_opacity(p, after, merged.config, merged.grid, kSeam - 1), 1e-4);
  EXPECT_NEAR(temporal_opacity(p, after, merged.config, merged.grid, kSeam + 0.002), 0.5, 1e-3);
  EXPECT_GT(temporal_opacity(p, after, merged.config, merged.grid, kSeam + 0.5), 0.99);
  // Its support, not its trajectory, moved: μ_τ as trained.
  EXPECT_EQ(p.mu_tau[after], 9);
  // Without a fade nothing is moved: every seam edge keeps γ.
  const Model sharp = merge_models({f.left, f.right}, {"a", "b"}, 0);
  EXPECT_EQ(sharp.primitives.tau_l[seam_rows(sharp).second], 1);
}

// Near a seam an image is the cross-fade of two images, each side's window drawn whole
// (seam_handover; playback draws them): drawn for one side, the seam's edges of that side are open
// and the other side's primitives there absent, so one primitive covers each time across the seam.
TEST(Merge, EachSideOfASeamDrawsItsWindowWhole) {
  const Fixture f = fixture();
  const Model merged = merge_models({f.left, f.right}, {"a", "b"});
  // Plain names: clang before 16 cannot capture structured bindings in a lambda.
  const std::pair<std::size_t, std::size_t> rows = seam_rows(merged);
  const std::size_t before = rows.first, after = rows.second;
  const auto side_sum = [&](SeamSide side, double t) {
    SliceOptions options;
    options.min_opacity = 0;
    options.side = side, options.side_seam = kSeam;
    const TimeSlice e = slice(merged.primitives, merged.config, merged.grid, t, camera(), options);
    double sum = 0;
    for (std::size_t k = 0; k < e.temporal.size(); ++k) {
      const std::size_t i = e.primitive_from_gaussian[k];
      EXPECT_NE(i, side == SeamSide::kBefore ? after : before) << "t = " << t;
      sum += e.temporal[k];
    }
    return sum;
  };
  for (double t = 7; t <= 9 + 1e-9; t += 0.125) {  // beyond the γ tails of the next edges
    EXPECT_NEAR(side_sum(SeamSide::kBefore, t), 1.0, 1e-4) << "t = " << t;
    EXPECT_NEAR(side_sum(SeamSide::kAfter, t), 1.0, 1e-4) << "t = " << t;
  }
  // The weights: the seam nearest t, the image before it weighted by the seam's sigmoid; beyond
  // the tail one side alone is drawn.
  const double scale = kDefaultSeamFade * kClip.step;
  for (const double t : {0.0, 5.0, 7.5, kSeam, 8.5, 11.0, 16.0}) {
    const std::optional<SeamHandover> h = seam_handover(merged.config, merged.grid, t);
    ASSERT_TRUE(h);
    EXPECT_EQ(h->seam, kSeam);
    const double before_weight = 1 / (1 + std::exp((t - kSeam) / scale));
    EXPECT_NEAR(h->before, before_weight, 1e-12) << "t = " << t;
    EXPECT_EQ(h->draws(SeamSide::kBefore), before_weight > kHandoverTail) << "t = " << t;
    EXPECT_EQ(h->draws(SeamSide::kAfter), before_weight < 1 - kHandoverTail) << "t = " << t;
  }
  EXPECT_FALSE(seam_handover(f.whole.config, f.whole.grid, kSeam));
}

TEST(Merge, SeamFadeIsStoredAndKeptByASecondMerge) {
  const Fixture f = fixture();
  const fs::path dir = fs::temp_directory_path() / "retimegs_test_merge_fade";
  fs::create_directories(dir);
  Model m = merge_models({f.left, f.right}, {"a", "b"}, 0.4);
  write_model(dir / "merged.rgs", m);
  EXPECT_EQ(read_model(dir / "merged.rgs").config.seam_fade, 0.4);
  // merge's default when none is given.
  EXPECT_EQ(merge_models({f.left, f.right}, {"a", "b"}).config.seam_fade, kDefaultSeamFade);
  // A merged model merged again: one fade for all its seams, the new merge's.
  Model left = f.left, right = f.right;
  left.window = TimeWindow{0, 2};
  left.config.seams = {1};
  left.config.seam_fade = 0.4;
  right.window = TimeWindow{2, 8};
  const Model again = merge_models({left, right}, {"a", "b"}, 0.3);
  EXPECT_EQ(again.config.seams, (std::vector<int>{1, 2}));
  EXPECT_EQ(again.config.seam_fade, 0.3);
  // Without a fade (a file from before the fade, or --seam-fade 0) the key is absent and the
  // seams' edges read as γ's.
  m.config.seam_fade = 0;
  write_model(dir / "plain.rgs", m);
  const Model plain = read_model(dir / "plain.rgs");
  EXPECT_EQ(plain.config.seam_fade, 0);
  EXPECT_EQ(plain.config.seams, m.config.seams);
  EXPECT_EQ(seam_scale_frames(plain.config, plain.grid), plain.grid.to_frames(plain.config.gamma));
  // A fade beyond core/limits.hpp's range is refused, naming it.
  test::expect_error([&] { merge_models({f.left, f.right}, {"a", "b"}, 1.5); }, {"seam fade"});
  fs::remove_all(dir);
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
  EXPECT_TRUE(f.left.config.seams.empty());
  // Given in either order, the windows meet at training frame 4 (t = 8).
  const Model m = merge_models({f.right, f.left}, {"b", "a"});
  EXPECT_EQ(m.config.seams, (std::vector<int>{4}));
  const fs::path dir = fs::temp_directory_path() / "retimegs_test_merge_seams";
  fs::create_directories(dir);
  write_model(dir / "merged.rgs", m);
  EXPECT_EQ(read_model(dir / "merged.rgs").config.seams, m.config.seams);
  // A merged model merged again keeps its seams beside the new one.
  Model left = f.left, right = f.right;
  left.window = TimeWindow{0, 2};
  left.config.seams = {1};
  right.window = TimeWindow{2, 8};
  right.config.seams = {4, 6};
  EXPECT_EQ(merge_models({left, right}, {"a", "b"}).config.seams, (std::vector<int>{1, 2, 4, 6}));
  // A seam at the clip's end is no seam: refused when written.
  Model bad = m;
  bad.config.seams = {8};
  EXPECT_THROW(write_model(dir / "bad.rgs", bad), Error);
  fs::remove_all(dir);
}

TEST(Merge, PartialMergeKeepsItsOuterEndsOpen) {
  // The same two windows as part of a longer clip (to t = 20): merged, they cover 0..16 only.
  // Without a fade, whose tail at t = 16 would add ψ(-8) = 3e-4 of the seam's edges.
  Fixture f = fixture();
  f.left.grid.count = f.right.grid.count = 11;
  const Model m = merge_models({f.left, f.right}, {"a", "b"}, 0);
  ASSERT_TRUE(m.window);
  EXPECT_EQ(*m.window, (TimeWindow{0, 8}));
  const Model drawn = window_view(m);
  EXPECT_NEAR(temporal_sum(drawn, kSeam), 1.0, 1e-5);  // the seam closed
  // Two primitives end at 16 ([14, 16] and [10, 16]): open there, as trained, each draws 1 (0.5
  // on the clip's grid, where the rest of the clip would meet them).
  EXPECT_NEAR(temporal_sum(drawn, 16.0), 2.0, 1e-5);
  EXPECT_NEAR(temporal_sum(m, 16.0), 1.0, 1e-5);
}

// Windows that overlap (slurm --overlap): window 0 trained 0..10, window 1 6..16, both with their
// own primitives over [6, 8] and [8, 10] and one stretched over [6, 10].
TEST(Merge, OverlappingWindowsHandOverInTheMiddleOfTheirOverlap) {
  std::mt19937 rng(11);
  Fixture f = fixture();
  f.left.window = TimeWindow{0, 5};
  f.right.window = TimeWindow{3, 8};
  add(f.left.primitives, 8, 10, rng);
  add(f.left.primitives, 6, 10, rng);
  add(f.right.primitives, 6, 8, rng);
  add(f.right.primitives, 6, 10, rng);  // μ_τ = 7: ended at the seam, its τ_l is negative
  move(f.left.primitives, 3, 1.0f);     // window 0's of [6, 8]: moves, ends at the seam
  // The unsplit model's counterpart: the two stretched primitives, each cut at the seam.
  Model whole = f.whole;
  add(whole.primitives, 6, 8, rng);
  add(whole.primitives, 8, 10, rng);
  for (const Model& merged : {merge_models({f.right, f.left}, {"right.rgs", "left.rgs"}, 0),
                              merge_models({f.left, f.right}, {"a", "b"})}) {
    EXPECT_EQ(merged.config.seams, (std::vector<int>{4}));  // the middle of training frames 3..5
    // Window 0's [8, 10] and window 1's [6, 8] lie beyond the seam: dropped.
    ASSERT_EQ(merged.primitives.size(), whole.primitives.size());
    const Primitives& p = merged.primitives;
    int cut_before = 0, cut_after = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double from = p.mu_tau[i] - p.tau_l[i], to = p.mu_tau[i] + p.tau_r[i];
      EXPECT_FALSE(from < kSeam - 1e-3 && to > kSeam + 1e-3) << "row " << i << " crosses the seam";
      if (p.mu_tau[i] == 7 && std::abs(from - 6) < 1e-6 && std::abs(to - kSeam) < 1e-6)
        ++cut_before;
      if (p.mu_tau[i] == 7 && std::abs(from - kSeam) < 1e-6 && std::abs(to - 10) < 1e-6) {
        ++cut_after;
        EXPECT_FLOAT_EQ(p.tau_l[i], -1);
      }
    }
    // Window 0's stretched one, cut, and with a fade only that one: its moving [6, 8] ended at
    // the seam as trained and moved 2ε off it (without a fade it stays, each edge γ's).
    EXPECT_EQ(cut_before, merged.config.seam_fade > 0 ? 1 : 2);
    EXPECT_EQ(cut_after, 1);  // window 1's stretched one, cut
  }
  // Without a fade (nothing moves off the seam then) it draws as the unsplit model, across the
  // overlap and everywhere else.
  const Model merged = merge_models({f.left, f.right}, {"a", "b"}, 0);
  for (double t = 0; t <= 16 + 1e-9; t += 0.25)
    EXPECT_NEAR(temporal_sum(merged, t), temporal_sum(whole, t), 1e-5) << "t = " << t;
  // With the fade, the supports the merge cut fade at the seam, trained on both sides of it;
  // window 0's moving primitive of the interval [6, 8] ended there as trained and keeps γ: half an
  // interval past the seam it is gone, where the cut one still shows its fade's tail.
  const Model faded = merge_models({f.left, f.right}, {"a", "b"});
  const double scale = kDefaultSeamFade * kClip.step, later = kSeam + 1;
  int natural = 0, cut = 0;
  for (std::size_t i = 0; i < faded.primitives.size(); ++i) {
    const Primitives& p = faded.primitives;
    if (p.mu_tau[i] != 7 || p.tau_l[i] != 1) continue;  // window 0's rows over [6, ...]
    const double sigma = temporal_opacity(p, i, faded.config, faded.grid, later);
    if (p.tau_r[i] < 1) {  // ended at the seam in window 0
      ++natural;
      EXPECT_LT(sigma, 1e-3);
    } else {
      ++cut;
      EXPECT_NEAR(sigma, 1 / (1 + std::exp((later - kSeam) / scale)), 1e-4);
    }
  }
  EXPECT_EQ(natural, 1);
  EXPECT_EQ(cut, 1);
  // A merged model with a negative half-width is written and read back as it is; an empty
  // window (τ_l + τ_r < 0) is refused (check_primitives, also where a file is read).
  const fs::path dir = fs::temp_directory_path() / "retimegs_test_merge_overlap";
  fs::create_directories(dir);
  write_model(dir / "merged.rgs", merged);
  EXPECT_EQ(read_model(dir / "merged.rgs").primitives.tau_l, merged.primitives.tau_l);
  Model empty = merged;
  empty.primitives.tau_l[0] = -empty.primitives.tau_r[0] - 0.5f;
  test::expect_error([&] { write_model(dir / "empty.rgs", empty); },
                     {"empty.rgs", "primitive 0", "empty temporal window"});
  fs::remove_all(dir);
}

TEST(Merge, RefusesOverlapsGapsAndMismatches) {
  const Fixture f = fixture();
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
      {"W.rgs", "R.rgs", "overlap", "holds"});
  // Merged models that overlap keep their own seams only where their rows are kept.
  {
    Model left = f.left, right = f.right;
    left.window = TimeWindow{0, 5};
    left.config.seams = {2, 4};
    right.window = TimeWindow{3, 8};
    right.config.seams = {3, 7};
    EXPECT_EQ(merge_models({left, right}, {"L.rgs", "R.rgs"}).config.seams,
              (std::vector<int>{2, 4, 7}));
  }
  // Three windows that overlap: each hands over to the next in the middle of their overlap.
  Model middle = f.right;
  middle.window = TimeWindow{2, 6};
  EXPECT_EQ(merge_models({f.left, middle, f.right}, {"L.rgs", "M.rgs", "R.rgs"}).config.seams,
            (std::vector<int>{3, 5}));
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

// Issue 65: the windows' pose corrections of a camera, weighted as the colour maps are; a camera
// only one window refined keeps that window's.
TEST(Merge, CameraPosesAreIntervalWeightedMeans) {
  const Fixture f = fixture();
  Model a = f.left, b = f.right;
  a.window = TimeWindow{0, 2};  // 2 intervals
  b.window = TimeWindow{2, 8};  // 6 intervals
  a.camera_poses["c"] = {{0.04, 0, -0.02}, {0.2, 0, 0}};
  b.camera_poses["c"] = {{0, 0.08, 0.02}, {0, -0.4, 0}};
  b.camera_poses["d"] = {{0.01, 0.02, 0.03}, {0.1, 0.2, 0.3}};
  const Model m = merge_models({b, a}, {"b", "a"});
  ASSERT_EQ(m.camera_poses.size(), 2u);
  const CameraPose& c = m.camera_poses.at("c");
  EXPECT_NEAR(c.rotation[0], 0.01, 1e-12);
  EXPECT_NEAR(c.rotation[1], 0.06, 1e-12);
  EXPECT_NEAR(c.rotation[2], 0.01, 1e-12);
  EXPECT_NEAR(c.translation[0], 0.05, 1e-12);
  EXPECT_NEAR(c.translation[1], -0.3, 1e-12);
  EXPECT_EQ(c.translation[2], 0.0);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(m.camera_poses.at("d").rotation[k], b.camera_poses.at("d").rotation[k], 1e-15);
    EXPECT_NEAR(m.camera_poses.at("d").translation[k], b.camera_poses.at("d").translation[k],
                1e-15);
  }
  EXPECT_TRUE(merge_models({f.left, f.right}, {"l", "r"}).camera_poses.empty());
}

}  // namespace
}  // namespace retimegs::model
