// Run folders and signals: Ctrl-C finishes the step, writes a checkpoint and exits 130, and the
// resumed run ends byte-identical to an uninterrupted one; a second train into a locked run folder
// is refused naming the holder; SIGTERM exits 143; a render stopped by Ctrl-C leaves nothing;
// --resume continues to a new --iters; a run killed before config.json restarts cleanly;
// temporaries left by kills are removed.
#include <signal.h>

#include <filesystem>
#include <regex>
#include <string>

#include <gtest/gtest.h>

#include "cli_run.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

// A synthetic scene of 2 cameras x 5 frames at 48x36 in `dir`/scene.
fs::path make_scene(const test::TempDir& dir) {
  const auto r = test::run_cli_timed(
      "synth --preset minimal --cameras 2 --frames 5 --size 48x36 "
      "--threads 2 --out " +
      (dir / "scene").string());
  EXPECT_EQ(r.status, 0) << r.err;
  return dir / "scene";
}

std::vector<std::string> train_args(const fs::path& scene, const fs::path& out, int iters) {
  return {
      "train", "--scene", scene.string(), "--out", out.string(), "--iters", std::to_string(iters),
      "--cap", "400",     "--threads",    "2"};
}

// Progress after the first steps: a plain progress line "train N/TOTAL" with N > 0 on stdout.
bool trained_some(const std::string& out) {
  static const std::regex line(R"((^|\n)train [1-9][0-9]*/)");
  return std::regex_search(out, line);
}

// The step N of "interrupted at step N; ..." in `err`, or -1.
int interrupted_step(const std::string& err) {
  std::smatch m;
  static const std::regex re(R"(interrupted at step ([0-9]+);)");
  return std::regex_search(err, m, re) ? std::stoi(m[1]) : -1;
}

TEST(TrainRunsCli, CtrlCWritesACheckpointAndTheResumedRunEqualsAnUninterruptedOne) {
  test::TempDir dir;
  const fs::path scene = make_scene(dir);
  constexpr int kIters = 300;
  {
    test::CliProcess full(train_args(scene, dir / "full", kIters), dir / "full.err");
    ASSERT_EQ(full.wait(), 0) << full.err();
  }
  test::CliProcess run(train_args(scene, dir / "run", kIters), dir / "run.err");
  ASSERT_TRUE(run.wait_for_err([&](const std::string&) { return trained_some(run.out()); }, 120))
      << run.err();
  run.signal(SIGINT);
  const int status = run.wait();
  const std::string err = run.err();
  if (status == 0) GTEST_SKIP() << "the run ended before the signal arrived";
  ASSERT_EQ(status, 130) << err;
  const int step = interrupted_step(err);
  ASSERT_GT(step, 0) << err;
  ASSERT_LT(step, kIters) << err;
  const fs::path checkpoint = dir / "run" / "checkpoints" / fmt::format("iter_{:06d}", step);
  EXPECT_EQ(test::last_line(err), "retimegs: interrupted at step " + std::to_string(step) +
                                      "; checkpoint written to " + checkpoint.string() +
                                      "; resume with --resume")
      << err;
  EXPECT_TRUE(fs::exists(checkpoint / "state.json"));
  EXPECT_FALSE(fs::exists(dir / "run" / "model.rgs"));

  auto args = train_args(scene, dir / "run", kIters);
  args.push_back("--resume");
  test::CliProcess resumed(args, dir / "resumed.err");
  ASSERT_EQ(resumed.wait(), 0) << resumed.err();
  EXPECT_EQ(test::read_text(dir / "run" / "model.rgs"), test::read_text(dir / "full" / "model.rgs"))
      << "interrupted at step " << step;
  // The log holds each logged step once (its lines differ only in their wall times).
  const auto iterations = [](const fs::path& log) {
    const std::string text = test::read_text(log);
    const std::regex key("\"iteration\":([0-9]+)");
    std::vector<int> out;
    for (auto m = std::sregex_iterator(text.begin(), text.end(), key); m != std::sregex_iterator();
         ++m)
      out.push_back(std::stoi((*m)[1]));
    return out;
  };
  EXPECT_EQ(iterations(dir / "run" / "log.jsonl"), iterations(dir / "full" / "log.jsonl"));
}

