// retimegs slurm: the window split, the job scripts, their submission through sbatch (a stand-in
// that records its arguments), and run_local.sh trained end to end on a small synthetic scene,
// then run again to resume. The real Slurm run is scripts/test_slurm.sh.
#include <sys/stat.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "retimegs/cluster/slurm.hpp"
#include "retimegs/core/escape_control_chars.hpp"
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
  const auto four = split_windows(frames, 4, 0);
  ASSERT_EQ(four.size(), 4u);
  for (int j = 0; j < 4; ++j) {
    EXPECT_EQ(four[j].first, 8 * j);
    EXPECT_EQ(four[j].last, 8 * j + 8);
  }
  const auto three = split_windows(frames, 3, 0);  // 16 intervals: 5, 5, 6
  ASSERT_EQ(three.size(), 3u);
  EXPECT_EQ(three[0].first, 0);
  EXPECT_EQ(three[0].last, three[1].first);
  EXPECT_EQ(three[1].last, three[2].first);
  EXPECT_EQ(three[2].last, 32);
  EXPECT_EQ(split_windows(frames, 16, 0).back().first, 30);
  test::expect_error([&] { split_windows(frames, 17, 0); }, {"--windows 17", "1 to 16"});
  test::expect_error([&] { split_windows(frames, 0, 0); }, {"--windows 0"});
}

TEST(Slurm, OverlappingWindowsTrainBeyondEachSeam) {
  std::vector<int> frames;
  for (int k = 0; k <= 32; k += 2) frames.push_back(k);  // seams at frames 8, 16, 24
  const auto four = split_windows(frames, 4, 1);
  ASSERT_EQ(four.size(), 4u);
  // One training interval (2 frames) past each seam; the clip's own ends stay where they are.
  EXPECT_EQ(four[0].first, 0);
  EXPECT_EQ(four[0].last, 10);
  EXPECT_EQ(four[1].first, 6);
  EXPECT_EQ(four[1].last, 18);
  EXPECT_EQ(four[3].first, 22);
  EXPECT_EQ(four[3].last, 32);
  // Up to half the shortest window (4 intervals): neighbours then meet, but never overlap a
  // window beyond them.
  const auto most = split_windows(frames, 4, 2);
  EXPECT_EQ(most[0].last, most[2].first);
  test::expect_error([&] { split_windows(frames, 4, 3); }, {"--overlap 3", "0 to 2"});
  test::expect_error([&] { split_windows(frames, 4, -1); }, {"--overlap -1"});
  // One window has no seam to overlap.
  EXPECT_EQ(split_windows(frames, 1, 5).front().last, 32);
  // By default windows only share their boundary frames.
  EXPECT_EQ(split_windows(frames, 4).front().last, 8 + 2 * kDefaultWindowOverlap);
}

TEST(Slurm, ShellQuoteKeepsWordsWhole) {
  EXPECT_EQ(shell_quote("/a/b_c-1.rgs"), "/a/b_c-1.rgs");
  EXPECT_EQ(shell_quote("a b"), "'a b'");
  EXPECT_EQ(shell_quote("it's"), "'it'\\''s'");
  EXPECT_EQ(shell_quote("a\\b"), "'a'\\\\'b'");  // sbatch would drop a backslash inside quotes
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
  job.merge_sbatch_args = {"--partition=cpu"};
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
  // --sbatch-arg goes to the window jobs only, --merge-sbatch-arg to the merge only.
  EXPECT_NE(train.find("#SBATCH --partition=gpu\n"), std::string::npos) << train;
  EXPECT_NE(train.find("#SBATCH --time=1:00:00\n"), std::string::npos) << train;
  EXPECT_EQ(train.find("--partition=cpu"), std::string::npos) << train;
  EXPECT_NE(merge.find("#SBATCH --partition=cpu\n"), std::string::npos) << merge;
  EXPECT_EQ(merge.find("--partition=gpu"), std::string::npos) << merge;
  EXPECT_EQ(merge.find("--time"), std::string::npos) << merge;
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
  job.sbatch_args = {};
  job.merge_sbatch_args = {"--comment=a\nb"};
  test::expect_error([&] { write_slurm_scripts(job, media::read_scene(scene_dir)); },
                     {"--merge-sbatch-arg '--comment=a"});
}

int run_shell(const std::string& command, const fs::path& output) {
  const int raw = std::system((command + " >" + output.string() + " 2>&1").c_str());
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

// The calls a stand-in binary recorded: one per line of `log`, its arguments separated by \x1f.
std::vector<std::vector<std::string>> recorded_calls(const fs::path& log) {
  std::vector<std::vector<std::string>> calls;
  const std::string text = test::read_text(log);
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t end = text.find('\x1e', start);
    std::vector<std::string> args;
    std::size_t a = start;
    while (a < end) {
      const std::size_t b = text.find('\x1f', a);
      args.push_back(text.substr(a, b - a));
      a = b + 1;
    }
    calls.push_back(args);
    start = end + 1;
  }
  return calls;
}

