// FrameWriter's outputs as a VFX pipeline reads them: .mp4 / .mov / .mkv are H.264 (libx264,
// 4:2:0, 8-bit, through the ffmpeg program) that decodes close to what was written, at the CRF
// asked for, .avi Motion-JPEG at any size; PNGs hold straight RGBA and 16-bit codes exactly; a
// folder has times.csv; an EXR frame and its depth pass appear together; options that do not fit
// the output are refused before anything is written, and so is H.264 without ffmpeg; a failing
// or abandoned ffmpeg leaves no file and no process.
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/media/ffmpeg_video.hpp"
#include "retimegs/media/frame_writer.hpp"
#include "retimegs/media/image_io.hpp"
#include "test_util.hpp"

namespace retimegs::media {
namespace {
namespace fs = std::filesystem;
using test::expect_error;
using test::TempDir;

// Options with the given fields set (the rest default).
FrameWriterOptions options(double fps = 0, bool alpha = false, int bit_depth = 8,
                           std::vector<double> times = {}) {
  FrameWriterOptions o;
  o.fps = fps, o.alpha = alpha, o.bit_depth = bit_depth, o.times = std::move(times);
  return o;
}

using Rgb16 = cv::Vec<std::uint16_t, 3>;
using Rgba16 = cv::Vec<std::uint16_t, 4>;

// A smooth frame that moves with k (what a render looks like to an encoder).
Image moving_frame(int width, int height, int k) {
  Image image(width, height, 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      image.at(y, x, 0) = float(x) / width;
      image.at(y, x, 1) = float(y) / height;
      image.at(y, x, 2) = 0.5f + 0.4f * float(std::sin((x + 6.0 * k) / 6.0));
    }
  return image;
}

// A moving texture in luma over smooth colour gradients: what 4:2:0 keeps (its chroma is smooth),
// so that a decoded frame differs from it by the encoder's loss rather than by the subsampling.
Image textured_frame(int width, int height, int k) {
  Image image(width, height, 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float t =
          0.35f + 0.3f * float(std::sin((x + 3.0 * k) / 3.0) * std::cos((y - 2.0 * k) / 5.0));
      image.at(y, x, 0) = 0.3f * float(x) / width + t;
      image.at(y, x, 1) = 0.3f * float(y) / height + t;
      image.at(y, x, 2) = 0.3f + t;
    }
  return image;
}

// PSNR in dB of a decoded BGR 8-bit frame against the RGB frame written.
double psnr(const cv::Mat& bgr, const Image& rgb) {
  double se = 0;
  for (int y = 0; y < rgb.height; ++y)
    for (int x = 0; x < rgb.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const double d = bgr.at<cv::Vec3b>(y, x)[2 - c] - std::round(rgb.at(y, x, c) * 255.0);
        se += d * d;
      }
  return 10 * std::log10(255.0 * 255.0 / (se / (3.0 * rgb.pixels())));
}

using FrameFunction = Image (*)(int width, int height, int k);

void write_video(const fs::path& path, int width, int height, int frames, double fps,
                 std::optional<int> crf = std::nullopt, FrameFunction frame = moving_frame) {
  FrameWriterOptions o = options(fps);
  o.crf = crf;
  FrameWriter writer(path, frames, o);
  for (int k = 0; k < frames; ++k) writer.write(frame(width, height, k));
  writer.finish();
}

// The mean PSNR in dB of a video's decoded frames against frame(width, height, k), and how many
// frames it has.
std::pair<double, int> video_psnr(const fs::path& path, int width, int height,
                                  FrameFunction frame) {
  cv::VideoCapture cap(path.string(), cv::CAP_FFMPEG);
  if (!cap.isOpened()) return {0.0, 0};
  double sum = 0;
  int frames = 0;
  for (cv::Mat bgr; cap.read(bgr); ++frames) sum += psnr(bgr, frame(width, height, frames));
  return {frames ? sum / frames : 0.0, frames};
}

// Environment variable `name` set to `value` for the life of the object (the writer looks ffmpeg
// up on PATH, and puts its log in TMPDIR).
class ScopedEnv {
 public:
  ScopedEnv(std::string name, const std::string& value) : name_(std::move(name)) {
    const char* old = std::getenv(name_.c_str());
    had_ = old != nullptr;
    if (had_) old_ = old;
    ::setenv(name_.c_str(), value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (had_)
      ::setenv(name_.c_str(), old_.c_str(), 1);
    else
      ::unsetenv(name_.c_str());
  }

 private:
  std::string name_, old_;
  bool had_ = false;
};

// A file-size limit of `bytes` for this process and its children while the object lives, with
// SIGXFSZ ignored as the app ignores it, so that writes beyond it fail with EFBIG.
class ScopedFileSizeLimit {
 public:
  explicit ScopedFileSizeLimit(rlim_t bytes) {
    old_handler_ = ::signal(SIGXFSZ, SIG_IGN);
    ::getrlimit(RLIMIT_FSIZE, &old_);
    rlimit limited = old_;
    limited.rlim_cur = bytes;
    ::setrlimit(RLIMIT_FSIZE, &limited);
  }
  ~ScopedFileSizeLimit() {
    ::setrlimit(RLIMIT_FSIZE, &old_);
    ::signal(SIGXFSZ, old_handler_);
  }

