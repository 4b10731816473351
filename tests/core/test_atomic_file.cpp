#include <filesystem>
#include <fstream>
#include <string>

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

// Messages name the output, not its temporary: a temporary's name, and that of a file written
// whole into another writer's temporary (FrameWriter's frame beside its depth pass), are shown as
// the output they become.
TEST(AtomicFile, ShownPathIsTheOutputsForTemporariesOfTemporaries) {
  test::TempDir dir;
  const AtomicFile outer(dir / "plate.depth.exr");
  const AtomicFile inner(outer.temp_path());
  EXPECT_NE(outer.temp_path(), dir / "plate.depth.exr");
  EXPECT_EQ(shown_path(outer.temp_path()), (dir / "plate.depth.exr").string());
  EXPECT_EQ(shown_path(inner.temp_path()), (dir / "plate.depth.exr").string());
  EXPECT_EQ(shown_path(dir / ".hidden.txt"), (dir / ".hidden.txt").string());
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

// `out/` names the folder `out`: its temporary sibling lies beside it, so the commit's rename
// does not move a folder into itself (it failed with "Directory not empty" after all the work).
TEST(AtomicDirectory, TrailingSeparatorsNameTheFolderItself) {
  test::TempDir dir;
  for (const std::string suffix : {"/", "//"}) {
    const std::string name = "frames" + std::to_string(suffix.size());
    AtomicDirectory out(dir.path().string() + "/" + name + suffix);
    EXPECT_EQ(out.final_path(), dir / name);
    EXPECT_EQ(out.temp_path().parent_path(), dir.path());
    std::ofstream(out.temp_path() / "00000.png") << "x";
    out.commit();
    EXPECT_EQ(test::read_text(dir / name / "00000.png"), "x");
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 2);
  EXPECT_EQ(output_path("a/b/"), fs::path("a/b"));
  EXPECT_EQ(output_path("a/b"), fs::path("a/b"));
  EXPECT_EQ(output_path("/"), fs::path("/"));
}

}  // namespace
}  // namespace retimegs
