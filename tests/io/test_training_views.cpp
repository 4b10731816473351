// io::training_views with a window (train --window, prepare --window) and --window parsing.
#include <gtest/gtest.h>

#include "retimegs/io/training_views.hpp"
#include "test_util.hpp"

namespace retimegs::io {
namespace {

Scene clip(int frames) {
  Scene scene;
  scene.root = "/nonexistent/clip";
  scene.num_frames = frames;
  Camera cam;
  cam.name = "c";
  cam.width = 8, cam.height = 6;
  cam.fx = cam.fy = 8, cam.cx = 4, cam.cy = 3;
  scene.cameras = {cam, cam};
  scene.cameras[1].split = Split::kTest;
  return scene;
}

TEST(TrainingViews, WindowKeepsItsFramesAndTheClipsScale) {
  const Scene scene = clip(33);
  const TrainingViews whole = training_views(scene, FrameSelection::kEven);
  const TrainingViews w = training_views(scene, FrameSelection::kEven, FrameWindow{8, 16});
  EXPECT_EQ(w.frames, (std::vector<int>{8, 10, 12, 14, 16}));
  // Within the window, and out of each end to the clip frame beyond (none before frame 0).
  ASSERT_EQ(w.flow_pairs.size(), 6u);
  EXPECT_EQ(w.flow_pairs.front(), (std::pair{6, 8}));
  EXPECT_EQ(w.flow_pairs[1], (std::pair{8, 10}));
  EXPECT_EQ(w.flow_pairs.back(), (std::pair{16, 18}));
  const TrainingViews first = training_views(scene, FrameSelection::kEven, FrameWindow{0, 8});
  ASSERT_EQ(first.flow_pairs.size(), 5u);
  EXPECT_EQ(first.flow_pairs.front(), (std::pair{0, 2}));
  EXPECT_EQ(first.flow_pairs.back(), (std::pair{8, 10}));
  EXPECT_EQ(training_views(scene, FrameSelection::kEven, FrameWindow{24, 32}).flow_pairs.back(),
            (std::pair{30, 32}));
  EXPECT_EQ(w.clip_frames, whole.frames);
  EXPECT_EQ(w.cameras, whole.cameras);
  EXPECT_EQ(w.extent, whole.extent);
  EXPECT_EQ(training_views(scene, FrameSelection::kAll, FrameWindow{7, 9}).frames,
            (std::vector<int>{7, 8, 9}));
  test::expect_error(
      [&] {
        training_views(scene, FrameSelection::kEven, FrameWindow{7, 16});
      },
      {"window 7:16", "frame 7 is not a training frame"});
  test::expect_error(
      [&] {
        training_views(scene, FrameSelection::kEven, FrameWindow{24, 34});
      },
      {"frame 34"});
}

TEST(TrainingViews, ParseFrameWindow) {
  const FrameWindow w = parse_frame_window("8:16", "--window");
  EXPECT_EQ(w.first, 8);
  EXPECT_EQ(w.last, 16);
  for (const char* bad : {"16:8", "8:8", "8", "a:b", "8:16:2", "-2:4", "8: 16", ""})
    test::expect_error([&] { parse_frame_window(bad, "--window"); }, {"--window", "A:B"});
}

}  // namespace
}  // namespace retimegs::io
