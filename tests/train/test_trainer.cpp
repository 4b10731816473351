// End to end on a tiny synthetic scene: training beats the cross-fade baseline on held-out
// in-between frames; resuming from a checkpoint reproduces the uninterrupted run bit for bit; the
// same seed gives the same model.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "retimegs/eval/protocol.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/model/temporal_index.hpp"
#include "retimegs/playback/render_model.hpp"
#include "retimegs/train/checkpoint.hpp"
#include "retimegs/train/cpu_step.hpp"
#include "retimegs/train/relocation.hpp"
#include "retimegs/train_run/load_training_set.hpp"
#include "retimegs/train_run/run.hpp"
#include "synth_scene.hpp"
#include "test_util.hpp"

namespace retimegs::train {
namespace {
namespace fs = std::filesystem;

TEST(Trainer, HeldOutFramesBeatCrossfade) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 4, 96, 72);
  TrainRun run;
  run.out = dir / "run";
  run.config.iters = 600;
  run.config.cap = 6000;
  run.progress = false;
  const model::Model model = train(scene, run);
  EXPECT_TRUE(fs::exists(dir / "run" / "model.rgs"));
  EXPECT_TRUE(fs::exists(dir / "run" / "config.json"));
  EXPECT_NE(test::read_text(dir / "run" / "log.jsonl").find("\"active\":"), std::string::npos);
  EXPECT_TRUE(
      faint_short_rows(model.primitives, model.grid, run.config.final_prune_opacity).empty())
      << "train() ends with finish()";

  eval::EvalOptions options;
  options.frames = {1, 3};
  for (int c = 0; c < int(scene.cameras.size()); ++c) options.cameras.push_back(c);
  options.progress = false;
  const float black[3] = {0, 0, 0};
  const auto ours = eval::evaluate_views(
      scene,
      [&](int c, int k) { return playback::render_model(model, scene.cameras[c], k, black); },
      options);
  const auto crossfade = eval::evaluate_views(
      scene, eval::baseline_renderer(scene, {0, 2, 4}, eval::Baseline::kCrossfade), options);
  EXPECT_GT(ours.psnr, crossfade.psnr + 0.5)
      << "held-out PSNR " << ours.psnr << " vs cross-fade " << crossfade.psnr;
  EXPECT_GT(ours.ssim, crossfade.ssim);
}

// step() is step_view() on the view it draws (the first step's losses: later ones differ by the
// generator's draws of the view); an explicit starting model is used as given; a step's stage
// times are its parts; a view outside the training set is an error.
TEST(Trainer, StepViewStagesAndExplicitPrimitives) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 3, 48, 36);
  const TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);
  TrainConfig config;
  config.iters = 40;
  config.cap = 1500;
  CpuStep drawn(set, config), given(set, config);
  drawn.initialize();
  given.initialize(drawn.model().primitives);
  const StepStats a = drawn.step();
  const int c =
      int(std::find(set.cameras.begin(), set.cameras.end(), a.camera) - set.cameras.begin());
  const int i = int(std::find(set.frames.begin(), set.frames.end(), a.frame) - set.frames.begin());
  const StepStats b = given.step_view(c, i);
  EXPECT_EQ(a.loss, b.loss);
  EXPECT_EQ(a.psnr, b.psnr);
  EXPECT_EQ(a.renders, b.renders);
  for (int k = 0; k < 3; ++k) {
    const StageSeconds t = given.step_view(k % int(set.cameras.size()), 1).seconds;
    for (double stage :
         {t.slice, t.render_forward, t.losses, t.render_backward, t.slice_backward, t.optimizer})
      EXPECT_GE(stage, 0);
    EXPECT_GE(t.other(), 0);
    EXPECT_GT(t.slice * t.render_forward * t.losses * t.render_backward, 0);
  }
  test::expect_error([&] { given.step_view(int(set.cameras.size()), 0); }, {"no view"});
  test::expect_error([&] { given.step_view(0, -1); }, {"no view"});
}

