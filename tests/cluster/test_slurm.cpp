// retimegs slurm: the window split, the job scripts, their submission through sbatch (a stand-in
// that records its arguments), and run_local.sh trained end to end on a small synthetic scene,
// then run again to resume. The real Slurm run is scripts/test_slurm.sh.
#include <sys/stat.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "retimegs/cluster/slurm.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/synth/synth.hpp"
#include "test_util.hpp"

namespace retimegs::cluster {
namespace {
namespace fs = std::filesystem;

fs::path small_scene(const test::TempDir& dir, int frames) {
  synth::SynthOptions options;
  options.preset = "minimal";
  options.cameras = 3;
  options.frames = frames;
  options.width = 32, options.height = 24;
  const fs::path root = dir / "scene";
  synth::synthesize_scene(options, root);
  return root;
}

bool executable(const fs::path& path) {
  return (fs::status(path).permissions() & fs::perms::owner_exec) != fs::perms::none;
}

TEST(Slurm, SplitWindowsShareTheirBoundaryFrames) {
  std::vector<int> frames;
  for (int k = 0; k <= 32; k += 2) frames.push_back(k);  // 33 frames trained on the even ones
  const auto four = split_windows(frames, 4);
  ASSERT_EQ(four.size(), 4u);
  for (int j = 0; j < 4; ++j) {
    EXPECT_EQ(four[j].first, 8 * j);
    EXPECT_EQ(four[j].last, 8 * j + 8);
  }
  const auto three = split_windows(frames, 3);  // 16 intervals: 5, 5, 6
  ASSERT_EQ(three.size(), 3u);
  EXPECT_EQ(three[0].first, 0);
  EXPECT_EQ(three[0].last, three[1].first);
  EXPECT_EQ(three[1].last, three[2].first);
  EXPECT_EQ(three[2].last, 32);
  EXPECT_EQ(split_windows(frames, 16).back().first, 30);
  test::expect_error([&] { split_windows(frames, 17); }, {"--windows 17", "1 to 16"});
  test::expect_error([&] { split_windows(frames, 0); }, {"--windows 0"});
}

TEST(Slurm, ShellQuoteKeepsWordsWhole) {
  EXPECT_EQ(shell_quote("/a/b_c-1.rgs"), "/a/b_c-1.rgs");
  EXPECT_EQ(shell_quote("a b"), "'a b'");
  EXPECT_EQ(shell_quote("it's"), "'it'\\''s'");
  EXPECT_EQ(shell_quote(""), "''");
}

TEST(Slurm, ScriptsNameEveryPathAbsolutelyAndCarryTheSbatchArgs) {
  test::TempDir dir;
  const fs::path scene_dir = small_scene(dir, 9);  // training frames 0, 2, 4, 6, 8
  SlurmJob job;
  job.binary = "/opt/x/retimegs";
  job.scene = scene_dir;
  job.run = dir / "run";
  job.windows = 2;
  job.train_args = {"--iters", "77"};
  job.sbatch_args = {"--partition=gpu", "--time=1:00:00"};
  const SlurmScripts s = write_slurm_scripts(job, media::read_scene(scene_dir));
  ASSERT_EQ(s.windows.size(), 2u);
  EXPECT_EQ(s.windows[0].last, 4);
  for (const fs::path& p : {s.window, s.train, s.merge, s.local}) {
    ASSERT_TRUE(fs::exists(p)) << p;
    EXPECT_TRUE(executable(p)) << p;
    EXPECT_TRUE(p.is_absolute());
  }
  EXPECT_TRUE(fs::is_directory(dir / "run" / "slurm" / "logs"));
  const std::string window = test::read_text(s.window), train = test::read_text(s.train);
  const std::string merge = test::read_text(s.merge), local = test::read_text(s.local);
  EXPECT_NE(window.find("windows=(0:4 4:8)"), std::string::npos) << window;
  EXPECT_NE(window.find("/opt/x/retimegs prepare --scene " + scene_dir.string()),
            std::string::npos);
  EXPECT_NE(window.find("/opt/x/retimegs train --scene " + scene_dir.string()), std::string::npos);
  EXPECT_NE(window.find("--iters 77"), std::string::npos);
  EXPECT_NE(window.find("--resume"), std::string::npos);
  EXPECT_NE(train.find("#SBATCH --array=0-1\n"), std::string::npos) << train;
  for (const std::string& text : {train, merge}) {
    EXPECT_NE(text.find("#SBATCH --partition=gpu\n"), std::string::npos) << text;
    EXPECT_NE(text.find("#SBATCH --time=1:00:00\n"), std::string::npos) << text;
  }
  const std::string run = (dir / "run").string();
  const std::string merge_line = "/opt/x/retimegs merge --force --out " + run + "/model.rgs " +
                                 run + "/windows/0/model.rgs " + run + "/windows/1/model.rgs";
  EXPECT_NE(merge.find(merge_line), std::string::npos) << merge;
  EXPECT_NE(local.find(merge_line), std::string::npos) << local;
  // Written again: the same scripts are kept (a resubmission), other settings need --force.
  EXPECT_NO_THROW(write_slurm_scripts(job, media::read_scene(scene_dir)));
  job.train_args = {"--iters", "78"};
  test::expect_error([&] { write_slurm_scripts(job, media::read_scene(scene_dir)); },
                     {"window.sh", "--force"});
  job.force = true;
  write_slurm_scripts(job, media::read_scene(scene_dir));
  EXPECT_NE(test::read_text(s.window).find("--iters 78"), std::string::npos);
  job.sbatch_args = {"partition=gpu"};
  test::expect_error([&] { write_slurm_scripts(job, media::read_scene(scene_dir)); },
                     {"--sbatch-arg 'partition=gpu'"});
}

// Sets PATH to `dir` first for the test's lifetime.
class PathFirst {
 public:
  explicit PathFirst(const fs::path& dir) : old_(std::getenv("PATH") ? std::getenv("PATH") : "") {
    setenv("PATH", (dir.string() + ":" + old_).c_str(), 1);
  }
  ~PathFirst() { setenv("PATH", old_.c_str(), 1); }

