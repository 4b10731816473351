// Checkpoints prove that their files belong together: manifest.json, written last, lists each
// file's size and hash, and resuming refuses in one line, naming the checkpoint and the file, a
// file of another step, swapped Adam moments, a truncated or missing file and a checkpoint
// without a manifest. Writing a checkpoint keeps the latest `checkpoint_keep`.
#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/train/checkpoint.hpp"
#include "retimegs/train_run/run.hpp"
#include "synth_scene.hpp"
#include "test_util.hpp"

namespace retimegs::train {
namespace {
namespace fs = std::filesystem;

// A run of 4 steps with its checkpoints at steps 2 and 4, trained once and copied per test.
class CheckpointDamage : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    scene_ = new io::Scene(minimal_scene(*dir_ / "scene", 2, 32, 24));
    train(*scene_, run(*dir_ / "trained"));
  }
  static void TearDownTestSuite() {
    delete scene_;
    delete dir_;
  }

  static TrainRun run(const fs::path& out) {
    TrainRun run;
    run.config.iters = 4;
    run.config.cap = 400;
    run.config.checkpoint_every = 2;
    run.progress = false;
    run.out = out;
    return run;
  }

  void SetUp() override {
    fs::copy(*dir_ / "trained", copy_.path(), fs::copy_options::recursive);
    fs::remove(copy_ / "model.rgs");
  }

  fs::path latest() const { return copy_ / "checkpoints" / "iter_000004"; }
  fs::path earlier() const { return copy_ / "checkpoints" / "iter_000002"; }

  // The one-line refusal of resuming the copy, which names the latest checkpoint and `file`.
  std::string resume_refusal(const std::string& file) {
    TrainRun resumed = run(copy_.path());
    resumed.resume = true;
    const std::string message = test::message_of([&] { train(*scene_, resumed); });
    EXPECT_NE(message.find(latest().string() + ": " + file), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    return message;
  }

  static test::TempDir* dir_;
  static io::Scene* scene_;
  test::TempDir copy_;
};

test::TempDir* CheckpointDamage::dir_ = nullptr;
io::Scene* CheckpointDamage::scene_ = nullptr;

TEST_F(CheckpointDamage, AnIntactCheckpointResumes) {
  TrainRun resumed = run(copy_.path());
  resumed.resume = true;
  train(*scene_, resumed);
  EXPECT_EQ(test::read_text(copy_ / "model.rgs"), test::read_text(*dir_ / "trained" / "model.rgs"));
}

TEST_F(CheckpointDamage, AModelOfAnotherStepIsRefused) {
  fs::copy_file(earlier() / "model.rgs", latest() / "model.rgs",
                fs::copy_options::overwrite_existing);
  EXPECT_NE(resume_refusal("model.rgs").find("another step's file"), std::string::npos);
}

TEST_F(CheckpointDamage, AStateOfAnotherStepIsRefused) {
  fs::copy_file(earlier() / "state.json", latest() / "state.json",
                fs::copy_options::overwrite_existing);
  EXPECT_NE(resume_refusal("state.json").find("another step's file"), std::string::npos);
}

// Same sizes, so only the hashes tell them apart; unchecked, the run fails later with NaNs.
TEST_F(CheckpointDamage, SwappedAdamMomentsAreRefused) {
  const fs::path m = latest() / "adam" / "mu_m.npy", v = latest() / "adam" / "mu_v.npy";
  fs::rename(m, copy_ / "swap");
  fs::rename(v, m);
  fs::rename(copy_ / "swap", v);
  EXPECT_NE(resume_refusal("adam/mu_m.npy").find("differs from its manifest's hash"),
            std::string::npos);
}

TEST_F(CheckpointDamage, ATruncatedFileIsRefused) {
  const fs::path file = latest() / "adam" / "sh_v.npy";
  fs::resize_file(file, fs::file_size(file) / 2);
  EXPECT_NE(resume_refusal("adam/sh_v.npy").find("truncated"), std::string::npos);
}

TEST_F(CheckpointDamage, AMissingFileIsRefused) {
  fs::remove(latest() / "adam" / "q0_m.npy");
  EXPECT_NE(resume_refusal("adam/q0_m.npy is missing").find("--force"), std::string::npos);
}

TEST_F(CheckpointDamage, AFileTheManifestDoesNotListIsRefused) {
  fs::copy_file(latest() / "adam" / "mu_m.npy", latest() / "adam" / "extra_m.npy");
  resume_refusal("adam/extra_m.npy is not in its manifest");
}

// Checkpoints of a retimegs before manifests cannot be verified: refused, with the way out.
TEST_F(CheckpointDamage, ACheckpointWithoutAManifestIsRefused) {
  fs::remove(latest() / "manifest.json");
  EXPECT_NE(resume_refusal("the checkpoint has no manifest.json").find("--force"),
            std::string::npos);
}

// The manifest's iteration is the state's.
TEST_F(CheckpointDamage, AManifestOfAnotherStepIsRefused) {
  fs::copy_file(earlier() / "state.json", latest() / "state.json",
                fs::copy_options::overwrite_existing);
  write_checkpoint_manifest(latest(), 4);
  resume_refusal("state.json is at iteration 2, its manifest at 4");
}

// checkpoint_keep 2 (the default) leaves the latest two; 0 keeps every one.
TEST(CheckpointKeep, WritingACheckpointKeepsTheLatestOnes) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 2, 32, 24);
  const auto checkpoints = [&](const fs::path& run) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(run / "checkpoints"))
      names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  };
  TrainRun run;
  run.config.iters = 5;
  run.config.cap = 300;
  run.config.checkpoint_every = 1;
  run.progress = false;
  run.out = dir / "kept";
  ASSERT_EQ(run.config.checkpoint_keep, 2);
  train(scene, run);
  EXPECT_EQ(checkpoints(run.out), (std::vector<std::string>{"iter_000004", "iter_000005"}));
  run.config.checkpoint_keep = 0;
  run.out = dir / "all";
  train(scene, run);
  EXPECT_EQ(checkpoints(run.out).size(), 5u);
}

}  // namespace
}  // namespace retimegs::train
