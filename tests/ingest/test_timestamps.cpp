// Per-frame timestamps of `import videos --timestamps` (ingest/timestamps.hpp): the CSV and the
// frame_times it gives.
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/ingest/timestamps.hpp"
#include "test_util.hpp"

namespace retimegs::ingest {
namespace {
namespace fs = std::filesystem;

const std::vector<std::string> kNames = {"cam00", "cam01"};

// A header, blank lines, spaces and CRLF are allowed; rows in any order. frame_times are the
// seconds since the first camera's scene frame 0, in frames at the scene's rate.
TEST(Timestamps, FrameTimesAreSecondsSinceTheFirstCamerasFirstFrameTimesFps) {
  test::TempDir dir;
  test::write_text(dir / "t.csv",
                   "camera,frame,seconds\r\n"
                   "cam01, 1, 100.110\r\n"
                   "cam00,0,100.000\n\n"
                   "cam00,1,100.040\n"
                   "cam00,2,100.080\n"
                   "cam01,0,100.070\n"
                   "cam01,2,100.150\n");
  const Timestamps t = read_timestamps(dir / "t.csv", kNames);
  ASSERT_EQ(t.cameras.at("cam01").size(), 3u);
  EXPECT_EQ(t.cameras.at("cam01").at(1).line, 2);
  // Scene frame k: cam00's source frame k + 1, cam01's k.
  const auto times = frame_times_from_timestamps(t, kNames, {1, 0}, 2, 25);
  ASSERT_EQ(times.size(), 2u);
  EXPECT_NEAR(times[0][0], 0, 1e-9);
  EXPECT_NEAR(times[0][1], 1, 1e-9);     // 40 ms at 25 fps
  EXPECT_NEAR(times[1][0], 0.75, 1e-9);  // 30 ms
  EXPECT_NEAR(times[1][1], 1.75, 1e-9);
  // Scene frame 2 of cam00 is its source frame 3, which has no timestamp.
  test::expect_error(
      [&] {
        frame_times_from_timestamps(t, kNames, {1, 0}, 3, 25);
      },
      {"t.csv: no timestamp for camera 'cam00' frame 3 (its scene frame 2)"});
}

// Each error names the file, the line and the value at fault.
TEST(Timestamps, ErrorsNameTheLineAndTheValue) {
  test::TempDir dir;
  const auto expect = [&](const std::string& text, const std::string& want) {
    test::write_text(dir / "t.csv", text);
    test::expect_error([&] { read_timestamps(dir / "t.csv", kNames); },
                       {(dir / "t.csv").string() + ":", want});
  };
  expect("cam00,0,1\ncam02,0,1\n", ":2: unknown camera 'cam02'");
  expect("cam00,0,1\ncam00,1,nan\n", ":2: seconds 'nan' is not a finite number");
  expect("cam00,0,1\ncam00,1,inf\n", ":2: seconds 'inf' is not a finite number");
  expect("cam00,0,1\ncam00,1,x\n", ":2: seconds 'x' is not a finite number");
  expect("cam00,0,1\ncam00,0,2\n", ":2: camera 'cam00' frame 0 is given twice (also line 1)");
  expect("cam00,0,1\ncam00,2,3\ncam00,1,3\n",
         ":2: camera 'cam00' frame 2 at 3 s is not after frame 1 at 3 s (line 3)");
  expect("cam00,0,1\ncam00,1,0.5\n", ":2: camera 'cam00' frame 1 at 0.5 s is not after frame 0");
  expect("cam00,0,1\ncam00,-1,0\n", ":2: frame '-1' is not a whole number");
  expect("cam00,0,1\ncam00,1.5,2\n", ":2: frame '1.5' is not a whole number");
  expect("cam00,0\n", ":1: 'cam00,0' is not camera,frame,seconds");
  // Only the first line may be a header.
  expect("cam00,0,1\ncamera,frame,seconds\n", ":2: unknown camera 'camera'");
}

}  // namespace
}  // namespace retimegs::ingest
