#pragma once
// H.264 video written by the ffmpeg program: FrameWriter pipes each frame to it as raw rgb24, and
// libx264 encodes them as 8-bit yuv420p at a constant quality, the CRF. OpenCV's FFmpeg backend
// (4.6) encodes libx264 at x264's default CRF 23 and offers no quality setting
// (OPENCV_FFMPEG_WRITER_OPTIONS is not applied reliably, opencv/opencv#24570), while plates for
// VFX and VR need near-lossless video (CRF 16 to 18) or lossless (0). Every H.264 output goes
// through ffmpeg, the default CRF too: one encoder writes them all, with the x264 settings
// OpenCV's writer used; a failed write is reported by the encoder (OpenCV's writer drops FFmpeg's
// write errors); and its RGB to YUV conversion is the more exact (at CRF 23 the frames decode
// over 1 dB closer at the same size). Starting the program costs about 0.15 s per video.
#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <functional>

namespace retimegs::media {

// libx264's constant rate factor for 8-bit video: 0 is lossless, 51 the coarsest; six steps up
// about halve the bit rate.
constexpr int kMinCrf = 0;
constexpr int kMaxCrf = 51;
constexpr int kDefaultCrf = 23;  // x264's own default, which OpenCV's writer used too

// The ffmpeg program on PATH. Throws Error naming `out` and the next step (install the Debian
// package ffmpeg, or write PNGs) when there is none.
std::filesystem::path find_ffmpeg(const std::filesystem::path& out);

// One running `ffmpeg` that encodes frames of width x height at `fps` into `file` (created or
// replaced), as H.264 at `crf` in the container of `out`'s extension (.mp4, .mov or .mkv). `out`
// is the output as the user named it, for messages; `file` is where it is written (its temporary
// sibling). ffmpeg's output goes to a log in the temporary folder, kept and named when it fails.
// `explain`, when given, runs first when ffmpeg has failed, and may throw its own Error instead
// (FrameWriter names a file-size limit or a full disk as every writer does); the log is then
// removed.
class FfmpegVideo {
 public:
  FfmpegVideo(const std::filesystem::path& ffmpeg, const std::filesystem::path& file,
              const std::filesystem::path& out, int width, int height, double fps, int crf,
              std::function<void()> explain = {});
  // A process that finish() has not waited for is killed (its half-written file is the caller's
  // to remove), so that an error or Ctrl-C leaves no encoder running.
  ~FfmpegVideo();
  FfmpegVideo(const FfmpegVideo&) = delete;
  FfmpegVideo& operator=(const FfmpegVideo&) = delete;

  // One frame: width * height * 3 bytes, rows top to bottom, R, G, B. Throws Error when ffmpeg
  // has stopped (as finish() does).
  void write(const std::uint8_t* rgb);
  // Ends the input and waits for ffmpeg to complete the file. Throws Error when it failed, by its
  // exit status, a signal or an error in its log: "<out>: ffmpeg failed (<exit status or
  // signal>): <its first error line> (its log: <path>); ...", and Interrupted on Ctrl-C or SIGTERM
  // meanwhile.
  void finish();

 private:
  [[noreturn]] void fail_stopped();
  void wait_for_exit();
  std::filesystem::path out_, file_, log_;
  std::function<void()> explain_;
  int width_, height_;
  int input_ = -1;  // our end of ffmpeg's standard input
  pid_t pid_ = -1;  // until it has been waited for
  int status_ = 0;  // its waitpid status, once it exited
  bool keep_log_ = false;
};

}  // namespace retimegs::media