// At an interior frame the no-triple ablation's step has the full recipe's flow loss (the same
// group renders) and the image loss of the all-primitives render alone (that of a step with no
// flow loss either, which renders nothing else).
TEST(Trainer, NoTripleStepKeepsTheGroupsFlowLossAndDropsTheirImageLoss) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 3, 48, 36);
  const TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);
  TrainConfig full;
  full.iters = 40;
  full.cap = 1500;
  TrainConfig no_triple = full, all_only = full;
  no_triple.ablate.no_triple = true;
  all_only.ablate.no_triple = all_only.ablate.no_flow_loss = true;
  CpuStep first(set, full);
  first.initialize();
  std::vector<StepStats> stats;
  for (const TrainConfig& config : {full, no_triple, all_only}) {
    CpuStep step(set, config);
    step.initialize(first.model().primitives);
    stats.push_back(step.step_view(1, 1));  // frame slot 1 of 0, 2, 4: interior
  }
  EXPECT_EQ(stats[0].renders, 3);
  EXPECT_EQ(stats[1].renders, 3);
  EXPECT_EQ(stats[2].renders, 1);
  EXPECT_GT(stats[0].flow_loss, 0);
  EXPECT_EQ(stats[1].flow_loss, stats[0].flow_loss);
  EXPECT_EQ(stats[1].image_loss, stats[2].image_loss);
  EXPECT_LT(stats[1].image_loss, stats[0].image_loss);
  EXPECT_EQ(stats[1].psnr, stats[0].psnr);
}

// tie_end_velocities: after a step at the clip's first (last) frame, the primitives of the first
// (last) interval have v1 = v2 (v3 = v2); without it v2 learns and v1 (v3) stays where the
// initialisation put it, on the initial v2.
TEST(Trainer, TieEndVelocitiesKeepsTheEndsOnV2) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 3, 48, 36);
  const TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);  // 0, 2, 4
  for (const bool tie : {false, true}) {
    TrainConfig config;
    config.iters = 40;
    config.cap = 1500;
    config.tie_end_velocities = tie;
    CpuStep step(set, config);
    step.initialize();
    step.step_view(0, 0);
    step.step_view(1, 2);
    const model::Primitives& p = step.model().primitives;
    std::size_t first = 0, last = 0, first_tied = 0, last_tied = 0;
    for (std::size_t r = 0; r < p.size(); ++r) {
      const float* v = &p.velocity[9 * r];
      const bool v1_tied = std::equal(v, v + 3, v + 3), v3_tied = std::equal(v + 6, v + 9, v + 3);
      if (p.tau_l[r] != 1.0f || p.tau_r[r] != 1.0f) continue;  // still content spans more
      if (p.mu_tau[r] == 1.0f) ++first, first_tied += v1_tied;
      if (p.mu_tau[r] == 3.0f) ++last, last_tied += v3_tied;
    }
    ASSERT_GT(first, 100u);
    ASSERT_GT(last, 100u);
    if (tie) {
      EXPECT_EQ(first_tied, first);
      EXPECT_EQ(last_tied, last);
    } else {
      EXPECT_LT(first_tied, first);
      EXPECT_LT(last_tied, last);
    }
  }
}

// A step changes only the rows of its active set, the temporal index's rows at its frame (the
// first step neither relocates nor stretches); the STGS baseline's set is every row.
TEST(Trainer, AStepChangesOnlyItsActiveRows) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 3, 48, 36);
  const TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);
  for (const bool stgs : {false, true}) {
    TrainConfig config;
    config.iters = 40;
    config.cap = 1500;
    config.stgs_baseline = stgs;
    CpuStep trainer(set, config);
    trainer.initialize();
    const model::Primitives before = trainer.model().primitives;
    const model::TemporalIndex index(before, trainer.model().config, trainer.model().grid);
    const std::vector<std::int32_t>& rows = index.rows_at(0);
    const StepStats s = trainer.step_view(1, 0);
    EXPECT_EQ(s.active, rows.size());
    if (stgs) {
      EXPECT_EQ(s.active, before.size());
      continue;
    }
    EXPECT_GT(s.active, 0u);
    EXPECT_LT(s.active, before.size());
    const model::Primitives& after = trainer.model().primitives;
    ASSERT_EQ(after.size(), before.size());
    std::size_t changed = 0;
    for (std::size_t r = 0; r < before.size(); ++r) {
      const bool active = std::binary_search(rows.begin(), rows.end(), std::int32_t(r));
      bool same = true;
      for (int f = 0; f < model::Primitives::kFieldCount; ++f) {
        const auto& a = *before.fields()[f].values;
        const auto& b = *after.fields()[f].values;
        const int width = before.fields()[f].width;
        same = same && std::equal(a.begin() + r * width, a.begin() + (r + 1) * width,
                                  b.begin() + r * width);
      }
      if (!active) {
        ASSERT_TRUE(same) << "row " << r << " is not active at frame 0";
      }
      changed += !same;
    }
    EXPECT_EQ(changed, s.active) << "every active row moves (Adam's first step moves every row)";
  }
}

