#pragma once
// Where rendered frames go, chosen by the output path: `x.png` (exactly one frame), `x.mp4` /
// `x.avi` / `x.mkv` / `x.mov` (a video through OpenCV's FFmpeg backend), a name without extension
// or ending in '/' a folder of `<frame:05d>.png`; any other extension (`x.jpg`) is an error rather
// than a folder of that name. Every kind appears atomically when finish() is called; an unfinished
// writer leaves nothing behind.
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/image.hpp"

namespace retimegs::io {

class FrameWriter {
 public:
  // `frames`: how many will be written (checked); `fps` for videos; `force` replaces an existing
  // output folder or file.
  FrameWriter(std::filesystem::path out, int frames, double fps, bool force = false);
  ~FrameWriter();
  FrameWriter(const FrameWriter&) = delete;
  FrameWriter& operator=(const FrameWriter&) = delete;

  void write(const Image& rgb);  // RGB in [0, 1], clamped
  void finish();

 private:
  enum class Kind { kPng, kVideo, kFolder };
  struct Video;
  std::filesystem::path out_;
  Kind kind_;
  int frames_, written_ = 0;
  double fps_;
  std::unique_ptr<AtomicFile> file_;
  std::unique_ptr<AtomicDirectory> folder_;
  std::unique_ptr<Video> video_;
};

// A speed-ramp file: CSV rows `output_frame,t` in increasing output_frame order (a header line and
// blank lines are allowed), the keyframes of a time remap. Returns one time per output frame from
// the first to the last keyframe, linearly interpolated between keyframes. Throws Error naming the
// file and line.
std::vector<double> read_retime_csv(const std::filesystem::path& path);

}  // namespace retimegs::io