// The words of `line` as a shell reads them (sbatch reads #SBATCH lines with the same quoting).
std::vector<std::string> shell_words(const std::string& line, const test::TempDir& dir) {
  test::write_text(dir / "line.txt", line);
  const fs::path words = dir / "words.txt";
  std::system(("bash -c 'eval \"set -- $(cat " + (dir / "line.txt").string() +
               ")\"; printf \"%s\\x1f\" \"$@\"; printf \"\\x1e\"' >" + words.string())
                  .c_str());
  const auto calls = recorded_calls(words);
  return calls.empty() ? std::vector<std::string>{} : calls.front();
}

// The #SBATCH lines of `script`, without "#SBATCH ".
std::vector<std::string> sbatch_lines_of(const std::string& script) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < script.size()) {
    std::size_t end = script.find('\n', start);
    if (end == std::string::npos) end = script.size();
    const std::string line = script.substr(start, end - start);
    if (line.rfind("#SBATCH ", 0) == 0) lines.push_back(line.substr(8));
    start = end + 1;
  }
  return lines;
}

TEST(Slurm, NamesThatLookLikeCommandsStayNames) {
  test::TempDir dir;
  // Every character a shell or sbatch could read as syntax, in the run folder, the scene folder and
  // the binary's folder; the last two also hold a line break and a backslash (which only sbatch's
  // --output cannot take).
  const std::string hostile = "a b'c\"$(touch PWNED1);d`touch PWNED2`;touch PWNED3 #50%j&|*";
  const fs::path root = dir / hostile, other = dir / (hostile + "\nx\\y");
  const fs::path run = root / "run", bin_dir = other / "bin";
  fs::create_directories(bin_dir);
  fs::rename(small_scene(dir, 5), other / "scene");  // training frames 0, 2, 4: two windows
  const fs::path scene = other / "scene";
  const fs::path log = dir / "calls.log";
  // A stand-in retimegs that records the arguments it was given.
  test::write_text(bin_dir / "retimegs",
                   "#!/bin/bash\nfor a in \"$@\"; do printf '%s\\x1f' \"$a\"; done >> \"$CALLS\"\n"
                   "printf '\\x1e' >> \"$CALLS\"\n");
  fs::permissions(bin_dir / "retimegs", fs::perms::owner_all);
  SlurmJob job;
  job.binary = bin_dir / "retimegs";
  job.scene = scene;
  job.run = run;
  job.windows = 2;
  job.train_args = {"--config", (other / "c;$(touch PWNED4).json").string()};
  job.sbatch_args = {"--comment=two words #not a comment $(touch PWNED5)"};
  job.merge_sbatch_args = {"--comment=it's"};
  const SlurmScripts s = write_slurm_scripts(job, media::read_scene(scene));

  // sbatch's reading of the #SBATCH lines: one word each, the run folder's % doubled for Slurm.
  std::string logs = (run / "slurm" / "logs").string();
  for (std::size_t at = logs.find('%'); at != std::string::npos; at = logs.find('%', at + 2))
    logs.insert(at, "%");
  const std::vector<std::vector<std::string>> train_lines = {
      {"--job-name=retimegs-train"},
      {"--array=0-1"},
      {"--output=" + logs + "/train_%A_%a.out"},
      {"--comment=two words #not a comment $(touch PWNED5)"}};
  const std::vector<std::vector<std::string>> merge_lines = {
      {"--job-name=retimegs-merge"}, {"--output=" + logs + "/merge_%j.out"}, {"--comment=it's"}};
  for (const auto& [script, expected] :
       {std::pair{s.train, train_lines}, std::pair{s.merge, merge_lines}}) {
    const std::vector<std::string> lines = sbatch_lines_of(test::read_text(script));
    ASSERT_EQ(lines.size(), expected.size()) << script;
    for (std::size_t k = 0; k < lines.size(); ++k)
      EXPECT_EQ(shell_words(lines[k], dir), expected[k]) << lines[k];
  }

  // Each script run with bash (the sbatch ones as a node would, by their task id) calls the binary
  // with exactly its arguments and runs nothing else. Window 1 has a run to resume.
  fs::create_directories(run / "windows" / "1");
  test::write_text(run / "windows" / "1" / "config.json", "{}");
  const std::string in_dir =
      "cd " + shell_quote(dir.path().string()) + " && CALLS=" + shell_quote(log.string()) + " ";
  const fs::path output = dir / "output.txt";
  for (const std::string& command :
       {"bash " + shell_quote(s.window.string()) + " 0",
        "SLURM_ARRAY_TASK_ID=1 bash " + shell_quote(s.train.string()),
        "bash " + shell_quote(s.merge.string()), "bash " + shell_quote(s.local.string())})
    ASSERT_EQ(run_shell(in_dir + command, output), 0) << command << "\n" << test::read_text(output);
  const std::string scene_arg = job.scene.string();
  auto window_calls = [&](int k, const std::string& range) {
    const std::vector<std::string> common = {"--train-frames", "even", "--window", range,
                                             "--threads",      "0"};
    std::vector<std::string> prepare = {"prepare", "--scene", scene_arg};
    prepare.insert(prepare.end(), common.begin(), common.end());
    std::vector<std::string> train = {"train", "--scene", scene_arg, "--out",
                                      (run / "windows" / std::to_string(k)).string()};
    train.insert(train.end(), common.begin(), common.end());
    train.insert(train.end(), {"--device", "auto", "--config", job.train_args[1]});
    if (k == 1) train.push_back("--resume");
    return std::vector<std::vector<std::string>>{prepare, train};
  };
  const std::vector<std::string> merge = {"merge",
                                          "--force",
                                          "--out",
                                          (run / "model.rgs").string(),
                                          (run / "windows" / "0" / "model.rgs").string(),
                                          (run / "windows" / "1" / "model.rgs").string()};
  std::vector<std::vector<std::string>> expected;
  for (const auto& calls : {window_calls(0, "0:2"), window_calls(1, "2:4"),
                            std::vector<std::vector<std::string>>{merge}, window_calls(0, "0:2"),
                            window_calls(1, "2:4"), std::vector<std::vector<std::string>>{merge}})
    expected.insert(expected.end(), calls.begin(), calls.end());
  EXPECT_EQ(recorded_calls(log), expected);
  for (const fs::path& where : {dir.path(), root, other, run / "slurm"})
    for (int k = 1; k <= 5; ++k)
      EXPECT_FALSE(fs::exists(where / ("PWNED" + std::to_string(k)))) << where << " " << k;
  // bash before 4.4 calls an empty array unbound under `set -u`: no script expands one.
  for (const fs::path& p : {s.window, s.train, s.merge, s.local})
    EXPECT_EQ(test::read_text(p).find("[@]"), std::string::npos) << p;

  // A run folder sbatch cannot write logs under is refused before anything is written.
  for (const std::string& name : {std::string("r\nx"), std::string("r\\x")}) {
    job.run = dir / name;
    test::expect_error(
        [&] { write_slurm_scripts(job, media::read_scene(scene)); },
        {"--out " + escape_control_chars(job.run.string()), "line break or a backslash"});
    EXPECT_FALSE(fs::exists(job.run)) << name;
  }
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

// `slurm --downscale F` reaches every window's train, not its prepare (flows are made at the
// images' size; train scales them with the images), and a factor train would refuse is refused
// now, in one line, before any script is written.
TEST(Slurm, DownscaleReachesEveryWindowsTrain) {
  test::TempDir dir;
  const fs::path scene = small_scene(dir, 5);
  const std::string slurm = "slurm --scene " + scene.string() + " --windows 2 --out ";
  const auto r = test::run_cli(slurm + (dir / "run").string() + " --downscale 2");
  ASSERT_EQ(r.status, 0) << r.err;
  std::string window = test::read_text(dir / "run" / "slurm" / "window.sh");
  // One command a line: join the lines a backslash continues.
  for (std::size_t at; (at = window.find("\\\n")) != std::string::npos;) window.replace(at, 2, " ");
  int train = 0, prepare = 0;
  std::size_t start = 0;
  for (std::size_t end; (end = window.find('\n', start)) != std::string::npos; start = end + 1) {
    const std::string line = window.substr(start, end - start);
    const bool downscaled =
        line.find(" --downscale 2 ") != std::string::npos || line.ends_with(" --downscale 2");
    if (line.find(" train --scene ") != std::string::npos) {
      ++train;
      EXPECT_TRUE(downscaled) << line;
    } else if (line.find(" prepare --scene ") != std::string::npos) {
      ++prepare;
      EXPECT_FALSE(downscaled) << line;
    }
  }
  EXPECT_GE(train, 1) << window;
  EXPECT_GE(prepare, 1) << window;
  for (const char* factor : {"0.5", "nan"}) {
    const auto refused =
        test::run_cli(slurm + (dir / "refused").string() + " --downscale " + factor);
    EXPECT_EQ(refused.status, 2) << factor;
    EXPECT_NE(refused.err.find("--downscale"), std::string::npos) << refused.err;
    EXPECT_TRUE(test::is_one_error_line(refused.err)) << refused.err;
    EXPECT_FALSE(fs::exists(dir / "refused")) << factor;
  }
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
