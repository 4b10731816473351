// probe_video (import_common.hpp): the one helper the importers share that needs OpenCV's videoio,
// apart so that the lean GPU build, which has no videoio, builds the others (CMakeLists.txt).
#include <cstdlib>

#include <opencv2/videoio.hpp>

#include "import_common.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/core/limits.hpp"

namespace retimegs::ingest::detail {

VideoInfo probe_video(const std::filesystem::path& path) {
  // FFmpeg prints its own complaints ("moov atom not found") on stderr, which would double the
  // one-line error; OpenCV reads this variable once, when its FFmpeg backend starts. A value the
  // user set wins.
  ::setenv("OPENCV_FFMPEG_LOGLEVEL", "-8", 0);  // AV_LOG_QUIET
  check_input_file(path, "a video");            // FFmpeg would wait on a FIFO for ever
  cv::VideoCapture cap(path.string(), cv::CAP_FFMPEG);
  if (!cap.isOpened()) fail("{}: cannot open video (FFmpeg could not decode it)", path.string());
  VideoInfo v;
  v.path = path;
  v.width = int(cap.get(cv::CAP_PROP_FRAME_WIDTH));
  v.height = int(cap.get(cv::CAP_PROP_FRAME_HEIGHT));
  v.frames = int(cap.get(cv::CAP_PROP_FRAME_COUNT));
  v.fps = cap.get(cv::CAP_PROP_FPS);
  cv::Mat first;
  if (!cap.read(first) || first.empty())
    fail("{}: cannot decode the first frame of the video", path.string());
  if (v.width < 1 || v.height < 1) v.width = first.cols, v.height = first.rows;
  if (v.frames < 1) fail("{}: video reports no frames", path.string());
  check_fps(v.fps, path.string() + ": the video's frame rate");
  return v;
}

}  // namespace retimegs::ingest::detail
