// parallel_for: every iteration runs once; the first exception comes out unchanged after the
// loop, and the iterations not yet started when it was thrown are skipped.
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"

namespace retimegs {
namespace {

// Sets the OpenMP thread count for one scope and restores the previous one.
class Threads {
 public:
  explicit Threads(int threads) : saved_(max_threads()) { set_threads(threads); }
  ~Threads() { set_threads(saved_); }

 private:
  int saved_;
};

TEST(ParallelFor, RunsEveryIterationOnce) {
  const Threads threads(4);
  std::vector<std::atomic<int>> runs(1000);
  parallel_for(runs.size(), [&](std::size_t i) { ++runs[i]; });
  for (std::size_t i = 0; i < runs.size(); ++i) ASSERT_EQ(runs[i].load(), 1) << i;
}

TEST(ParallelFor, RethrowsTheErrorUnchangedOnceEveryThreadHasStopped) {
  const Threads threads(4);
  std::atomic<int> running{0}, finished{0};
  try {
    parallel_for(1000, [&](std::size_t i) {
      ++running;
      // Slow enough that the other threads cannot run through the loop while one throws.
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      if (i == 10) {
        --running;
        fail("{}: bad value {}", "frame.png", 7);
      }
      ++finished;
      --running;
    });
    ADD_FAILURE() << "no exception";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "frame.png: bad value 7");
  }
  EXPECT_EQ(running.load(), 0) << "an iteration was still running after the rethrow";
  EXPECT_LT(finished.load(), 999) << "the iterations after the error should be skipped";
}

TEST(ParallelFor, KeepsTheExceptionTypeAndSkipsTheRestOnOneThread) {
  const Threads threads(1);
  std::vector<int> ran;
  EXPECT_THROW(parallel_for(10,
                            [&](std::size_t i) {
                              ran.push_back(int(i));
                              if (i == 3) throw std::out_of_range("index 3");
                            }),
               std::out_of_range);
  EXPECT_EQ(ran, (std::vector<int>{0, 1, 2, 3}));
}

// --threads beyond any machine (100 000 crashed) and negative counts are refused by name; the
// thread count in force is unchanged.
TEST(SetThreads, RefusesCountsOutsideTheRange) {
  const int before = max_threads();
  for (int threads : {-1, 1025, 100000}) {
    try {
      set_threads(threads);
      ADD_FAILURE() << threads << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("--threads: must lie in [0, 1024]"), std::string::npos)
          << e.what();
    }
    EXPECT_EQ(max_threads(), before);
  }
}

}  // namespace
}  // namespace retimegs
