// find_executable looks programs up as a shell does: the first runnable file of that name on
// PATH, a name with a '/' as it is, nothing for a file that is not executable or a folder.
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "retimegs/core/executable.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

TEST(FindExecutable, TakesTheFirstRunnableFileOnPath) {
  test::TempDir dir;
  for (const char* folder : {"a", "b", "c"}) fs::create_directories(dir / folder);
  test::write_text(dir / "a" / "tool", "not executable");  // skipped
  fs::create_directories(dir / "b" / "tool");              // a folder: skipped
  test::write_text(dir / "c" / "tool", "#!/bin/sh\n");
  fs::permissions(dir / "c" / "tool", fs::perms::owner_all);
  test::write_text(dir / "a" / "other", "#!/bin/sh\n");
  fs::permissions(dir / "a" / "other", fs::perms::owner_all);
  const char* old = std::getenv("PATH");
  const std::string saved = old ? old : "";
  const std::string path =
      (dir / "a").string() + "::" + (dir / "b").string() + ":" + (dir / "c").string();
  ::setenv("PATH", path.c_str(), 1);
  const fs::path tool = find_executable("tool"), other = find_executable("other"),
                 missing = find_executable("missing");
  ::setenv("PATH", saved.c_str(), 1);
  EXPECT_EQ(tool, dir / "c" / "tool");
  EXPECT_EQ(other, dir / "a" / "other");
  EXPECT_TRUE(missing.empty());
  // A name with a '/' is itself, when runnable.
  EXPECT_EQ(find_executable((dir / "c" / "tool").string()), dir / "c" / "tool");
  EXPECT_TRUE(find_executable((dir / "a" / "tool").string()).empty());
}

}  // namespace
}  // namespace retimegs