// finish() removes the faint primitives of one interval and nothing else, with their optimiser
// state: the kept rows are the others (as a set), and training can go on (index and Adam agree).
TEST(Trainer, FinishRemovesTheFaintShortLivedRows) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 3, 48, 36);
  const TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);
  TrainConfig config;
  config.iters = 4;
  config.cap = 600;
  CpuStep trainer(set, config);
  trainer.initialize();
  model::Primitives start = trainer.model().primitives;
  for (std::size_t r = 0; r < start.size(); r += 4) start.opacity_logit[r] = -5.0f;  // σ ≈ 0.007
  trainer.initialize(start);
  trainer.step_view(0, 1);
  const model::Model& model = trainer.model();
  const std::vector<std::int32_t> faint =
      faint_short_rows(model.primitives, model.grid, config.final_prune_opacity);
  ASSERT_GT(faint.size(), 10u);
  ASSERT_LT(faint.size(), model.primitives.size());
  const auto keys = [](const model::Primitives& p, const std::vector<bool>& skip) {
    std::vector<std::array<float, 4>> out;  // mean and opacity, sorted
    for (std::size_t i = 0; i < p.size(); ++i)
      if (skip.empty() || !skip[i])
        out.push_back({p.mu[3 * i], p.mu[3 * i + 1], p.mu[3 * i + 2], p.opacity_logit[i]});
    std::sort(out.begin(), out.end());
    return out;
  };
  std::vector<bool> skip(model.primitives.size(), false);
  for (const std::int32_t r : faint) skip[std::size_t(r)] = true;
  const auto expected = keys(model.primitives, skip);
  EXPECT_NE(trainer.finish().find(std::to_string(faint.size())), std::string::npos);
  EXPECT_EQ(keys(trainer.model().primitives, {}), expected);
  EXPECT_TRUE(
      faint_short_rows(trainer.model().primitives, model.grid, config.final_prune_opacity).empty());
  const StepStats s = trainer.step_view(1, 2);
  EXPECT_GE(s.primitives, expected.size());  // growth may add rows again
  EXPECT_TRUE(std::isfinite(s.loss));
}

// The trainer keeps its rows in the temporal index's locality order: a starting model in any order
// is reordered (the same primitives), and so is the model after relocation, growth and stretching.
TEST(Trainer, KeepsItsRowsInLocalityOrder) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 3, 48, 36);
  const TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);
  TrainConfig config;
  config.iters = 60;  // milestones scaled: relocation and growth every step, stretching at 9
  config.cap = 1500;
  CpuStep drawn(set, config);
  drawn.initialize();
  model::Primitives shuffled = drawn.model().primitives;
  std::vector<std::int32_t> old_from_new(shuffled.size());
  for (std::size_t k = 0; k < old_from_new.size(); ++k)
    old_from_new[k] = std::int32_t((k * 7919) % old_from_new.size());
  shuffled.reorder(old_from_new);
  const auto in_order = [&](const model::Primitives& p) {
    const std::vector<std::int32_t> order =
        model::TemporalIndex(p, drawn.model().config, drawn.model().grid).locality_order();
    for (std::size_t k = 0; k < order.size(); ++k)
      if (order[k] != std::int32_t(k)) return false;
    return true;
  };
  ASSERT_TRUE(in_order(drawn.model().primitives));
  ASSERT_FALSE(in_order(shuffled));
  CpuStep trainer(set, config);
  trainer.initialize(shuffled);
  EXPECT_TRUE(in_order(trainer.model().primitives));
  const auto rows = [](const model::Primitives& p) {  // the rows' means and colours, sorted
    std::vector<std::array<float, 6>> out(p.size());
    for (std::size_t i = 0; i < p.size(); ++i)
      for (int a = 0; a < 3; ++a)
        out[i][a] = p.mu[3 * i + a], out[i][3 + a] = p.sh[model::Primitives::kShWidth * i + a];
    std::sort(out.begin(), out.end());
    return out;
  };
  EXPECT_EQ(rows(trainer.model().primitives), rows(drawn.model().primitives));
  int changed = 0;
  for (int it = 0; it < config.iters; ++it) {
    const StepStats s = trainer.step();
    changed += s.relocated + s.added + s.stretched > 0;
    ASSERT_TRUE(in_order(trainer.model().primitives)) << "after step " << s.iteration;
  }
  EXPECT_GT(changed, 5);
}

