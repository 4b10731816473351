// Writes that fail: on a full disk every writer fails in one line naming its file, with exit 2 and
// no (0-byte) output left, and `train` stops before its first step; a video into a read-only folder
// names the folder's problem, not the encoder. A file-size limit (ulimit -f; the app ignores
// SIGXFSZ, so writes fail with EFBIG) stands for a full disk on any machine; the real full and
// read-only file systems are small tmpfs mounts, which need root and the right to mount, and are
// skipped without them.
#include <sys/mount.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "cli_run.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

// A tmpfs of `size` mounted at `path` for the life of the object (`options`: "ro" for read-only).
class TmpfsMount {
 public:
  TmpfsMount(const fs::path& path, const std::string& size, const std::string& options = "")
      : path_(path) {
    fs::create_directories(path);
    const std::string data = "size=" + size;
    mounted_ = ::geteuid() == 0 && ::mount("tmpfs", path.c_str(), "tmpfs",
                                           options == "ro" ? MS_RDONLY : 0, data.c_str()) == 0;
  }
  ~TmpfsMount() {
    if (mounted_) ::umount(path_.c_str());
  }
  bool mounted() const { return mounted_; }

 private:
  fs::path path_;
  bool mounted_ = false;
};

// Fills the file system of `dir` to the last byte.
void fill(const fs::path& dir) {
  std::ofstream out(dir / "filler", std::ios::binary);
  const std::string block(4096, 'x');
  while (out.write(block.data(), std::streamsize(block.size()))) {
  }
}

class DiskFullCli : public testing::Test {
 protected:
  void SetUp() override {
    const auto r = test::run_cli_timed(
        "synth --preset minimal --cameras 2 --frames 3 --size 64x48 --threads 2 --out " +
        (dir_ / "scene").string());
    ASSERT_EQ(r.status, 0) << r.err;
  }
  // Files under `full` other than the filler.
  static std::string leftovers(const fs::path& full) {
    std::string names;
    for (const auto& e : fs::recursive_directory_iterator(full))
      if (e.path().filename() != "filler") names += e.path().string() + " ";
    return names;
  }
  test::TempDir dir_;
};

TEST_F(DiskFullCli, EveryCommandFailsInOneLineNamingTheFileAndLeavesNothing) {
  const TmpfsMount full(dir_ / "full", "256k");
  if (!full.mounted()) GTEST_SKIP() << "mounting a tmpfs needs root";
  // A model first (on the big disk), then fill the small one.
  const std::string scene = " --scene " + (dir_ / "scene").string();
  auto r = test::run_cli_timed("train" + scene + " --out " + (dir_ / "run").string() +
                               " --iters 2 --cap 300 --threads 2");
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string model = " --model " + (dir_ / "run" / "model.rgs").string();
  fill(dir_ / "full");
  const fs::path f = dir_ / "full";
  struct Case {
    std::string args;
    fs::path named;  // the file the message must name
  };
  const std::vector<Case> cases = {
      {"eval" + model + scene + " --frames 1 --out " + (f / "m.json").string(), f / "m.json"},
      {"render" + model + scene + " --camera cam00 --time 1 --out " + (f / "r.png").string(),
       f / "r.png"},
      {"export" + model + " --time 1 --out " + (f / "e.ply").string(), f / "e.ply"},
      {"render" + model + scene + " --camera cam00 --times 0:2:1 --out " + (f / "v.mp4").string(),
       f / "v.mp4"},
      {"sheet" + scene + " --out " + (f / "s.png").string(), f / "s.png"},
      {"train" + scene + " --out " + (f / "run").string() + " --iters 50 --cap 300", f / "run"},
      {"synth --preset minimal --cameras 2 --frames 3 --size 32x24 --out " + (f / "scene").string(),
       f},
  };
  for (const Case& c : cases) {
    r = test::run_cli_timed(c.args);
    EXPECT_EQ(r.status, 2) << c.args << "\n" << r.err;
    // Progress lines of the work done may come first; the error is one line, the last.
    EXPECT_TRUE(test::is_one_error_line(r.err)) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.named.string()), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(leftovers(f), "") << c.args;
  }
}

