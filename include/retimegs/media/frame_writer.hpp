#pragma once
// Where rendered frames go, chosen by the output path:
//   x.png                  exactly one frame
//   x.exr                  exactly one frame as OpenEXR (write_exr: half or float, unclamped)
//   x.mp4, x.mov, x.mkv    H.264 video (libx264 through the ffmpeg program, ffmpeg_video.hpp;
//                          8-bit yuv420p at a constant quality, CRF 23 unless set): what
//                          browsers, players and editors open
//   x.avi                  Motion-JPEG video (every frame a JPEG, 4:2:0): intra-only frames for
//                          tools that scrub or cut frame by frame
// Both videos halve the chroma in each direction, so their frames must have an even width and
// height: an odd size is refused (the encoders would drop the last column and row).
//   x/, or no extension    a folder of <frame:05d>.png (frame 0 first), or .exr with an EXR
//                          precision set, with times.csv (write_times_csv) when the frames' times
//                          are given
// Any other extension (x.jpg) is an error rather than a folder of that name. PNG outputs hold 8- or
// 16-bit RGB, or RGBA with straight (unassociated) alpha as PNG defines it; EXR outputs RGB or RGBA
// with premultiplied alpha as EXR defines it; videos hold 8-bit RGB.
// EXR outputs may carry a depth pass (render/depth.hpp): one 32-bit float channel per frame,
// written beside it as depth_path(frame) (x.depth.exr, 00012.depth.exr); PNGs and videos cannot.
// Every kind appears atomically when finish() is called; an unfinished writer leaves nothing
// behind.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/image.hpp"

namespace retimegs::media {

enum class ExrPrecision { kHalf, kFloat };

struct FrameWriterOptions {
  double fps = 0;      // frame rate of a video, finite and > 0; PNG outputs ignore it
  bool alpha = false;  // image outputs only: write() takes RGBA, written with its alpha
  int bit_depth = 8;   // PNG outputs: 8 or 16 bits per channel; videos are 8-bit only
  // EXR outputs: half or 32-bit float per channel. Set, a folder holds EXR frames; an x.exr
  // output without it is half.
  std::optional<ExrPrecision> exr;
  std::vector<double> times;  // scene time of each frame (empty: unknown): a folder's times.csv
  // EXR outputs only: write() also takes each frame's depth pass, written as float EXR at
  // depth_path(frame) (so an x.exr output also claims x.depth.exr, --force and all).
  bool depth = false;
  // H.264 outputs only: libx264's constant rate factor, kMinCrf to kMaxCrf (0 lossless; unset:
  // kDefaultCrf, 23).
  std::optional<int> crf;
  bool force = false;  // replace an existing output folder or file
};

class FrameWriter {
 public:
  // `frames`: how many will be written (checked; so is times.size() when times are given). Throws
  // Error naming the output when the options do not fit its kind (alpha or 16 bits for a video,
  // EXR where this build cannot write it, a depth pass for PNGs or a video, a CRF for anything
  // but H.264 or outside its range), or when H.264 is asked for and ffmpeg is not installed.
  FrameWriter(std::filesystem::path out, int frames, const FrameWriterOptions& options);
  FrameWriter(std::filesystem::path out, int frames, double fps, bool force = false);
  ~FrameWriter();
  FrameWriter(const FrameWriter&) = delete;
  FrameWriter& operator=(const FrameWriter&) = delete;

  // Whether write() takes RGBA (options.alpha) rather than RGB.
  bool alpha() const { return options_.alpha; }
  // Whether write() takes a depth pass (options.depth).
  bool depth() const { return options_.depth; }
  // Values in [0, 1], clamped: RGB, or RGBA with straight alpha when alpha(). Every frame of a
  // video has the first one's size. `depth` [H, W, 1], the image's size, given exactly when
  // depth(); written as it is.
  void write(const Image& image, const Image* depth = nullptr);
  void finish();

 private:
  enum class Kind { kImage, kVideo, kFolder };
  // An image file (PNG or EXR by the options), and its depth pass when given; an existing `path`
  // replaced only with `replace`.
  void write_image(const std::filesystem::path& path, const Image& image, const Image* depth,
                   bool replace) const;
  struct Video;
  std::filesystem::path out_;
  Kind kind_;
  int frames_, written_ = 0;
  FrameWriterOptions options_;
  std::unique_ptr<AtomicFile> file_;
  std::unique_ptr<AtomicDirectory> folder_;
  std::unique_ptr<Video> video_;
};

// Where the depth pass of the frame file `frame` goes: beside it, `<stem>.depth.exr`.
std::filesystem::path depth_path(const std::filesystem::path& frame);

// The times of a sequence of frames, as render (a folder output) and export (--times) write them
// beside the frames: CSV with the header `frame,time`, then per frame its index k (the k of the
// file <k:05d>.png / .ply) and its time in scene frame units, printed in the shortest form that
// reads back as the same double. Written atomically; throws Error naming `path` on a non-finite
// time or a failed write.
void write_times_csv(const std::filesystem::path& path, const std::vector<double>& times);

// A keyframe of a time remap: output frame `output_frame` shows scene time `t`.
struct RetimeKey {
  int output_frame = 0;
  double t = 0;
};

// A speed-ramp file: CSV rows `output_frame,t` in increasing output_frame order (a header line and
// blank lines are allowed), the keyframes of a time remap (playback::ramp_times gives the time of
// every output frame). Returns at least one keyframe; throws Error naming the file and line.
std::vector<RetimeKey> read_retime_csv(const std::filesystem::path& path);

}  // namespace retimegs::media
