#include "retimegs/io/frame_writer.hpp"

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/io/image_io.hpp"

namespace retimegs::io {
namespace fs = std::filesystem;

struct FrameWriter::Video {
  cv::VideoWriter writer;
};

namespace {
bool is_video(const fs::path& path) {
  const std::string ext = path.extension().string();
  return ext == ".mp4" || ext == ".avi" || ext == ".mkv" || ext == ".mov";
}
}  // namespace

FrameWriter::FrameWriter(fs::path out, int frames, double fps, bool force)
    : out_(output_path(out)), frames_(frames), fps_(fps) {
  if (frames < 1) fail("{}: nothing to render (0 frames)", out_.string());
  check_output_free(out_, force);
  const std::string ext = out_.extension().string();
  if (!out.has_filename() || ext.empty()) {  // `x/` is a folder whatever its name
    kind_ = Kind::kFolder;
    folder_ = std::make_unique<AtomicDirectory>(out_, force);
  } else if (ext == ".png") {
    if (frames != 1)
      fail("{}: a .png output holds one frame but {} were requested; give a folder or an .mp4",
           out_.string(), frames);
    kind_ = Kind::kPng;
  } else if (is_video(out_)) {
    if (!(fps > 0) || !std::isfinite(fps))
      fail("{}: invalid video frame rate {}", out_.string(), fps);
    kind_ = Kind::kVideo;
    file_ = std::make_unique<AtomicFile>(out_);
    video_ = std::make_unique<Video>();
  } else {
    fail(
        "{}: unknown output type '{}': give x.png (one frame), a video (.mp4, .avi, .mkv, .mov) "
        "or a folder (a name ending in '/' is always one)",
        out_.string(), ext);
  }
}

FrameWriter::~FrameWriter() = default;

void FrameWriter::write(const Image& rgb) {
  if (written_ >= frames_) fail("{}: more frames than announced ({})", out_.string(), frames_);
  switch (kind_) {
    case Kind::kPng:
      write_png(out_, rgb);
      break;
    case Kind::kFolder:
      write_png(folder_->temp_path() / fmt::format("{:05d}.png", written_), rgb);
      break;
    case Kind::kVideo: {
      if (!video_->writer.isOpened()) {
        const int fourcc = out_.extension() == ".avi" ? cv::VideoWriter::fourcc('M', 'J', 'P', 'G')
                                                      : cv::VideoWriter::fourcc('m', 'p', '4', 'v');
        video_->writer.open(file_->temp_path().string(), cv::CAP_FFMPEG, fourcc, fps_,
                            cv::Size(rgb.width, rgb.height));
        if (!video_->writer.isOpened())
          fail("{}: cannot open a video writer (OpenCV built without FFmpeg?)", out_.string());
      }
      cv::Mat f(rgb.height, rgb.width, CV_32FC3, const_cast<float*>(rgb.data.data())), bgr8;
      f.convertTo(bgr8, CV_8UC3, 255.0);
      cv::cvtColor(bgr8, bgr8, cv::COLOR_RGB2BGR);
      video_->writer.write(bgr8);
      break;
    }
  }
  ++written_;
}

void FrameWriter::finish() {
  if (written_ != frames_)
    fail("{}: {} of {} frames were written", out_.string(), written_, frames_);
  if (kind_ == Kind::kVideo) {
    video_->writer.release();
    if (!fs::exists(file_->temp_path()) || fs::file_size(file_->temp_path()) == 0)
      fail("{}: the video encoder wrote nothing", out_.string());
    if (fs::exists(out_)) fs::remove(out_);
    file_->commit();
  } else if (kind_ == Kind::kFolder) {
    folder_->commit();
  }
}

std::vector<double> read_retime_csv(const fs::path& path) {
  std::ifstream in(path);
  if (!in) fail("{}: cannot open retime file", path.string());
  std::map<int, double> keys;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    double frame = 0, t = 0;
    std::string rest;
    if (!(fields >> frame >> t)) {
      if (keys.empty() && number == 1) continue;  // header
      fail("{}:{}: expected 'output_frame,t'", path.string(), number);
    }
    if (fields >> rest) fail("{}:{}: more than two columns", path.string(), number);
    if (!std::isfinite(t) || frame < 0 || frame != std::floor(frame) || frame > 1e7)
      fail("{}:{}: output_frame must be a non-negative integer and t finite", path.string(),
           number);
    if (!keys.empty() && int(frame) <= keys.rbegin()->first)
      fail("{}:{}: output frame {} after {}: rows must be in increasing output_frame order",
           path.string(), number, int(frame), keys.rbegin()->first);
    keys.emplace(int(frame), t);
  }
  if (keys.empty()) fail("{}: no keyframes", path.string());
  std::vector<double> times;
  auto it = keys.begin();
  for (int frame = keys.begin()->first; frame <= keys.rbegin()->first; ++frame) {
    auto next = std::next(it);
    if (next != keys.end() && frame >= next->first) it = next++;
    if (next == keys.end()) {
      times.push_back(it->second);
    } else {
      const double s = double(frame - it->first) / double(next->first - it->first);
      times.push_back(it->second + s * (next->second - it->second));
    }
  }
  return times;
}

}  // namespace retimegs::io
