// Writers under signals and beside other writers: export --time, export --web and merge of a large
// model stop on Ctrl-C / SIGTERM while they load, pack or write (exit 130 / 143, one line, their
// unfinished output removed), and so does an H.264 render, ending its ffmpeg; an output that
// another writer creates while a command runs is not replaced (the command fails in one line, exit
// 2); a link at --out, dangling or a loop, is an existing output.
#include <signal.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cli_run.hpp"
#include "retimegs/core/interrupt.hpp"
#include "retimegs/model/model_file.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

// Bytes process `pid` has read so far (0 once it has ended). Shared libraries are mapped, not
// read: a command past a few MB is reading its input.
std::size_t bytes_read(pid_t pid) {
  std::ifstream io("/proc/" + std::to_string(pid) + "/io");
  std::string key;
  std::size_t value = 0;
  while (io >> key >> value)
    if (key == "rchar:") return value;
  return 0;
}

// Past this much, a command is loading the large model (a few hundred MB).
constexpr std::size_t kLoadingBytes = std::size_t(32) << 20;

// Names in `dir` (not recursive), space-separated.
std::string entries(const fs::path& dir) {
  std::string names;
  for (const auto& e : fs::directory_iterator(dir)) names += e.path().filename().string() + " ";
  return names;
}

// A scene, a small trained model and a large one (its rows repeated to a million primitives, a few
// hundred MB: every command on it runs for a second or more), shared by the suite.
class WritersCli : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = std::make_unique<test::TempDir>();
    auto r = test::run_cli_timed(
        "synth --preset minimal --cameras 2 --frames 3 --size 64x48 --threads 2 --out " +
        (*dir_ / "scene").string());
    ASSERT_EQ(r.status, 0) << r.err;
    r = test::run_cli_timed("train --scene " + (*dir_ / "scene").string() + " --out " +
                            (*dir_ / "run").string() + " --iters 2 --cap 300 --threads 2");
    ASSERT_EQ(r.status, 0) << r.err;
    const model::Model small = model::read_model(small_model());
    model::Model large = small;
    constexpr std::size_t kRows = 1'000'000;
    large.primitives.resize(kRows);
    for (std::size_t i = 0; i < kRows; ++i)
      large.primitives.copy_row(i, small.primitives, i % small.primitives.size());
    model::write_model(large_model(), large);
  }
  static void TearDownTestSuite() { dir_.reset(); }
  void SetUp() override {
    out_ = *dir_ / ("out" + std::to_string(++outputs_));
    fs::create_directories(out_);
  }

  static fs::path small_model() { return *dir_ / "run" / "model.rgs"; }
  static fs::path large_model() { return *dir_ / "large.rgs"; }
  static fs::path scene() { return *dir_ / "scene"; }

  // Runs `args`, sends `signal` once `ready()` holds, and expects the interrupted ending: 128 +
  // the signal, one line, nothing left in out_.
  void expect_interrupted(const std::vector<std::string>& args, int signal,
                          const std::function<bool(pid_t)>& ready) {
    test::CliProcess process(args, *dir_ / "err.txt");
    const pid_t pid = process.pid();
    ASSERT_TRUE(process.wait_for_err([&](const std::string&) { return ready(pid); }, 120))
        << process.err();
    process.signal(signal);
    const int status = process.wait();
    EXPECT_EQ(status, 128 + signal) << args[0] << "\n" << process.err();
    EXPECT_EQ(test::last_line(process.err()),
              "retimegs: interrupted by " + signal_name(signal) + "; unfinished outputs removed")
        << process.err();
    EXPECT_EQ(entries(out_), "") << args[0];
  }

  static std::unique_ptr<test::TempDir> dir_;
  static int outputs_;
  fs::path out_;
};
std::unique_ptr<test::TempDir> WritersCli::dir_;
int WritersCli::outputs_ = 0;

bool loading(pid_t pid) {
  return bytes_read(pid) > kLoadingBytes;
}

TEST_F(WritersCli, CtrlCStopsAnExportWhileItLoadsTheModel) {
  expect_interrupted({"export", "--model", large_model().string(), "--time", "1", "--out",
                      (out_ / "e.ply").string()},
                     SIGINT, loading);
}

TEST_F(WritersCli, SigtermStopsAnExportWhileItWritesAndRemovesTheTemporary) {
  // Its temporary is there: the export is writing rows.
  const auto writing = [&](pid_t pid) {
    return fs::exists(out_ / (".e.tmp" + std::to_string(pid) + ".ply"));
  };
  expect_interrupted({"export", "--model", large_model().string(), "--time", "1", "--out",
                      (out_ / "e.ply").string()},
                     SIGTERM, writing);
}

TEST_F(WritersCli, SigtermStopsAWebExport) {
  expect_interrupted({"export", "--model", large_model().string(), "--scene", scene().string(),
                      "--web", (out_ / "site").string()},
                     SIGTERM, loading);
}

TEST_F(WritersCli, CtrlCStopsAMerge) {
  expect_interrupted({"merge", "--out", (out_ / "m.rgs").string(), large_model().string()}, SIGINT,
                     loading);
}

