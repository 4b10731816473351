// The CLI runs itself again with libgomp's short spin (apps/retimegs/main.cpp) where the user set
// no wait policy; ctest sets one for every test (tests/CMakeLists.txt), so this test takes it
// away: the second run must see the user's arguments unchanged, spaces and quotes included.
#include <string>

#include <gtest/gtest.h>

#include "test_util.hpp"

namespace retimegs {
namespace {

TEST(ShortSpinCli, TheRunAgainKeepsTheArguments) {
  const std::string args = "'not a \"command\"'";
  const test::CommandResult with_spin = test::run_cli(args);
  const test::CommandResult again = test::run_cli(args, "env -u GOMP_SPINCOUNT -u OMP_WAIT_POLICY");
  EXPECT_EQ(again.status, 2);
  EXPECT_NE(again.err.find("unknown command 'not a \"command\"'"), std::string::npos) << again.err;
  EXPECT_EQ(again.err, with_spin.err);
  EXPECT_EQ(again.out, with_spin.out);
}

}  // namespace
}  // namespace retimegs
