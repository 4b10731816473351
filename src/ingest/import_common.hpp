#pragma once
// Pieces the importers share (import_*.cpp): JSON number checks, downscaling, undistortion into a
// pinhole camera, and the parallel write loop with its progress bar.
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/core/progress.hpp"
#include "retimegs/ingest/import.hpp"
#include "retimegs/io/colmap.hpp"

namespace retimegs::ingest::detail {

// v as a finite double; throws Error "<file>: '<field>' must be a finite number, got <v>".
double finite_number(const nlohmann::json& v, const std::string& file, const std::string& field);

// The first and last source frame that --frames selects out of `steps` (last_frame < 0: to the
// end); throws "--frames: A:B is outside the frames 0:N of <what>".
std::pair<int, int> frame_range(const ImportOptions& options, int steps, const std::string& what);

// An 8-bit BGR / BGRA / grey OpenCV image -> RGB Image in [0, 1].
Image from_bgr8(const cv::Mat& mat);

// Resampling of a distorted COLMAP camera into a pinhole camera of the same size. The new focal
// length is the smallest that leaves no pixel outside the source image (OpenCV's
// getOptimalNewCameraMatrix with alpha 0), with the principal point kept; pinhole models pass
// through unchanged.
class Undistorter {
 public:
  // `what` names the source in errors (file and camera). Supports SIMPLE_PINHOLE, PINHOLE,
  // SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV and OPENCV_FISHEYE.
  Undistorter(const io::ColmapCamera& source, const std::string& what);
  bool identity() const { return identity_; }
  // Intrinsics and size of the output (name, pose and split are the caller's).
  const Camera& pinhole() const { return pinhole_; }
  // Resamples an image of the source camera's size (bilinear).
  Image apply(const Image& image) const;
  // Pixel coordinates (continuous, +0.5 centres) in the source image of a normalised pinhole ray
  // (x/z, y/z): the COLMAP projection with distortion.
  Eigen::Vector2d distort_project(double x, double y) const;

 private:
  io::ColmapCamera source_;
  Camera pinhole_;
  bool identity_ = true;
  cv::Mat map_x_, map_y_;  // [H, W] float source coordinates, OpenCV convention (centres at .0)
};

// A video's header as OpenCV's FFmpeg backend reports it. `frames` is the container's count,
// which some containers only estimate: decoding checks it frame by frame.
struct VideoInfo {
  std::filesystem::path path;
  int width = 0, height = 0, frames = 0;
  double fps = 0;
};

// Opens a video, reads its header and decodes its first frame; one error naming the file when
// OpenCV cannot.
VideoInfo probe_video(const std::filesystem::path& path);

// Decodes `video` up to source frame `last` (grabbing the ones before `first` undecoded) and
// calls use(image, k) for k in first..last; one error naming the file and the frame when a frame
// cannot be decoded or has another size than the header says.
void decode_video(const VideoInfo& video, int first, int last,
                  const std::function<void(const Image&, int)>& use);

// Runs job(i, progress) for i in [0, count) in parallel under a progress bar of `ticks` steps
// (the jobs tick it); errors as in parallel_for (core/parallel.hpp): the first is rethrown.
void parallel_jobs(std::size_t count, std::size_t ticks, const std::string& label, bool progress,
                   const std::function<void(std::size_t, Progress&)>& job);

// "Up" of a set of cameras: the normalised mean of their -y axes in world space (OpenCV cameras
// have y down), the convention of LLFF / nerfstudio re-centring.
Eigen::Vector3d mean_camera_up(const std::vector<Camera>& cameras);

}  // namespace retimegs::ingest::detail
