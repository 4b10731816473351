#include "retimegs/media/frame_writer.hpp"

#include <sys/resource.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/core/limits.hpp"
#include "retimegs/media/ffmpeg_video.hpp"
#include "retimegs/media/image_io.hpp"

namespace retimegs::media {
namespace fs = std::filesystem;

// Motion-JPEG through OpenCV's writer; H.264 through the ffmpeg program (ffmpeg_video.hpp), once
// the first frame gives the size.
struct FrameWriter::Video {
  fs::path ffmpeg;  // H.264 only
  cv::VideoWriter mjpeg;
  std::unique_ptr<FfmpegVideo> h264;
  bool started = false;
  int width = 0, height = 0;
};

namespace {
// H.264 in the containers browsers, players and editors open it in; .avi keeps Motion-JPEG,
// which AVI tools expect.
bool is_h264(const fs::path& path) {
  const std::string ext = path.extension().string();
  return ext == ".mp4" || ext == ".mov" || ext == ".mkv";
}

// OpenCV's video writer drops FFmpeg's write errors: a video cut short by a file-size limit or a
// full disk after its first block (the probe in the constructor) would be kept as if complete.
// ffmpeg reports them in its words (and exits with status 0 when its trailer is cut): FfmpegVideo
// runs this check first when it fails, so that either is named as every other writer names it.
// Each leaves a trace: the file at the size limit (a write beyond it fails with EFBIG),
// or its file system without a free block (root may write into the reserved ones, others may not).
void check_video_not_cut_short(const fs::path& file, const fs::path& out) {
  rlimit limit{};
  if (::getrlimit(RLIMIT_FSIZE, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY &&
      fs::file_size(file) >= limit.rlim_cur)
    fail("{}: cannot write the video file: {}", out.string(), std::strerror(EFBIG));
  struct statvfs disk {};
  if (::statvfs(file.c_str(), &disk) == 0 &&
      (disk.f_bfree == 0 || (::geteuid() != 0 && disk.f_bavail == 0)))
    fail("{}: cannot write the video file: {}", out.string(), std::strerror(ENOSPC));
}

bool is_video(const fs::path& path) {
  return is_h264(path) || path.extension() == ".avi";
}

FrameWriterOptions video_options(double fps, bool force) {
  FrameWriterOptions options;
  options.fps = fps;
  options.force = force;
  return options;
}
}  // namespace

FrameWriter::FrameWriter(fs::path out, int frames, double fps, bool force)
    : FrameWriter(std::move(out), frames, video_options(fps, force)) {}

FrameWriter::FrameWriter(fs::path out, int frames, const FrameWriterOptions& options)
    : out_(output_path(out)), frames_(frames), options_(options) {
  if (frames < 1) fail("{}: nothing to render (0 frames)", out_.string());
  if (!options.times.empty() && int(options.times.size()) != frames)
    fail("{}: {} frame times for {} frames", out_.string(), options.times.size(), frames);
  if (options.bit_depth != 8 && options.bit_depth != 16)
    fail("{}: bit depth must be 8 or 16, not {}", out_.string(), options.bit_depth);
  check_output_free(out_, options.force);
  const std::string ext = out_.extension().string();
  if (ext == ".exr" && !options_.exr) options_.exr = ExrPrecision::kHalf;
  if (options_.exr) check_exr_writer(out_);
  if (options_.depth && !options_.exr)
    fail(
        "{}: a depth pass (--depth) is float EXR beside EXR frames: give x.exr or a folder with "
        "--exr",
        out_.string());
  const bool folder = !out.has_filename() || ext.empty();  // `x/` is a folder whatever its name
  if (options_.depth && !folder) check_output_free(depth_path(out_), options.force);
  const bool h264 = !folder && is_h264(out_);
  if (options_.crf && !h264)
    fail("{}: --crf is the quality of H.264 video (.mp4, .mov, .mkv), not of {}", out_.string(),
         folder ? std::string("a folder of frames") : fmt::format("a {} output", ext));
  if (options_.crf && (*options_.crf < kMinCrf || *options_.crf > kMaxCrf))
    fail(
        "{}: --crf {} is outside libx264's range {} to {} (0 lossless, 16 to 18 near-lossless, {} "
        "the default)",
        out_.string(), *options_.crf, kMinCrf, kMaxCrf, kDefaultCrf);
  if (folder) {
    kind_ = Kind::kFolder;
    folder_ = std::make_unique<AtomicDirectory>(out_, options.force);
  } else if (ext == ".png" || ext == ".exr") {
    if (frames != 1)
      fail("{}: a {} output holds one frame but {} were requested; give a folder or an .mp4",
           out_.string(), ext, frames);
    if (ext == ".png" && options_.exr)
      fail("{}: an EXR precision was given for a .png output: name it x.exr", out_.string());
    kind_ = Kind::kImage;
  } else if (is_video(out_)) {
    if (options_.exr)
      fail("{}: a video is not EXR: give x.exr or a folder for EXR frames", out_.string());
    if (!(options.fps > 0) || !std::isfinite(options.fps))
      fail("{}: invalid video frame rate {}", out_.string(), options.fps);
    if (options.alpha)
      fail("{}: a video has no alpha channel (--alpha): write a .png or a folder of PNGs",
           out_.string());
    if (options.bit_depth != 8)
      fail("{}: a video is 8-bit; {} bits per channel (--bit-depth) need a .png or a folder",
           out_.string(), options.bit_depth);
    kind_ = Kind::kVideo;
    video_ = std::make_unique<Video>();
    if (h264) video_->ffmpeg = find_ffmpeg(out_);
    file_ = std::make_unique<AtomicFile>(out_, /*replace=*/options.force);
    // The encoder reports any failure to create or start its file as "cannot open": try both
    // first (a block of the size of a container header), so that a read-only folder or a full
    // disk is named as such. The encoder then writes over this file.
    {
      errno = 0;
      std::ofstream probe(file_->temp_path(), std::ios::binary);
      const std::string block(4096, '\0');
      probe.write(block.data(), std::streamsize(block.size()));
      probe.close();
      if (!probe)
        fail("{}: cannot create the video file: {}", out_.string(),
             errno ? std::strerror(errno) : "unknown error");
    }
  } else {
    fail(
        "{}: unknown output type '{}': give x.png or x.exr (one frame), a video (.mp4, .mov, "
        ".mkv, .avi) or a folder (a name ending in '/' is always one)",
        out_.string(), ext);
  }
}

FrameWriter::~FrameWriter() = default;

void FrameWriter::write(const Image& image, const Image* depth) {
  if (written_ >= frames_) fail("{}: more frames than announced ({})", out_.string(), frames_);
  const int channels = options_.alpha ? 4 : 3;
  if (image.channels != channels || image.width <= 0 || image.height <= 0 ||
      image.data.size() != image.pixels() * channels)
    fail("{}: frame {} is {}x{}x{}, expected {} channels", out_.string(), written_, image.width,
         image.height, image.channels, channels);
  if ((depth != nullptr) != options_.depth)
    fail("{}: frame {} {} a depth pass", out_.string(), written_, options_.depth ? "lacks" : "has");
  if (depth && (depth->width != image.width || depth->height != image.height ||
                depth->channels != 1 || depth->data.size() != depth->pixels()))
    fail("{}: frame {} is {}x{} but its depth pass {}x{}x{}", out_.string(), written_, image.width,
         image.height, depth->width, depth->height, depth->channels);
  switch (kind_) {
    case Kind::kImage:
      write_image(out_, image, depth, /*replace=*/options_.force);
      break;
    case Kind::kFolder:
      write_image(
          folder_->temp_path() / fmt::format("{:05d}.{}", written_, options_.exr ? "exr" : "png"),
          image, depth, /*replace=*/true);
      break;
    case Kind::kVideo: {
      const bool h264 = !video_->ffmpeg.empty();
      if (!video_->started) {
        if (image.width % 2 != 0 || image.height % 2 != 0)
          fail(
              "{}: a video needs an even width and height (4:2:0 chroma), the frames are {}x{}: "
              "render at an even size (--size, --scale) or write PNGs",
              out_.string(), image.width, image.height);
        if (h264) {
          const fs::path file = file_->temp_path(), out = out_;
          video_->h264 =
              std::make_unique<FfmpegVideo>(video_->ffmpeg, file, out, image.width, image.height,
                                            options_.fps, options_.crf.value_or(kDefaultCrf),
                                            [file, out] { check_video_not_cut_short(file, out); });
        } else {
          // Software encoding: the codec and its settings do not depend on the machine's GPU.
          const std::vector<int> params = {cv::VIDEOWRITER_PROP_HW_ACCELERATION,
                                           cv::VIDEO_ACCELERATION_NONE};
          video_->mjpeg.open(file_->temp_path().string(), cv::CAP_FFMPEG,
                             cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), options_.fps,
                             cv::Size(image.width, image.height), params);
          if (!video_->mjpeg.isOpened())
            fail(
                "{}: cannot open a Motion-JPEG video writer (OpenCV's FFmpeg backend without "
                "mjpeg?)",
                out_.string());
        }
        video_->started = true;
        video_->width = image.width, video_->height = image.height;
      }
      if (image.width != video_->width || image.height != video_->height)
        fail("{}: frame {} is {}x{} but the video is {}x{}", out_.string(), written_, image.width,
             image.height, video_->width, video_->height);
      cv::Mat f(image.height, image.width, CV_32FC3, const_cast<float*>(image.data.data())), rgb8;
      f.convertTo(rgb8, CV_8UC3, 255.0);  // rounded, clamped to [0, 255]
      if (h264) {
        video_->h264->write(rgb8.ptr<std::uint8_t>());
      } else {
        cv::cvtColor(rgb8, rgb8, cv::COLOR_RGB2BGR);
        video_->mjpeg.write(rgb8);
      }
      break;
    }
  }
  ++written_;
}

void FrameWriter::write_image(const fs::path& path, const Image& image, const Image* depth,
                              bool replace) const {
  const auto write_colour = [&](const fs::path& to, bool replace_to) {
    if (options_.exr)
      write_exr(to, image, *options_.exr == ExrPrecision::kFloat, replace_to);
    else
      write_png(to, image, options_.bit_depth, replace_to);
  };
  if (!depth) return write_colour(path, replace);
  // A frame and its depth pass appear together or not at all: both are written under temporary
  // names, then moved into place, the depth pass first, which is taken back when the frame's move
  // fails (another writer's x.exr there meanwhile, a folder in its place).
  AtomicFile depth_file(depth_path(path), replace), colour_file(path, replace);
  // Float, whatever the frames' precision: half's 11-bit mantissa would step by 1/1024 of the
  // depth, and kNoDepth is beyond its range.
  write_exr(depth_file.temp_path(), *depth, /*float32=*/true, /*replace=*/true);
  write_colour(colour_file.temp_path(), /*replace_to=*/true);
  depth_file.commit();
  try {
    colour_file.commit();
  } catch (...) {
    std::error_code ignored;
    fs::remove(depth_file.final_path(), ignored);
    throw;
  }
}

void FrameWriter::finish() {
  if (written_ != frames_)
    fail("{}: {} of {} frames were written", out_.string(), written_, frames_);
  if (kind_ == Kind::kVideo) {
    if (video_->h264) video_->h264->finish();
    video_->mjpeg.release();
    if (!fs::exists(file_->temp_path()) || fs::file_size(file_->temp_path()) == 0)
      fail("{}: the video encoder wrote nothing", out_.string());
    check_video_not_cut_short(file_->temp_path(), out_);
    file_->commit();
  } else if (kind_ == Kind::kFolder) {
    if (!options_.times.empty())
      write_times_csv(folder_->temp_path() / "times.csv", options_.times);
    folder_->commit();
  }
}

fs::path depth_path(const fs::path& frame) {
  return fs::path(frame).replace_extension(".depth.exr");
}

void write_times_csv(const fs::path& path, const std::vector<double>& times) {
  std::string text = "frame,time\n";
  for (std::size_t k = 0; k < times.size(); ++k) {
    if (!std::isfinite(times[k])) fail("{}: frame {} has time {}", path.string(), k, times[k]);
    text += fmt::format("{},{}\n", k, times[k]);  // {}: the shortest exact round trip
  }
  write_text_file(path, text);
}

std::vector<RetimeKey> read_retime_csv(const fs::path& path) {
  check_input_file(path, "a retime file");
  std::ifstream in(path);
  if (!in) fail("{}: cannot open retime file", path.string());
  std::vector<RetimeKey> keys;
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
    if (!std::isfinite(t) || frame < 0 || frame != std::floor(frame) || frame >= kMaxOutputFrames)
      fail("{}:{}: output_frame must be an integer in [0, {}) and t finite", path.string(), number,
           kMaxOutputFrames);
    if (!keys.empty() && int(frame) <= keys.back().output_frame)
      fail("{}:{}: output frame {} after {}: rows must be in increasing output_frame order",
           path.string(), number, int(frame), keys.back().output_frame);
    keys.push_back({int(frame), t});
  }
  if (keys.empty()) fail("{}: no keyframes", path.string());
  return keys;
}

}  // namespace retimegs::media
