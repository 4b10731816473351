#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

TEST(AtomicFile, AppearsOnlyOnCommit) {
  test::TempDir dir;
  const fs::path target = dir / "out.txt";
  {
    AtomicFile file(target);
    std::ofstream(file.temp_path()) << "hello";
    EXPECT_FALSE(fs::exists(target));
    EXPECT_EQ(file.temp_path().extension(), ".txt");
    file.commit();
  }
  EXPECT_EQ(test::read_text(target), "hello");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);
}

TEST(AtomicFile, AbandonedWriteLeavesNothing) {
  test::TempDir dir;
  {
    AtomicFile file(dir / "sub" / "out.bin");
    std::ofstream(file.temp_path()) << "partial";
  }  // destroyed without commit, as when an error is thrown mid-write
  EXPECT_FALSE(fs::exists(dir / "sub" / "out.bin"));
  EXPECT_TRUE(fs::is_empty(dir / "sub"));
}

TEST(AtomicFile, TextFileIsWrittenWholeOrNamesThePath) {
  test::TempDir dir;
  write_text_file(dir / "sub" / "state.json", "{\"a\": 1}\n");
  EXPECT_EQ(test::read_text(dir / "sub" / "state.json"), "{\"a\": 1}\n");
  write_text_file(dir / "sub" / "state.json", "replaced");
  EXPECT_EQ(test::read_text(dir / "sub" / "state.json"), "replaced");
  // A folder in the way: an Error naming the path, and no temporary file left behind.
  fs::create_directories(dir / "taken" / "inner");
  test::expect_error([&] { write_text_file(dir / "taken", "text"); }, {(dir / "taken").string()});
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 2);
}

TEST(AtomicDirectory, RefusesExistingUnlessReplacing) {
  test::TempDir dir;
  fs::create_directories(dir / "scene");
  EXPECT_THROW(AtomicDirectory(dir / "scene"), Error);
  {
    AtomicDirectory out(dir / "scene", /*replace=*/true);
    std::ofstream(out.temp_path() / "a.txt") << "new";
    EXPECT_FALSE(fs::exists(dir / "scene" / "a.txt"));
    out.commit();
  }
  EXPECT_EQ(test::read_text(dir / "scene" / "a.txt"), "new");
  {
    AtomicDirectory out(dir / "other");
    std::ofstream(out.temp_path() / "a.txt") << "partial";
  }
  EXPECT_FALSE(fs::exists(dir / "other"));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);
}

}  // namespace
}  // namespace retimegs