TEST_F(DiskFullCli, AFileSizeLimitFailsEveryWriterInOneLineAndLeavesNothing) {
  const std::string scene = " --scene " + (dir_ / "scene").string();
  auto r = test::run_cli_timed("train" + scene + " --out " + (dir_ / "run").string() +
                               " --iters 2 --cap 300 --threads 2");
  ASSERT_EQ(r.status, 0) << r.err;
  const fs::path model_file = dir_ / "run" / "model.rgs";
  const std::string model = " --model " + model_file.string();
  // A run stopped before its model: its checkpoint at step 2 is there, the model is not.
  const fs::path stopped = dir_ / "stopped";
  fs::copy(dir_ / "run", stopped, fs::copy_options::recursive);
  fs::remove(stopped / "model.rgs");
  fs::remove(stopped / ".lock");
  const auto stopped_before = test::snapshot(stopped);
  const fs::path f = dir_ / "limited";
  fs::create_directories(f);
  // 512 bytes: less than any of these outputs, more than the error line on stderr. SIGXFSZ is
  // left as the shell has it: the app itself must ignore it (its default kills without a word).
  const std::string limit = "ulimit -f 1; ";
  const std::vector<std::pair<std::string, fs::path>> cases = {
      {"eval" + model + scene + " --frames 1 --out " + (f / "m.json").string(), f / "m.json"},
      {"eval" + model + scene + " --frames 1 --out " + (dir_ / "m.json").string() +
           " --save-renders " + (f / "renders").string(),
       f / "renders"},
      {"render" + model + scene + " --camera cam00 --time 1 --out " + (f / "r.png").string(),
       f / "r.png"},
      {"render" + model + scene + " --camera cam00 --times 0:2:1 --out " + (f / "v.mp4").string(),
       f / "v.mp4"},
      {"render" + model + scene + " --camera cam00 --times 0:2:1 --out " + (f / "frames").string() +
           "/",
       f / "frames"},
      {"export" + model + " --time 1 --out " + (f / "e.ply").string(), f / "e.ply"},
      {"export" + model + scene + " --web " + (f / "site").string(), f / "site"},
      {"merge --out " + (f / "merged.rgs").string() + " " + model_file.string(), f / "merged.rgs"},
      {"sheet" + scene + " --out " + (f / "s.png").string(), f / "s.png"},
      {"train" + scene + " --out " + (f / "run").string() + " --iters 50 --cap 300",
       f / "run" / "config.json"},
      {"train" + scene + " --out " + stopped.string() + " --iters 50 --cap 300 --resume", stopped},
  };
  for (const auto& [args, named] : cases) {
    r = test::run_cli_timed(args, 60, limit);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.err;
    EXPECT_TRUE(test::is_one_error_line(r.err)) << args << "\n" << r.err;
    // The path the user gave, not a hidden temporary, and the system's reason (EFBIG).
    EXPECT_NE(r.err.find(named.string()), std::string::npos) << args << "\n" << r.err;
    EXPECT_EQ(r.err.find(".tmp"), std::string::npos) << args << "\n" << r.err;
    EXPECT_NE(r.err.find("File too large"), std::string::npos) << args << "\n" << r.err;
    EXPECT_TRUE(fs::is_empty(f)) << args << ": " << leftovers(f);
  }
  // The resumed run failed before changing anything: no half checkpoint, no model.
  EXPECT_EQ(test::snapshot_diff(stopped_before, test::snapshot(stopped)), "");
}

// A video that a file-size limit or a full disk cuts short after its first block (the encoder
// itself reports no failed write) is refused in one line, alone on stderr after the progress,
// and not kept.
TEST_F(DiskFullCli, AVideoCutShortIsRefused) {
  const std::string scene = " --scene " + (dir_ / "scene").string();
  auto r = test::run_cli_timed("train" + scene + " --out " + (dir_ / "run").string() +
                               " --iters 2 --cap 300 --threads 2");
  ASSERT_EQ(r.status, 0) << r.err;
  // 401 frames of 320x240: some 20 KB of H.264, past both limits below.
  const std::string render = "render --model " + (dir_ / "run" / "model.rgs").string() + scene +
                             " --camera cam00 --times 0:2:0.005 --size 320x240 --threads 2 --out ";
  const auto expect_refused = [&](const fs::path& out, const std::string& limit,
                                  const std::string& reason) {
    fs::create_directories(out.parent_path());
    const auto refused = test::run_cli_timed(render + out.string(), 120, limit);
    EXPECT_EQ(refused.status, 2) << refused.err;
    EXPECT_TRUE(test::is_single_error_line(refused.err)) << refused.err;
    EXPECT_NE(refused.err.find(out.string() + ": cannot write the video file: " + reason),
              std::string::npos)
        << refused.err;
    EXPECT_TRUE(fs::is_empty(out.parent_path())) << leftovers(out.parent_path());
  };
  // 8 KiB: more than the encoder's first block (4 KiB, written before it starts).
  expect_refused(dir_ / "limited" / "v.mp4", "ulimit -f 16; ", "File too large");
  const TmpfsMount full(dir_ / "full", "8k");
  if (!full.mounted()) GTEST_SKIP() << "mounting a tmpfs needs root";
  expect_refused(dir_ / "full" / "v.mp4", "", "No space left on device");
}

TEST_F(DiskFullCli, AVideoIntoAReadOnlyFolderNamesTheFolder) {
  const std::string scene = " --scene " + (dir_ / "scene").string();
  auto r = test::run_cli_timed("train" + scene + " --out " + (dir_ / "run").string() +
                               " --iters 2 --cap 300 --threads 2");
  ASSERT_EQ(r.status, 0) << r.err;
  const TmpfsMount ro(dir_ / "ro", "64k", "ro");
  if (!ro.mounted()) GTEST_SKIP() << "mounting a tmpfs needs root";
  const fs::path out = dir_ / "ro" / "clip.mp4";
  r = test::run_cli_timed("render --model " + (dir_ / "run" / "model.rgs").string() + scene +
                          " --camera cam00 --times 0:2:1 --out " + out.string());
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_TRUE(test::is_single_error_line(r.err)) << r.err;
  EXPECT_NE(r.err.find(out.string() + ": cannot create the video file: Read-only file system"),
            std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace retimegs
