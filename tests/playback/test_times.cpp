// The times of a render's frames: a range A:B:STEP, slow motion over a clip, a speed ramp; more
// frames than one command renders are refused naming the flag (or, for a ramp, the file's line).
#include <gtest/gtest.h>

#include "retimegs/playback/times.hpp"
#include "test_util.hpp"

namespace retimegs::playback {
namespace {
using test::expect_error;

TEST(Times, RangeIncludesItsEndDespiteRounding) {
  EXPECT_EQ(range_times({0, 2, 0.5}, "--times"), (std::vector<double>{0, 0.5, 1, 1.5, 2}));
  // 3 x 0.1 is 0.30000000000000004 > 0.3: the end is still in.
  const std::vector<double> tenths = range_times({0, 0.3, 0.1}, "--times");
  ASSERT_EQ(tenths.size(), 4u);
  EXPECT_DOUBLE_EQ(tenths[3], 0.3);
  EXPECT_EQ(range_times({2.5, 3, 1}, "--times"), (std::vector<double>{2.5}));  // B not on the grid
  EXPECT_EQ(range_times({4, 4, 1}, "--times"), (std::vector<double>{4}));
}

TEST(Times, RangeOutOfOrderOrWithoutStepIsRefused) {
  expect_error([] { range_times({0, 1, 0}, "--times"); }, {"--times", "STEP > 0", "'0:1:0'"});
  expect_error([] { range_times({2, 1, 0.5}, "--times"); }, {"--times", "A <= B", "'2:1:0.5'"});
  expect_error([] { range_times({0, 1, -1}, "--times"); }, {"--times"});
}

TEST(Times, FrameCountLimit) {
  check_frame_count(kMaxOutputFrames, "--x");
  expect_error([] { check_frame_count(kMaxOutputFrames + 1, "--x"); }, {"--x", "1000001 frames"});
  // 0:1000000:1 is 1000001 frames: refused before any is listed.
  expect_error([] { range_times({0, 1e6, 1}, "--times"); }, {"--times", "1000001 frames"});
  EXPECT_EQ(range_times({0, 1e6 - 1, 1}, "--times").size(), std::size_t(kMaxOutputFrames));
}

TEST(Times, SlowMotionAtFactorEightOverAClip) {
  // Scene frames 0..16 at 8x: 8 frames per interval, 16 x 8 + 1 in all, both ends included.
  const std::vector<double> times = slowmo_times(0, 16, 8);
  ASSERT_EQ(times.size(), 129u);
  EXPECT_EQ(times[1], 0.125);
  EXPECT_EQ(times[8], 1.0);
  EXPECT_EQ(times[100], 12.5);
  EXPECT_EQ(times.back(), 16.0);
  // A clip that does not start at 0: t = first + k / F.
  const std::vector<double> thirds = slowmo_times(2, 5, 3);
  ASSERT_EQ(thirds.size(), 10u);
  EXPECT_DOUBLE_EQ(thirds[1], 2 + 1.0 / 3);
  EXPECT_EQ(thirds.back(), 5.0);
  EXPECT_EQ(slowmo_times(2, 5, 1), (std::vector<double>{2, 3, 4, 5}));
}

TEST(Times, SlowMotionFactorMustBePositiveAndTheCountBounded) {
  expect_error([] { slowmo_times(0, 16, 0); }, {"--slowmo", ">= 1", "0"});
  expect_error([] { slowmo_times(0, 16, 1'000'000'000); }, {"--slowmo", "at most 1000000"});
}

TEST(Times, RampInterpolatesBetweenKeyframes) {
  // Real time to frame 4, a hold over frames 4..6, then twice the speed.
  const std::vector<media::RetimeKey> keys = {{0, 0.0}, {4, 2.0}, {6, 2.0}, {8, 6.0}};
  EXPECT_EQ(ramp_times(keys), (std::vector<double>{0, 0.5, 1, 1.5, 2, 2, 2, 4, 6}));
  // The output starts at the first keyframe; a reverse ramp runs time backwards.
  EXPECT_EQ(ramp_times({{3, 8.0}, {5, 7.0}}), (std::vector<double>{8, 7.5, 7}));
  EXPECT_EQ(ramp_times({{2, 1.25}}), (std::vector<double>{1.25}));
  EXPECT_TRUE(ramp_times({}).empty());
}

// Found by fuzzing: a 14-byte file with a keyframe at output frame 9992992 made ten million times
// (seconds of work and 80 MB before any check) for a render that the frame limit refuses anyway.
TEST(Times, RampKeyframesBeyondTheOutputLimitAreRefusedWhereTheFileIsRead) {
  test::TempDir dir;
  const std::filesystem::path csv = dir / "ramp.csv";
  test::write_text(csv, "9-9\n9992992 5\n");
  expect_error([&] { media::read_retime_csv(csv); }, {"ramp.csv:2", "[0, 1000000)"});
  test::write_text(csv, "output_frame,t\n0,0\n999999,1\n");
  EXPECT_EQ(ramp_times(media::read_retime_csv(csv)).size(), std::size_t(kMaxOutputFrames));
}

}  // namespace
}  // namespace retimegs::playback
