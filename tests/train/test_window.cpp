// train --window: a window trains only its frames, writes a model on the clip's grid with its
// window recorded, resumes only from its own checkpoints; a window drawn alone matches what it
// trained on.
#include <algorithm>
#include <filesystem>

#include <gtest/gtest.h>

#include "retimegs/model/model_file.hpp"
#include "retimegs/model/window.hpp"
#include "retimegs/train/dataset.hpp"
#include "retimegs/train_run/load_training_set.hpp"
#include "retimegs/train_run/run.hpp"
#include "synth_scene.hpp"
#include "test_util.hpp"

namespace retimegs::train {
namespace {
namespace fs = std::filesystem;

TEST(Window, TrainingSetHoldsOnlyTheWindowsFrames) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 2, 32, 24);  // training frames 0, 2, 4
  const TrainingSet set =
      load_training_set(scene, io::FrameSelection::kEven, io::FrameWindow{2, 4});
  EXPECT_EQ(set.frames, (std::vector<int>{2, 4}));
  EXPECT_EQ(set.grid.first, 2);
  EXPECT_EQ(set.grid.count, 2);
  ASSERT_TRUE(set.clip_grid);
  EXPECT_EQ(set.clip_grid->count, 3);
  ASSERT_TRUE(set.forward[0][0]);   // 2 -> 4
  ASSERT_TRUE(set.backward[0][0]);  // 2 -> 0: out of the window's first frame, to the clip's
  ASSERT_TRUE(set.backward[0][1]);  // 4 -> 2
  EXPECT_FALSE(set.forward[0][1]);  // frame 4 ends the clip
  // The flows out of the window's ends are the clip's own files, as a whole-clip run loads them.
  const TrainingSet whole = load_training_set(scene, io::FrameSelection::kEven);
  EXPECT_EQ(set.backward[0][0]->uv, whole.backward[0][1]->uv);
  EXPECT_FALSE(load_training_set(scene, io::FrameSelection::kEven).clip_grid);
  test::expect_error(
      [&] {
        load_training_set(scene, io::FrameSelection::kEven, io::FrameWindow{1, 4});
      },
      {"window 1:4", "frame 1 is not a training frame"});
}

TEST(Window, ModelKeepsTheClipGridAndResumesOnlyItsOwnWindow) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 3, 48, 36);
  TrainRun run;
  run.config.iters = 30;
  run.config.cap = 1500;
  run.config.checkpoint_every = 10;
  run.progress = false;
  run.window = io::FrameWindow{2, 4};
  run.out = dir / "w";
  const model::Model m = train(scene, run);
  const model::Model read = model::read_model(dir / "w" / "model.rgs");
  ASSERT_TRUE(read.window);
  EXPECT_EQ(*read.window, (model::TimeWindow{1, 2}));
  EXPECT_EQ(read.grid.first, 0);
  EXPECT_EQ(read.grid.count, 3);
  EXPECT_EQ(read.config.gamma, run.config.gamma);
  // Every primitive lives within the window's frames.
  const model::Primitives& p = read.primitives;
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_GE(p.mu_tau[i] - p.tau_l[i], 2 - 1e-3) << i;
    EXPECT_LE(p.mu_tau[i] + p.tau_r[i], 4 + 1e-3) << i;
  }
  // Drawn alone it is the model training held: its own grid, the clip's edge width in frames.
  const model::Model local = model::window_view(read);
  EXPECT_EQ(local.grid.first, 2);
  EXPECT_EQ(local.grid.count, 2);
  EXPECT_NEAR(local.grid.to_frames(local.config.gamma), read.grid.to_frames(run.config.gamma),
              1e-12);
  // A checkpoint of window 2:4 does not resume window 0:2.
  fs::remove(dir / "w" / "model.rgs");
  run.resume = true;
  run.window = io::FrameWindow{0, 2};
  test::expect_error([&] { train(scene, run); }, {"checkpoint", "same --window"});
}

}  // namespace
}  // namespace retimegs::train