TEST(Trainer, ResumeEqualsUninterruptedAndSeedsAreDeterministic) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 3, 48, 36);
  TrainRun run;
  run.config.iters = 40;
  run.config.cap = 1500;
  run.config.checkpoint_every = 15;
  run.config.checkpoint_keep = 0;  // all, to resume from the first
  run.progress = false;
  // Milestones scaled to 40 iterations: relocation every 1 step after 1, stretching every 6.
  run.out = dir / "full";
  train(scene, run);
  run.out = dir / "again";
  train(scene, run);
  EXPECT_EQ(test::read_text(dir / "full" / "model.rgs"),
            test::read_text(dir / "again" / "model.rgs"))
      << "same seed and threads must give the same model";
  // The camera colours are in the model and their Adam state in the checkpoint.
  EXPECT_EQ(model::read_model(dir / "full" / "model.rgs").camera_colors.size(), 3u);
  EXPECT_TRUE(
      fs::exists(dir / "full" / "checkpoints" / "iter_000015" / "adam" / "camera_color_v.npy"));
  // Interrupted: keep only the iteration-15 checkpoint of a copy and resume it.
  fs::copy(dir / "full", dir / "resumed", fs::copy_options::recursive);
  fs::remove(dir / "resumed" / "model.rgs");
  fs::remove_all(dir / "resumed" / "checkpoints" / "iter_000030");
  fs::remove_all(dir / "resumed" / "checkpoints" / "iter_000040");  // the last step's
  run.out = dir / "resumed";
  run.resume = true;
  train(scene, run);
  EXPECT_EQ(test::read_text(dir / "full" / "model.rgs"),
            test::read_text(dir / "resumed" / "model.rgs"));
  // A different seed gives a different model.
  run.resume = false;
  run.out = dir / "other";
  run.config.seed = 1;
  train(scene, run);
  EXPECT_NE(test::read_text(dir / "full" / "model.rgs"),
            test::read_text(dir / "other" / "model.rgs"));
  // An existing run is refused; force starts it afresh: the same model, a log of one run only.
  run.out = dir / "again";
  run.config.seed = 0;
  // The log without its wall times, which differ from run to run.
  const auto log_of = [](const fs::path& file) {
    std::istringstream lines(test::read_text(file));
    std::string out;
    for (std::string line; std::getline(lines, line);) {
      nlohmann::json entry = nlohmann::json::parse(line);
      EXPECT_TRUE(entry.contains("ms_per_step")) << line;
      entry.erase("ms_per_step");
      out += entry.dump() + "\n";
    }
    return out;
  };
  const std::string log = log_of(dir / "again" / "log.jsonl");
  EXPECT_NE(test::message_of([&] { train(scene, run); }).find("--force to start afresh"),
            std::string::npos);
  run.force = true;
  train(scene, run);
  EXPECT_EQ(test::read_text(dir / "full" / "model.rgs"),
            test::read_text(dir / "again" / "model.rgs"));
  EXPECT_EQ(log_of(dir / "again" / "log.jsonl"), log);
}

