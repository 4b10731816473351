// The rules that keep runs and outputs safe: signals noticed between units of work, folder locks,
// inputs that must be regular files and outputs that must not be inputs.
#include <signal.h>
#include <sys/stat.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/folder_lock.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/core/interrupt.hpp"
#include "retimegs/core/progress.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

TEST(Interrupt, ASignalIsRecordedAndThrownAtTheNextPoll) {
  install_interrupt_handlers();
  clear_interrupt();
  EXPECT_NO_THROW(throw_if_interrupted());
  ::raise(SIGTERM);
  EXPECT_EQ(interrupt_signal(), SIGTERM);
  try {
    throw_if_interrupted();
    ADD_FAILURE() << "no Interrupted thrown";
  } catch (const Interrupted& e) {
    EXPECT_EQ(e.exit_code(), 143);
    EXPECT_EQ(std::string(e.what()), "interrupted by SIGTERM; unfinished outputs removed");
  }
  // A progress bar polls too, unless its loop handles the signal itself.
  Progress quiet("test", 10, /*enabled=*/false, /*interruptible=*/false);
  EXPECT_NO_THROW(quiet.tick());
  Progress bar("test", 10, /*enabled=*/false);
  EXPECT_THROW(bar.tick(), Interrupted);
  clear_interrupt();
  EXPECT_NO_THROW(bar.tick());
  signal(SIGINT, SIG_DFL);
  signal(SIGTERM, SIG_DFL);
}

TEST(FolderLock, ASecondLockOnTheFolderIsRefusedNamingTheHolder) {
  test::TempDir dir;
  {
    const FolderLock first(dir.path(), "run folder");
    EXPECT_EQ(test::read_text(FolderLock::file(dir.path())), std::to_string(::getpid()) + "\n");
    test::expect_error([&] { FolderLock second(dir.path(), "run folder"); },
                       {dir.path().string(), "run folder is in use by another process (pid " +
                                                 std::to_string(::getpid()) + ")"});
  }
  EXPECT_NO_THROW(FolderLock again(dir.path(), "run folder"));  // released with its object
}

TEST(InputFile, FifosDevicesAndFoldersAreRefusedByName) {
  test::TempDir dir;
  ASSERT_EQ(::mkfifo((dir / "pipe").c_str(), 0644), 0);
  test::expect_error([&] { check_input_file(dir / "pipe", "a config"); },
                     {(dir / "pipe").string(), "is a FIFO", "a config"});
  test::expect_error([&] { read_text_file("/dev/zero", "a config"); }, {"/dev/zero", "a device"});
  test::expect_error([&] { read_text_file(dir.path(), "a config"); }, {"a folder"});
  test::expect_error([&] { read_text_file(dir / "missing", "a config"); },
                     {"cannot open a config"});
  test::write_text(dir / "ok.json", "{}");
  EXPECT_EQ(read_text_file(dir / "ok.json", "a config"), "{}");
}

TEST(InputStatus, MissingIsNotFoundAndAnUnsearchablePathIsAnError) {
  test::TempDir dir;
  test::write_text(dir / "ok.png", "x");
  EXPECT_TRUE(fs::is_regular_file(input_status(dir / "ok.png")));
  EXPECT_EQ(input_status(dir / "missing.png").type(), fs::file_type::not_found);
  EXPECT_TRUE(fs::is_directory(input_status(dir.path())));
  const fs::path long_name = dir / (std::string(300, 'x') + ".png");
  EXPECT_THROW(static_cast<void>(fs::exists(long_name)), fs::filesystem_error);
  test::expect_error([&] { input_status(long_name); },
                     {long_name.string(), "cannot look it up", "File name too long"});
  fs::create_symlink(dir / "loop", dir / "loop");
  test::expect_error([&] { input_status(dir / "loop"); }, {"loop", "cannot look it up"});
}

TEST(OutputOverlap, AnOutputThatIsOrHoldsAnInputIsRefused) {
  test::TempDir dir;
  test::write_text(dir / "scene" / "scene.json", "{}");
  test::write_text(dir / "scene" / "images" / "cam00" / "00000.png", "x");
  test::write_text(dir / "model.rgs", "x");
  fs::create_symlink(dir / "model.rgs", dir / "link.ply");
  const std::vector<InputPath> inputs = {{dir / "scene" / "scene.json", "scene file"},
                                         {dir / "scene" / "images", "images folder", true},
                                         {dir / "model.rgs", "model"}};
  const auto refused = [&](const fs::path& out, const std::string& why) {
    test::expect_error([&] { check_output_overlap(out, "--out", inputs); },
                       {"--out " + out.string(), why});
  };
  refused(dir / "scene" / "scene.json", "is the scene file");
  refused(dir / "scene" / "images" / ".." / "scene.json", "is the scene file");
  refused(dir / "link.ply", "is the model");
  refused(dir / "scene", "holds the scene file");
  refused(dir.path() / "", "holds");
  refused(dir / "scene" / "images" / "cam00", "lies inside the images folder");
  // A new entry beside the inputs, or inside an input folder, is fine.
  EXPECT_NO_THROW(check_output_overlap(dir / "scene" / "metrics.json", "--out", inputs));
  EXPECT_NO_THROW(check_output_overlap(dir / "scene" / "images" / "new", "--out", inputs));
  // A device is no output, even with --force.
  test::expect_error([] { check_output_free("/dev/null", true); }, {"/dev/null", "device"});
}

}  // namespace
}  // namespace retimegs