TEST(TrainRunsCli, ALockedRunFolderIsRefusedAndSigtermExits143) {
  test::TempDir dir;
  const fs::path scene = make_scene(dir);
  test::CliProcess first(train_args(scene, dir / "run", 100000), dir / "first.err");
  // Some steps done: the log has its first line (every 10 steps).
  const auto logged = [&](const std::string&) {
    return !test::read_text(dir / "run" / "log.jsonl").empty();
  };
  ASSERT_TRUE(first.wait_for_err(logged, 120)) << first.err();
  auto args = train_args(scene, dir / "run", 100000);
  args.push_back("--resume");
  test::CliProcess second(args, dir / "second.err");
  EXPECT_EQ(second.wait(), 2);
  EXPECT_TRUE(test::is_single_error_line(second.err())) << second.err();
  EXPECT_NE(
      second.err().find("in use by another process (pid " + std::to_string(first.pid()) + ")"),
      std::string::npos)
      << second.err();
  first.signal(SIGTERM);
  EXPECT_EQ(first.wait(), 143);
  const int step = interrupted_step(first.err());
  ASSERT_GT(step, 0) << first.err();

  // Temporaries of a kill during a checkpoint and a model write; the resume removes them and
  // continues to a new total.
  fs::create_directories(dir / "run" / "checkpoints" / ".iter_000007.tmp99999" / "adam");
  test::write_text(dir / "run" / ".model.tmp99999.rgs", "partial");
  args = train_args(scene, dir / "run", step + 3);
  args.push_back("--resume");
  test::CliProcess resumed(args, dir / "resumed.err");
  ASSERT_EQ(resumed.wait(), 0) << resumed.err();
  EXPECT_FALSE(fs::exists(dir / "run" / "checkpoints" / ".iter_000007.tmp99999"));
  EXPECT_FALSE(fs::exists(dir / "run" / ".model.tmp99999.rgs"));
  EXPECT_TRUE(fs::exists(dir / "run" / "model.rgs"));
  EXPECT_NE(test::read_text(dir / "run" / "config.json")
                .find("\"iters\": " + std::to_string(step + 3) + ","),
            std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "run" / "checkpoints" / fmt::format("iter_{:06d}", step + 3)));
}

TEST(TrainRunsCli, ResumeContinuesToANewIters) {
  test::TempDir dir;
  const fs::path scene = make_scene(dir);
  auto r = test::run_cli_timed("train --scene " + scene.string() + " --out " +
                               (dir / "run").string() + " --iters 6 --cap 400 --threads 2");
  ASSERT_EQ(r.status, 0) << r.err;
  r = test::run_cli_timed("train --scene " + scene.string() + " --out " + (dir / "run").string() +
                          " --iters 12 --cap 400 --threads 2 --resume");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(test::read_text(dir / "run" / "log.jsonl").find("\"iteration\":10,"),
            std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "run" / "checkpoints" / "iter_000012"));
  EXPECT_NE(test::read_text(dir / "run" / "config.json").find("\"iters\": 12,"), std::string::npos);
}

TEST(TrainRunsCli, ARunKilledBeforeItsConfigRestartsCleanly) {
  test::TempDir dir;
  const fs::path scene = make_scene(dir);
  // What a kill during the initialisation leaves: the folder, its lock and a log line.
  fs::create_directories(dir / "run");
  test::write_text(dir / "run" / ".lock", "12345\n");
  test::write_text(dir / "run" / "log.jsonl", "{\"iteration\": 999}\n");
  for (const std::string extra : {" --resume", ""}) {
    const auto r =
        test::run_cli_timed("train --scene " + scene.string() + " --out " + (dir / "run").string() +
                            " --iters 4 --cap 400 --threads 2" + extra);
    ASSERT_EQ(r.status, 0) << extra << "\n" << r.err;
    EXPECT_EQ(test::read_text(dir / "run" / "log.jsonl").find("\"iteration\": 999"),
              std::string::npos);
    EXPECT_TRUE(fs::exists(dir / "run" / "model.rgs"));
    // Back to the killed state for the next form.
    for (const char* name : {"model.rgs", "config.json", "checkpoints"})
      fs::remove_all(dir / "run" / name);
    test::write_text(dir / "run" / "log.jsonl", "{\"iteration\": 999}\n");
  }
}

// Other commands stop between two frames on Ctrl-C, remove their unfinished output and exit 130.
TEST(TrainRunsCli, CtrlCStopsARenderAndRemovesItsUnfinishedFolder) {
  test::TempDir dir;
  const fs::path scene = make_scene(dir);
  auto r = test::run_cli_timed("train --scene " + scene.string() + " --out " +
                               (dir / "run").string() + " --iters 2 --cap 400 --threads 2");
  ASSERT_EQ(r.status, 0) << r.err;
  test::CliProcess render({"render", "--model", (dir / "run" / "model.rgs").string(), "--scene",
                           scene.string(), "--camera", "cam00", "--times", "0:2:0.0002",
                           "--threads", "2", "--out", (dir / "frames").string()},
                          dir / "render.err");
  const auto rendered_some = [&](const std::string&) {
    return std::regex_search(render.out(), std::regex(R"((^|\n)render [1-9][0-9]*/)"));
  };
  ASSERT_TRUE(render.wait_for_err(rendered_some, 120)) << render.err();
  render.signal(SIGINT);
  const int status = render.wait();
  if (status == 0) GTEST_SKIP() << "the render ended before the signal arrived";
  EXPECT_EQ(status, 130) << render.err();
  EXPECT_EQ(test::last_line(render.err()),
            "retimegs: interrupted by SIGINT; unfinished outputs removed");
  EXPECT_FALSE(fs::exists(dir / "frames"));
  for (const auto& e : fs::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().find(".frames"), std::string::npos) << e.path();
}

}  // namespace
}  // namespace retimegs