// One camera's images darkened by a known gain: its learned correction, relative to the other
// camera's, maps the scene's colours to the gain times theirs (compared as maps over the colours
// the scene shows: gain and offset are nearly interchangeable on a narrow range of values); the
// gauge keeps the corrections' mean at the identity. The run is short: a rate of 1e-2, ten times
// the default, and view-independent colour (SH degree 0), which cannot fit a camera's gain as
// view dependence of two cameras could.
TEST(Trainer, CameraColorRecoversAKnownGain) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 2, 48, 36);
  constexpr float kGain = 0.75f;
  constexpr int kDark = 1;
  std::vector<float> values;  // the undarkened camera's, to compare the maps over
  for (int k = 0; k < scene.num_frames; ++k) {
    Image image = media::load_image(scene, kDark, k);
    for (float& v : image.data) v *= kGain;
    media::write_png(scene.image_path(kDark, k), image);
    const Image other = media::load_image(scene, 1 - kDark, k);
    values.insert(values.end(), other.data.begin(), other.data.end());
  }
  const TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);
  TrainConfig config;
  config.iters = 400;
  config.cap = 1000;
  config.lr_camera_color = 1e-2;
  config.max_sh_degree = 0;
  CpuStep trainer(set, config);
  trainer.initialize();
  while (trainer.iteration() < config.iters) trainer.step();
  const auto& colors = trainer.model().camera_colors;
  ASSERT_EQ(colors.size(), 2u);
  const model::CameraColor& dark = colors.at(scene.cameras[kDark].name);
  const model::CameraColor& ref = colors.at(scene.cameras[1 - kDark].name);
  // Mean |dark map - gain · reference map| over the channels, and the same for identity maps.
  double deviation = 0, uncorrected = 0;
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(dark.m[k] + ref.m[k], 0.0, 1e-6) << "channel " << k;
    EXPECT_NEAR(dark.c[k] + ref.c[k], 0.0, 1e-6) << "channel " << k;
    EXPECT_LT(dark.m[k], ref.m[k]) << "channel " << k;
    for (std::size_t i = k; i < values.size(); i += 3) {
      const double x = values[i];
      deviation += std::abs(std::exp(dark.m[k]) * x + dark.c[k] -
                            kGain * (std::exp(ref.m[k]) * x + ref.c[k]));
      uncorrected += (1 - kGain) * x;
    }
  }
  EXPECT_GT(uncorrected / double(values.size()), 0.05);
  EXPECT_LT(deviation, 0.25 * uncorrected) << "the correction recovers most of the gain";
}

// The ablation learns no correction and stores none.
TEST(Trainer, NoCameraColorAblationStoresNone) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 2, 32, 24);
  TrainRun run;
  run.config.iters = 3;
  run.config.cap = 300;
  run.config.checkpoint_every = 2;
  run.config.ablate.no_camera_color = true;
  run.progress = false;
  run.out = dir / "run";
  EXPECT_TRUE(train(scene, run).camera_colors.empty());
  EXPECT_TRUE(model::read_model(dir / "run" / "model.rgs").camera_colors.empty());
  EXPECT_FALSE(
      fs::exists(dir / "run" / "checkpoints" / "iter_000002" / "adam" / "camera_color_m.npy"));
}

TEST(Trainer, ResumeFromAStateLackingAKeyNamesTheFileAndTheKey) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 3, 48, 36);
  TrainRun run;
  run.config.iters = 2;
  run.config.cap = 500;
  run.config.checkpoint_every = 1;
  run.progress = false;
  run.out = dir / "run";
  train(scene, run);
  // Drop the "iteration" line of the iteration-1 checkpoint's state (one key per line).
  const fs::path state = dir / "run" / "checkpoints" / "iter_000001" / "state.json";
  std::istringstream in(test::read_text(state));
  std::string text;
  for (std::string line; std::getline(in, line);)
    if (line.find("\"iteration\"") == std::string::npos) text += line + "\n";
  test::write_text(state, text);
  write_checkpoint_manifest(state.parent_path(), 1);            // as a writer of such a state would
  fs::remove_all(dir / "run" / "checkpoints" / "iter_000002");  // the last step's
  run.resume = true;
  const std::string message = test::message_of([&] { train(scene, run); });
  EXPECT_NE(message.find(state.string()), std::string::npos) << message;
  EXPECT_NE(message.find("lacks 'iteration'"), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

}  // namespace
}  // namespace retimegs::train