 private:
  rlimit old_{};
  sighandler_t old_handler_ = SIG_DFL;
};

// A folder holding an executable `ffmpeg` shell script with `body`, to stand for a broken one.
fs::path fake_ffmpeg(const fs::path& dir, const std::string& body) {
  fs::create_directories(dir);
  test::write_text(dir / "ffmpeg", "#!/bin/sh\n" + body + "\n");
  fs::permissions(dir / "ffmpeg", fs::perms::owner_all);
  return dir;
}

// The "(its log: PATH)" a failure message names.
fs::path named_log(const std::string& message) {
  const std::string key = "(its log: ";
  const std::size_t at = message.find(key);
  if (at == std::string::npos) return {};
  const std::size_t end = message.find(')', at);
  return message.substr(at + key.size(), end - at - key.size());
}

std::string fourcc_text(double fourcc) {
  const int v = int(fourcc);
  return {char(v & 255), char((v >> 8) & 255), char((v >> 16) & 255), char((v >> 24) & 255)};
}

// Exp-Golomb reader over an H.264 RBSP.
struct Bits {
  std::vector<std::uint8_t> bytes;
  std::size_t pos = 0;
  int bit() {
    const int b = (bytes.at(pos / 8) >> (7 - pos % 8)) & 1;
    ++pos;
    return b;
  }
  unsigned ue() {
    int zeros = 0;
    while (bit() == 0) ++zeros;
    unsigned v = 1;
    for (int i = 0; i < zeros; ++i) v = (v << 1) | bit();
    return v - 1;
  }
};

struct SpsInfo {
  int profile = -1, chroma_format = -1, bit_depth_luma = -1;
};

// The first SPS of an MP4's avcC box (ISO 14496-15): profile, chroma format (1 = 4:2:0) and luma
// bit depth.
SpsInfo sps_of_mp4(const std::string& file) {
  const std::size_t at = file.find("avcC");
  if (at == std::string::npos) return {};
  const auto* p = reinterpret_cast<const std::uint8_t*>(file.data()) + at + 4;
  const int sps_length = (p[6] << 8) | p[7];
  const std::uint8_t* nal = p + 8;
  Bits rbsp;
  for (int i = 1; i < sps_length; ++i) {  // skip the NAL header, drop emulation prevention bytes
    if (i >= 3 && nal[i] == 3 && nal[i - 1] == 0 && nal[i - 2] == 0) continue;
    rbsp.bytes.push_back(nal[i]);
  }
  SpsInfo info;
  info.profile = rbsp.bytes.at(0);
  rbsp.pos = 24;                                    // profile_idc, constraint flags, level_idc
  rbsp.ue();                                        // seq_parameter_set_id
  info.chroma_format = 1, info.bit_depth_luma = 8;  // implied below the High profiles
  if (info.profile == 100 || info.profile == 110 || info.profile == 122 || info.profile == 244) {
    info.chroma_format = int(rbsp.ue());
    if (info.chroma_format == 3) rbsp.bit();
    info.bit_depth_luma = 8 + int(rbsp.ue());
  }
  return info;
}

TEST(FrameWriter, Mp4IsH264Yuv420FromLibx264AndDecodesClose) {
  TempDir dir;
  const fs::path mp4 = dir / "clip.mp4";
  write_video(mp4, 64, 48, 6, 12.5);
  const std::string bytes = test::read_text(mp4);
  // libx264 signs its stream with its settings (an SEI message): the encoder was libx264.
  EXPECT_NE(bytes.find("x264 - core"), std::string::npos);
  const SpsInfo sps = sps_of_mp4(bytes);
  EXPECT_EQ(sps.chroma_format, 1) << "profile " << sps.profile;  // 4:2:0
  EXPECT_EQ(sps.bit_depth_luma, 8);

  cv::VideoCapture cap(mp4.string(), cv::CAP_FFMPEG);
  ASSERT_TRUE(cap.isOpened());
  EXPECT_EQ(fourcc_text(cap.get(cv::CAP_PROP_FOURCC)), "avc1");
  EXPECT_NEAR(cap.get(cv::CAP_PROP_FPS), 12.5, 1e-6);
  EXPECT_EQ(fourcc_text(cap.get(cv::CAP_PROP_CODEC_PIXEL_FORMAT)), "I420");  // yuv420p
  int frames = 0;
  for (cv::Mat bgr; cap.read(bgr); ++frames) {
    ASSERT_EQ(bgr.cols, 64);
    ASSERT_EQ(bgr.rows, 48);
    // x264 at CRF 23 gives about 34 dB here; the frame before or after is under 25 dB.
    EXPECT_GT(psnr(bgr, moving_frame(64, 48, frames)), 30.0) << "frame " << frames;
    EXPECT_LT(psnr(bgr, moving_frame(64, 48, frames + 1)), 25.0) << "frame " << frames;
  }
  EXPECT_EQ(frames, 6);
}

TEST(FrameWriter, MovAndMkvAreH264Too) {
  TempDir dir;
  for (const char* name : {"clip.mov", "clip.mkv"}) {
    write_video(dir / name, 64, 48, 3, 24);
    EXPECT_NE(test::read_text(dir / name).find("x264 - core"), std::string::npos) << name;
    cv::VideoCapture cap((dir / name).string(), cv::CAP_FFMPEG);
    ASSERT_TRUE(cap.isOpened()) << name;
    const std::string codec = fourcc_text(cap.get(cv::CAP_PROP_FOURCC));
    EXPECT_TRUE(codec == "avc1" || codec == "h264" || codec == "H264") << name << ": " << codec;
    cv::Mat bgr;
    ASSERT_TRUE(cap.read(bgr)) << name;
    EXPECT_GT(psnr(bgr, moving_frame(64, 48, 0)), 30.0) << name;
  }
}

TEST(FrameWriter, AviIsMotionJpeg) {
  TempDir dir;
  write_video(dir / "clip.avi", 64, 48, 3, 24);
  cv::VideoCapture cap((dir / "clip.avi").string(), cv::CAP_FFMPEG);
  ASSERT_TRUE(cap.isOpened());
  EXPECT_EQ(fourcc_text(cap.get(cv::CAP_PROP_FOURCC)), "MJPG");
  cv::Mat bgr;
  ASSERT_TRUE(cap.read(bgr));
  EXPECT_EQ(bgr.cols, 64);
  EXPECT_EQ(bgr.rows, 48);
  EXPECT_GT(psnr(bgr, moving_frame(64, 48, 0)), 30.0);
}

// The CRF (--crf) trades size for quality: CRF 0 (lossless coding of the 4:2:0 frames) is far
// larger and decodes far closer to the frames than the default 23, and 23 than 40 (on these
// frames about 45, 37 and 28 dB; 57, 4.3 and 2.6 KB). x264 signs each file with the rate control
// it used.
TEST(FrameWriter, CrfTradesSizeForQuality) {
  TempDir dir;
  struct Result {
    std::uintmax_t bytes = 0;
    double psnr = 0;
  };
  std::vector<Result> results;
  for (const std::optional<int> crf :
       {std::optional<int>(0), std::optional<int>(), std::optional<int>(40)}) {
    const fs::path mp4 = dir / fmt::format("crf{}.mp4", crf.value_or(kDefaultCrf));
    write_video(mp4, 128, 96, 12, 24, crf, textured_frame);
    const std::string bytes = test::read_text(mp4);
    // x264 codes CRF 0 as constant QP 0, its lossless mode.
    EXPECT_NE(
        bytes.find(crf == 0 ? "rc=cqp" : fmt::format("rc=crf mbtree=1 crf={}.0", crf.value_or(23))),
        std::string::npos)
        << mp4;
    const auto [psnr_db, frames] = video_psnr(mp4, 128, 96, textured_frame);
    EXPECT_EQ(frames, 12) << mp4;
    results.push_back({fs::file_size(mp4), psnr_db});
  }
  const Result lossless = results[0], standard = results[1], coarse = results[2];
  EXPECT_GT(lossless.bytes, 5 * standard.bytes);
  EXPECT_GT(standard.bytes, 1.3 * double(coarse.bytes));
  EXPECT_GT(lossless.psnr, 43.0);  // what 4:2:0 and 8-bit YUV alone lose
  EXPECT_GT(lossless.psnr, standard.psnr + 5);
  EXPECT_GT(standard.psnr, coarse.psnr + 5);
}

// H.264 needs the ffmpeg program: without it on PATH, an H.264 output is refused when the writer
// is made, in words that say what to install or write instead; Motion-JPEG and PNGs (OpenCV,
// libpng) are written as before.
TEST(FrameWriter, H264WithoutFfmpegIsRefusedUpFront) {
  TempDir dir;
  fs::create_directories(dir / "empty-bin");
  const ScopedEnv path("PATH", (dir / "empty-bin").string());
  for (const char* name : {"v.mp4", "v.mov", "v.mkv"})
    expect_error([&] { FrameWriter(dir / name, 2, 24); },
                 {name, "ffmpeg program", "not on PATH", "Debian package ffmpeg", "PNGs"});
  EXPECT_FALSE(fs::exists(dir / "v.mp4"));
  write_video(dir / "clip.avi", 64, 48, 2, 24);
  write_video(dir / "frames/", 8, 6, 2, 24);
  EXPECT_TRUE(fs::exists(dir / "clip.avi"));
  EXPECT_TRUE(fs::exists(dir / "frames" / "00001.png"));
}

// A failing ffmpeg (here a stand-in that fails as ffmpeg does, at once, after reading a little,
// by a signal, or with status 0 and an error) is one error naming the output, how it ended, its
// first error line (the output named as the user did, not its temporary) and its log, which is
// kept; the half-written video is not.
TEST(FrameWriter, AFailingFfmpegLeavesNoVideoAndKeepsItsLog) {
  TempDir dir;
  struct Case {
    std::string script, how, line;
  };
  for (const Case& c : {
           Case{"echo \"[libx264 @ 0x1] broken encoder\" >&2; echo 'Conversion failed!' >&2; "
                "exit 1",
                "(exit status 1)", "[libx264 @ 0x1] broken encoder"},
           Case{"head -c 1000 >/dev/null; echo 'av_interleaved_write_frame(): I/O error' >&2; "
                "exit 3",
                "(exit status 3)", "av_interleaved_write_frame(): I/O error"},
           Case{"kill -SEGV $$", "(ended by signal 11", "(no output)"},
           // ffmpeg 5.1 exits with 0 when its trailer cannot be written, and says so.
           Case{"cat >/dev/null; for last; do :; done; "
                "echo \"Error writing trailer of $last: Input/output error\" >&2",
                "(exit status 0, after an error)",
                "Error writing trailer of " + (dir / "out" / "v.mp4").string() +
                    ": Input/output error"},
       }) {
    const ScopedEnv path("PATH",
                         fake_ffmpeg(dir / "bin", c.script).string() + ":" + std::getenv("PATH"));
    const fs::path out = dir / "out" / "v.mp4";
    std::string message;
    {
      // 512x384 frames: more than the socket holds, so that the stop shows in write() too.
      FrameWriter writer(out, 4, 24);
      message = test::message_of([&] {
        for (int k = 0; k < 4; ++k) writer.write(moving_frame(512, 384, k));
        writer.finish();
      });
    }
    EXPECT_NE(message.find(out.string() + ": ffmpeg failed " + c.how), std::string::npos)
        << message;
    EXPECT_NE(message.find(c.line), std::string::npos) << message;
    EXPECT_NE(message.find("write PNGs"), std::string::npos) << message;
    const fs::path log = named_log(message);
    ASSERT_FALSE(log.empty()) << message;
    // The log as ffmpeg wrote it (the temporary's name in it).
    EXPECT_NE(test::read_text(log).find(c.line == "(no output)" ? "" : c.line.substr(0, 20)),
              std::string::npos);
    EXPECT_EQ(message.find(".tmp"), std::string::npos) << message;
    fs::remove(log);
    EXPECT_TRUE(fs::is_empty(dir / "out")) << c.script;
  }
}

// A video cut short by a file-size limit is named as every writer names it, whether ffmpeg failed
// mid-stream or, writing its trailer, said so and exited with status 0 (ffmpeg 5.1 does); its log
// is not kept, as the message does not name it.
TEST(FrameWriter, AVideoCutShortByAFileSizeLimitIsNamedSo) {
  TempDir dir;
  fs::create_directories(dir / "tmp");
  const ScopedEnv tmpdir("TMPDIR", (dir / "tmp").string());
  write_video(dir / "whole.mp4", 128, 96, 12, 24, std::nullopt, textured_frame);
  const std::uintmax_t whole = fs::file_size(dir / "whole.mp4");
  // Mid-stream: lossless frames pass the limit long before the end. The trailer: an MP4's index
  // is its last box, so a limit a little below the whole file cuts it there.
  for (const auto& entry : {std::pair{0, std::uintmax_t(16384)}, {23, whole - 64}}) {
    const int crf = entry.first;  // a plain variable: clang 14 cannot capture a structured binding
    const std::uintmax_t limit = entry.second;
    std::string message;
    {
      const ScopedFileSizeLimit limited(limit);
      message = test::message_of(
          [&] { write_video(dir / "out" / "v.mp4", 128, 96, 12, 24, crf, textured_frame); });
    }
    EXPECT_NE(message.find("v.mp4: cannot write the video file: File too large"), std::string::npos)
        << "CRF " << crf << ": " << message;
    EXPECT_TRUE(fs::is_empty(dir / "out")) << crf;
    EXPECT_TRUE(fs::is_empty(dir / "tmp")) << crf;  // no log left
  }
}

// A writer dropped before finish() (an error or Ctrl-C while rendering) ends its ffmpeg and
// leaves no file: the process is gone once the writer is.
TEST(FrameWriter, AnAbandonedVideoEndsItsFfmpeg) {
  TempDir dir;
  {
    // The real encoder, half-way through.
    FrameWriter writer(dir / "out" / "half.mp4", 4, 24);
    writer.write(moving_frame(64, 48, 0));
    writer.write(moving_frame(64, 48, 1));
  }
  EXPECT_TRUE(fs::is_empty(dir / "out"));
  // A stand-in that says who it is and reads on until its input ends.
  const ScopedEnv path("PATH", fake_ffmpeg(dir / "bin", "echo $$ > " + (dir / "pid").string() +
                                                            "; exec cat >/dev/null")
                                       .string() +
                                   ":" + std::getenv("PATH"));
  {
    FrameWriter writer(dir / "out" / "half.mp4", 4, 24);
    writer.write(moving_frame(64, 48, 0));
    for (int wait = 0; wait < 500 && test::read_text(dir / "pid").empty(); ++wait) ::usleep(10000);
  }
  const pid_t pid = std::stoi(test::read_text(dir / "pid"));
  EXPECT_EQ(::kill(pid, 0), -1);
  EXPECT_EQ(errno, ESRCH) << "ffmpeg " << pid << " still runs";
  EXPECT_TRUE(fs::is_empty(dir / "out"));
}

TEST(FrameWriter, VideosRefuseAnOddSizeAndLeaveNothing) {
  TempDir dir;
  for (const char* name : {"odd.mp4", "odd.avi"}) {
    FrameWriter writer(dir / name, 2, 24);
    expect_error([&] { writer.write(moving_frame(64, 47, 0)); }, {name, "even", "64x47"});
  }
  {
    FrameWriter writer(dir / "changes.mp4", 2, 24);
    writer.write(moving_frame(64, 48, 0));
    expect_error([&] { writer.write(moving_frame(32, 24, 1)); }, {"changes.mp4", "32x24"});
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(FrameWriter, AlphaPngsHoldStraightRgbaCodes) {
  TempDir dir;
  Image rgba(3, 2, 4);
  for (std::size_t i = 0; i < rgba.data.size(); ++i) rgba.data[i] = float(i * 37 % 256) / 255.0f;
  rgba.at(0, 0, 3) = 0.0f;  // a transparent pixel keeps its colour codes
  for (const int bits : {8, 16}) {
    const fs::path png = dir / fmt::format("one{}.png", bits);
    FrameWriter writer(png, 1, options(0, true, bits));
    EXPECT_TRUE(writer.alpha());
    writer.write(rgba);
    writer.finish();
    const cv::Mat read = cv::imread(png.string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(read.type(), bits == 8 ? CV_8UC4 : CV_16UC4);
    const double max_code = bits == 8 ? 255.0 : 65535.0;
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 3; ++x)
        for (int c = 0; c < 4; ++c) {
          const int bgra = c == 3 ? 3 : 2 - c;
          const double code =
              bits == 8 ? read.at<cv::Vec4b>(y, x)[bgra] : read.at<Rgba16>(y, x)[bgra];
          EXPECT_EQ(code, std::round(rgba.at(y, x, c) * max_code)) << x << "," << y << "," << c;
        }
  }
  // A folder of RGBA frames.
  FrameWriter folder(dir / "seq/", 2, options(0, true));
  folder.write(rgba);
  folder.write(rgba);
  folder.finish();
  EXPECT_EQ(cv::imread((dir / "seq" / "00001.png").string(), cv::IMREAD_UNCHANGED).type(), CV_8UC4);
}

TEST(FrameWriter, SixteenBitPngsKeepEveryCode) {
  TempDir dir;
  Image rgb(4, 3, 3);
  for (std::size_t i = 0; i < rgb.data.size(); ++i)
    rgb.data[i] = float((i * 7919 + 1) % 65536) / 65535.0f;  // not multiples of 257 (8-bit codes)
  FrameWriter writer(dir / "deep", 1, options(0, false, 16));
  writer.write(rgb);
  writer.finish();
  const cv::Mat read = cv::imread((dir / "deep" / "00000.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(read.type(), CV_16UC3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x)
      for (int c = 0; c < 3; ++c)
        EXPECT_EQ(read.at<Rgb16>(y, x)[2 - c], std::lround(rgb.at(y, x, c) * 65535.0))
            << x << "," << y << "," << c;
}

TEST(FrameWriter, AFolderGetsItsFramesTimes) {
  TempDir dir;
  const std::vector<double> times = {0.0, 0.1, 1.0 / 3.0, 2.5};
  FrameWriter writer(dir / "frames", 4, options(0, false, 8, times));
  for (int k = 0; k < 4; ++k) writer.write(moving_frame(8, 6, k));
  writer.finish();
  const std::string csv = test::read_text(dir / "frames" / "times.csv");
  EXPECT_EQ(csv, "frame,time\n0,0\n1,0.1\n2,0.3333333333333333\n3,2.5\n");
  EXPECT_EQ(std::stod(csv.substr(csv.find("\n2,") + 3)), 1.0 / 3.0);  // reads back exactly
  EXPECT_TRUE(fs::exists(dir / "frames" / "00003.png"));
  // Without times there is no times.csv.
  write_video(dir / "plain/", 8, 6, 1, 24);
  EXPECT_TRUE(fs::exists(dir / "plain" / "00000.png"));
  EXPECT_FALSE(fs::exists(dir / "plain" / "times.csv"));
  expect_error(
      [&] {
        write_times_csv(dir / "bad.csv", {0.0, std::nan("")});
      },
      {"bad.csv", "frame 1"});
  EXPECT_FALSE(fs::exists(dir / "bad.csv"));
}

// An EXR plate as a compositor reads it: half or float as asked, values unclamped, alpha
// premultiplied (EXR's convention); a folder of EXRs with the precision set.
TEST(FrameWriter, ExrHoldsUnclampedPremultipliedRgbaAtTheAskedPrecision) {
  if (!can_write_exr()) GTEST_SKIP() << "this OpenCV build writes no OpenEXR";
  ::setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 1);  // OpenCV reads EXR only when asked to
  TempDir dir;
  Image rgba(3, 2, 4);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) {
      for (int c = 0; c < 3; ++c) rgba.at(y, x, c) = 0.1f + float(6 * y + 3 * x + c) / 5.0f;
      rgba.at(y, x, 3) = float(x + 3 * y) / 5.0f;  // 0 to 1
    }
  rgba.at(0, 0, 0) = 1.0f / 3.0f;  // not a half: float keeps it, half rounds it
  rgba.at(0, 0, 3) = 1.0f;
  for (const ExrPrecision precision : {ExrPrecision::kHalf, ExrPrecision::kFloat}) {
    const bool float32 = precision == ExrPrecision::kFloat;
    const fs::path path = dir / (float32 ? "float.exr" : "half.exr");
    FrameWriterOptions o = options(0, true);
    o.exr = precision;
    FrameWriter writer(path, 1, o);
    writer.write(rgba);
    writer.finish();
    const cv::Mat read = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(read.type(), CV_32FC4) << path;
    const double tolerance = float32 ? 1e-7 : 2e-3;  // half: 11 significant bits
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 3; ++x)
        for (int c = 0; c < 4; ++c) {
          const double alpha = c == 3 ? 1.0 : rgba.at(y, x, 3);
          const double expected = rgba.at(y, x, c) * alpha;  // above 1 where the image is
          EXPECT_NEAR(read.at<cv::Vec4f>(y, x)[c == 3 ? 3 : 2 - c], expected,
                      tolerance * std::max(1.0, expected))
              << path << " " << x << "," << y << "," << c;
        }
    EXPECT_EQ(read.at<cv::Vec4f>(0, 0)[2] == 1.0f / 3.0f, float32) << path;
  }
  FrameWriterOptions o = options(0, false, 8, {0.0, 0.5});
  o.exr = ExrPrecision::kFloat;
  FrameWriter folder(dir / "plates", 2, o);
  folder.write(moving_frame(8, 6, 0));
  folder.write(moving_frame(8, 6, 1));
  folder.finish();
  EXPECT_EQ(cv::imread((dir / "plates" / "00001.exr").string(), cv::IMREAD_UNCHANGED).type(),
            CV_32FC3);
  EXPECT_TRUE(fs::exists(dir / "plates" / "times.csv"));
}

// A depth pass beside each EXR frame, named by depth_path: one 32-bit float channel whatever the
// frames' precision (a half would round 1/3 and overflow at 1e10), values as given.
TEST(FrameWriter, DepthPassIsOneFloatChannelBesideEachExrFrame) {
  if (!can_write_exr()) GTEST_SKIP() << "this OpenCV build writes no OpenEXR";
  ::setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 1);  // OpenCV reads EXR only when asked to
  TempDir dir;
  Image depth(4, 3, 1, 1.0f / 3.0f);
  depth.at(2, 3) = 1e10f;
  const auto expect_depth = [&](const fs::path& path) {
    const cv::Mat read = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(read.type(), CV_32FC1) << path;
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 4; ++x) EXPECT_EQ(read.at<float>(y, x), depth.at(y, x)) << path;
  };
  EXPECT_EQ(depth_path("a/00012.exr"), fs::path("a/00012.depth.exr"));
  FrameWriterOptions o = options(0, true);
  o.depth = true;
  FrameWriter one(dir / "plate.exr", 1, o);  // half frames
  one.write(Image(4, 3, 4, 0.5f), &depth);
  one.finish();
  expect_depth(dir / "plate.depth.exr");
  EXPECT_EQ(cv::imread((dir / "plate.exr").string(), cv::IMREAD_UNCHANGED).type(), CV_32FC4);
  o.alpha = false;
  o.exr = ExrPrecision::kHalf;
  FrameWriter folder(dir / "plates", 2, o);
  folder.write(Image(4, 3, 3), &depth);
  folder.write(Image(4, 3, 3), &depth);
  folder.finish();
  expect_depth(dir / "plates" / "00000.depth.exr");
  expect_depth(dir / "plates" / "00001.depth.exr");
  EXPECT_TRUE(fs::exists(dir / "plates" / "00001.exr"));
  // An existing x.depth.exr is an output like x.exr: replaced only with force.
  fs::remove(dir / "plate.exr");
  expect_error([&] { FrameWriter(dir / "plate.exr", 1, o); }, {"plate.depth.exr"});
}

// A one-frame x.exr and its x.depth.exr appear together or not at all: when the frame cannot be
// moved into place (another writer's x.exr appeared meanwhile; with --force, a folder stands
// there), no depth pass is left behind, nor any temporary.
TEST(FrameWriter, AnExrFrameAndItsDepthPassAppearTogether) {
  if (!can_write_exr()) GTEST_SKIP() << "this OpenCV build writes no OpenEXR";
  TempDir dir;
  const Image depth(4, 3, 1, 2.0f);
  FrameWriterOptions o = options();
  o.depth = true;
  {
    FrameWriter writer(dir / "plate.exr", 1, o);
    test::write_text(dir / "plate.exr", "another writer's");
    expect_error([&] { writer.write(Image(4, 3, 3, 0.5f), &depth); },
                 {"plate.exr", "already exists"});
  }
  EXPECT_FALSE(fs::exists(dir / "plate.depth.exr"));
  EXPECT_EQ(test::read_text(dir / "plate.exr"), "another writer's");
  o.force = true;
  fs::create_directories(dir / "held.exr" / "inside");
  {
    FrameWriter writer(dir / "held.exr", 1, o);
    expect_error([&] { writer.write(Image(4, 3, 3, 0.5f), &depth); }, {"held.exr"});
  }
  EXPECT_FALSE(fs::exists(dir / "held.depth.exr"));
  std::vector<std::string> left;
  for (const auto& entry : fs::directory_iterator(dir.path()))
    left.push_back(entry.path().filename().string());
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, (std::vector<std::string>{"held.exr", "plate.exr"}));
  // Written, the pair is there.
  {
    FrameWriter writer(dir / "both.exr", 1, o);
    writer.write(Image(4, 3, 3, 0.5f), &depth);
    writer.finish();
  }
  EXPECT_TRUE(fs::exists(dir / "both.exr"));
  EXPECT_TRUE(fs::exists(dir / "both.depth.exr"));
}

TEST(FrameWriter, RefusesOptionsThatDoNotFitTheOutput) {
  TempDir dir;
  expect_error([&] { FrameWriter(dir / "v.mp4", 2, options(24, true)); },
               {"v.mp4", "alpha", "--alpha"});
  expect_error([&] { FrameWriter(dir / "v.mov", 2, options(24, false, 16)); },
               {"v.mov", "--bit-depth", "16"});
  expect_error([&] { FrameWriter(dir / "v.png", 1, options(0, false, 12)); }, {"v.png", "12"});
  expect_error([&] { FrameWriter(dir / "v.mp4", 2, options(0)); }, {"v.mp4", "frame rate"});
  expect_error([&] { FrameWriter(dir / "f", 2, options(0, false, 8, {0.0})); },
               {"1 frame times for 2 frames"});
  expect_error([&] { FrameWriter(dir / "v.tif", 1, options()); }, {"'.tif'"});
  FrameWriterOptions exr = options(24);
  exr.exr = ExrPrecision::kHalf;
  expect_error([&] { FrameWriter(dir / "v.mp4", 2, exr); }, {"v.mp4", "not EXR"});
  expect_error([&] { FrameWriter(dir / "v.png", 1, exr); }, {"v.png", "x.exr"});
  FrameWriterOptions depth = options(24);
  depth.depth = true;
  for (const std::string name : {"v.mp4", "v.png", "pngs/"})
    expect_error([&] { FrameWriter(dir / name, name == "v.png" ? 1 : 2, depth); },
                 {name.substr(0, 4), "--depth", "x.exr"});
  exr.depth = true;
  expect_error([&] { FrameWriter(dir / "v.avi", 2, exr); }, {"v.avi", "not EXR"});
  // A CRF is H.264's alone, within libx264's range.
  for (const int crf : {-1, 52}) {
    FrameWriterOptions o = options(24);
    o.crf = crf;
    expect_error([&] { FrameWriter(dir / "v.mp4", 2, o); },
                 {"v.mp4", fmt::format("--crf {}", crf), "0 to 51"});
  }
  for (const std::string name : {"v.avi", "v.png", "v.exr", "pngs/", "v.mp4/"}) {
    FrameWriterOptions o = options(24);
    o.crf = 18;
    if (name == "v.exr" && !can_write_exr()) continue;
    expect_error([&] { FrameWriter(dir / name, name == "v.png" || name == "v.exr" ? 1 : 2, o); },
                 {name.substr(0, 4), "--crf", "H.264"});
  }
  {
    FrameWriter rgba(dir / "a.png", 1, options(0, true));
    expect_error([&] { rgba.write(moving_frame(4, 4, 0)); }, {"a.png", "4 channels"});
    FrameWriter rgb(dir / "b.png", 1, options());
    expect_error([&] { rgb.write(Image(4, 4, 4)); }, {"b.png", "3 channels"});
  }
  if (can_write_exr()) {
    FrameWriterOptions o = options();
    o.depth = true;
    FrameWriter with(dir / "c.exr", 1, o);
    expect_error([&] { with.write(Image(4, 4, 3)); }, {"c.exr", "lacks a depth pass"});
    const Image wrong(4, 3, 1);
    expect_error([&] { with.write(Image(4, 4, 3), &wrong); }, {"c.exr", "depth pass 4x3x1"});
    FrameWriter without(dir / "d.exr", 1, options());
    expect_error([&] { without.write(Image(4, 4, 3), &wrong); }, {"d.exr", "has a depth pass"});
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

}  // namespace
}  // namespace retimegs::media