 private:
  std::string old_;
};

TEST(Slurm, SubmitMakesTheMergeWaitForTheArray) {
  test::TempDir dir;
  SlurmScripts s;
  s.train = dir / "train.sbatch";
  s.merge = dir / "merge.sbatch";
  const fs::path log = dir / "calls.txt";
  // A stand-in sbatch: records its arguments, prints "<id>;<cluster>" as --parsable does.
  test::write_text(dir / "sbatch", "#!/bin/sh\necho \"$@\" >> " + log.string() + "\nn=$(wc -l < " +
                                       log.string() + ")\necho \"$((4000 + n));testcluster\"\n");
  fs::permissions(dir / "sbatch", fs::perms::owner_all);
  {
    PathFirst path(dir.path());
    const SubmittedJobs jobs = submit(s);
    EXPECT_EQ(jobs.train, "4001");
    EXPECT_EQ(jobs.merge, "4002");
  }
  EXPECT_EQ(test::read_text(log), "--parsable " + s.train.string() +
                                      "\n--parsable --dependency=afterok:4001 " + s.merge.string() +
                                      "\n");
  test::write_text(dir / "sbatch",
                   "#!/bin/sh\necho 'sbatch: error: invalid partition' >&2\nexit 1\n");
  PathFirst path(dir.path());
  test::expect_error([&] { submit(s); }, {"invalid partition", "exit 1"});
}

int run_shell(const std::string& command, const fs::path& output) {
  const int raw = std::system((command + " >" + output.string() + " 2>&1").c_str());
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

TEST(Slurm, RunLocalTrainsTheWindowsMergesAndResumes) {
  test::TempDir dir;
  const fs::path scene = small_scene(dir, 5);  // training frames 0, 2, 4: two windows
  test::write_text(dir / "config.json", R"({"checkpoint_every": 10, "cap": 3000})");
  const fs::path run = dir / "run";
  const auto r =
      test::run_cli("slurm --scene " + scene.string() + " --out " + run.string() +
                    " --windows 2 --iters 30 --config " + (dir / "config.json").string());
  ASSERT_EQ(r.status, 0) << r.err;
  const fs::path output = dir / "local.txt";
  ASSERT_EQ(run_shell("bash " + (run / "slurm" / "run_local.sh").string(), output), 0)
      << test::read_text(output);
  const model::Model a = model::read_model(run / "windows" / "0" / "model.rgs");
  const model::Model b = model::read_model(run / "windows" / "1" / "model.rgs");
  ASSERT_TRUE(a.window && b.window);
  EXPECT_EQ(*a.window, (model::TimeWindow{0, 1}));
  EXPECT_EQ(*b.window, (model::TimeWindow{1, 2}));
  EXPECT_EQ(a.grid.count, 3);
  const model::Model merged = model::read_model(run / "model.rgs");
  EXPECT_FALSE(merged.window);
  EXPECT_EQ(merged.primitives.size(), a.primitives.size() + b.primitives.size());
  // merge by hand: an existing output is refused without --force; overlapping windows in one line.
  const std::string models = (run / "windows" / "0" / "model.rgs").string() + " " +
                             (run / "windows" / "1" / "model.rgs").string();
  auto refused = test::run_cli("merge --out " + (run / "model.rgs").string() + " " + models);
  EXPECT_EQ(refused.status, 2);
  EXPECT_TRUE(test::is_one_error_line(refused.err)) << refused.err;
  refused = test::run_cli("merge --out " + (dir / "m.rgs").string() + " " + models + " " +
                          (run / "windows" / "1" / "model.rgs").string());
  EXPECT_EQ(refused.status, 2);
  EXPECT_NE(refused.err.find("overlap"), std::string::npos) << refused.err;
  EXPECT_TRUE(test::is_one_error_line(refused.err)) << refused.err;

  // A resubmission: window 0 is done, window 1 lost its model and resumes from its checkpoint.
  fs::remove(run / "windows" / "1" / "model.rgs");
  fs::remove(run / "model.rgs");
  ASSERT_EQ(run_shell("bash " + (run / "slurm" / "run_local.sh").string(), output), 0)
      << test::read_text(output);
  const std::string log = test::read_text(output);
  EXPECT_NE(log.find("window 0 (0:2): done"), std::string::npos) << log;
  EXPECT_NE(log.find("resuming from"), std::string::npos) << log;
  EXPECT_TRUE(fs::exists(run / "model.rgs"));
}

}  // namespace
}  // namespace retimegs::cluster
