// probe_video and decode_video (import_common.hpp): the helpers the importers share that need
// OpenCV's videoio, apart so that the lean GPU build, which has no videoio, builds the others
// (CMakeLists.txt).
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

void decode_video(const VideoInfo& video, int first, int last,
                  const std::function<void(const Image&, int)>& use) {
  cv::VideoCapture cap(video.path.string(), cv::CAP_FFMPEG);
  if (!cap.isOpened()) fail("{}: cannot open video", video.path.string());
  cv::Mat frame;
  for (int k = 0; k <= last; ++k) {
    const bool ok = k < first ? cap.grab() : cap.read(frame) && !frame.empty();
    if (!ok)
      fail("{}: cannot decode frame {} (the video ends early or is corrupt)", video.path.string(),
           k);
    if (k < first) continue;
    if (frame.cols != video.width || frame.rows != video.height)
      fail("{}: frame {} is {}x{} but the video header says {}x{}", video.path.string(), k,
           frame.cols, frame.rows, video.width, video.height);
    use(from_bgr8(frame), k);
  }
}

}  // namespace retimegs::ingest::detail