// The ffmpeg process that `pid` started, or 0 while there is none.
pid_t ffmpeg_child(pid_t pid) {
  for (const auto& entry : fs::directory_iterator("/proc")) {
    std::ifstream stat(entry.path() / "stat");
    std::string line;
    if (!std::getline(stat, line)) continue;
    // "pid (comm) state ppid ...": the command name may hold spaces, so read after its ')'.
    const std::size_t close = line.rfind(')');
    if (close == std::string::npos || line.find("(ffmpeg)") == std::string::npos) continue;
    std::istringstream rest(line.substr(close + 1));
    char state = 0;
    pid_t parent = 0;
    rest >> state >> parent;
    if (parent == pid) return std::stoi(line);
  }
  return 0;
}

// Ctrl-C while a render pipes its frames to ffmpeg: the render stops as every command does
// (130, one line, no output), and its ffmpeg is ended with it, not left to finish a removed file.
TEST_F(WritersCli, CtrlCStopsAnH264RenderAndItsFfmpeg) {
  pid_t encoder = 0;
  const auto encoding = [&](pid_t pid) {
    encoder = ffmpeg_child(pid);
    return encoder != 0;
  };
  expect_interrupted(
      {"render", "--model", small_model().string(), "--scene", scene().string(), "--camera",
       "cam00", "--times", "0:2:0.002", "--size", "320x240", "--out", (out_ / "v.mp4").string()},
      SIGINT, encoding);
  ASSERT_NE(encoder, 0);
  EXPECT_EQ(::kill(encoder, 0), -1) << "ffmpeg " << encoder << " still runs";
}

// Another writer creates the output while the command runs (after its own check that nothing is
// there): the command must not replace it.
TEST_F(WritersCli, AnOutputThatAppearsWhileACommandRunsIsNotReplaced) {
  struct Case {
    std::vector<std::string> args;
    fs::path out;
    bool folder;
  };
  const std::vector<Case> cases = {
      {{"export", "--model", large_model().string(), "--time", "1", "--out",
        (out_ / "e.ply").string()},
       out_ / "e.ply",
       false},
      {{"export", "--model", large_model().string(), "--web", (out_ / "site").string()},
       out_ / "site",
       true},
      {{"merge", "--out", (out_ / "m.rgs").string(), large_model().string()},
       out_ / "m.rgs",
       false},
  };
  for (const Case& c : cases) {
    test::CliProcess process(c.args, *dir_ / "err.txt");
    const pid_t pid = process.pid();
    ASSERT_TRUE(process.wait_for_err([&](const std::string&) { return loading(pid); }, 120))
        << process.err();
    // The other writer's output: a file, or an empty folder (which a plain rename would replace).
    if (c.folder)
      fs::create_directory(c.out);
    else
      test::write_text(c.out, "the other writer's output");
    const int status = process.wait();
    EXPECT_EQ(status, 2) << c.args[0] << "\n" << process.err();
    EXPECT_TRUE(test::is_one_error_line(process.err())) << process.err();
    EXPECT_NE(test::last_line(process.err()).find(c.out.string() + ": output already exists"),
              std::string::npos)
        << process.err();
    if (c.folder)
      EXPECT_TRUE(fs::is_empty(c.out)) << c.args[0];
    else
      EXPECT_EQ(test::read_text(c.out), "the other writer's output");
    EXPECT_EQ(entries(out_), c.out.filename().string() + " ") << c.args[0];
    fs::remove_all(c.out);
  }
}

TEST_F(WritersCli, ALinkAtTheOutputIsAnExistingOutput) {
  const std::string model = small_model().string(), scene_dir = scene().string();
  const std::vector<std::string> names = {"r.png", "v.mp4", "e.ply", "m.rgs", "site", "s.png"};
  for (const std::string& name : names) {
    // A dangling link, and a loop (a link to itself).
    for (const bool is_loop : {false, true}) {
      const fs::path out = out_ / ((is_loop ? "loop_" : "dangling_") + name);
      fs::create_symlink(is_loop ? out : out_ / "nothing" / name, out);
      const std::map<std::string, std::string> commands = {
          {"r.png",
           "render --model " + model + " --scene " + scene_dir + " --camera cam00 --time 1 --out "},
          {"v.mp4", "render --model " + model + " --scene " + scene_dir +
                        " --camera cam00 --times 0:2:1 --out "},
          {"e.ply", "export --model " + model + " --time 1 --out "},
          {"m.rgs", "merge " + model + " --out "},
          {"site", "export --model " + model + " --web "},
          {"s.png", "sheet --scene " + scene_dir + " --out "}};
      const auto target = fs::read_symlink(out);
      const auto r = test::run_cli_timed(commands.at(name) + out.string());
      EXPECT_EQ(r.status, 2) << name << "\n" << r.err;
      EXPECT_TRUE(test::is_one_error_line(r.err)) << r.err;
      EXPECT_NE(r.err.find(out.string() + ": output already exists (pass --force"),
                std::string::npos)
          << r.err;
      EXPECT_TRUE(fs::is_symlink(out)) << out;
      EXPECT_EQ(fs::read_symlink(out), target);
    }
  }
  // With --force the link is replaced (not what it points to).
  const fs::path out = out_ / "dangling_e.ply";
  const auto r =
      test::run_cli_timed("export --force --model " + model + " --time 1 --out " + out.string());
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(out)));
}

}  // namespace
}  // namespace retimegs
