// Neural3DV / DyNeRF (poses_bounds.npy + camNN.mp4) -> scene format.
//
// LLFF convention (LLFF imgs2poses.py, read by NeRF's load_llff.py as
// `[poses[:, 1:2], -poses[:, 0:1], poses[:, 2:]]` "[-u, r, -t] -> [r, u, -t]"): the columns of
// the 3x3 block are the camera's down, right and backward axes in world space. OpenCV's
// (right, down, forward) camera-to-world is therefore (col1, col0, -col2), with the same centre.
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "import_common.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/ingest/import.hpp"
#include "retimegs/io/npy.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/resize.hpp"

namespace retimegs::ingest {
namespace fs = std::filesystem;

namespace {

constexpr int kPoseColumns = 17;  // 3x5 matrix + near + far

}  // namespace

void import_n3dv(const fs::path& source, const fs::path& out, const ImportOptions& options) {
  if (!fs::is_directory(source))
    fail("{}: Neural3DV source folder does not exist", source.string());
  check_downscale(options.downscale);

  const fs::path poses_path = source / "poses_bounds.npy";
  const std::string poses_file = poses_path.string();
  const io::NpyArray poses = io::read_npy(poses_path);  // [N, 17]
  if (poses.shape.size() != 2 || poses.shape[1] != kPoseColumns || poses.shape[0] < 1)
    fail("{}: expected shape [N, {}] (3x5 pose + near, far per camera), got [{}]", poses_file,
         kPoseColumns, fmt::join(poses.shape, ", "));
  const int count = int(poses.shape[0]);
  for (std::size_t i = 0; i < poses.values.size(); ++i)
    if (!std::isfinite(poses.values[i]))
      fail("{}: value [{}][{}] is not finite", poses_file, i / kPoseColumns, i % kPoseColumns);

  std::vector<fs::path> videos;
  for (const auto& entry : fs::directory_iterator(source)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_regular_file() && name.rfind("cam", 0) == 0 && entry.path().extension() == ".mp4")
      videos.push_back(entry.path());
  }
  std::sort(videos.begin(), videos.end());

  // Every row is checked before any video is opened (and before the video count, so that a bad
  // row is named even when videos are missing).
  struct Pose {
    Eigen::Matrix4d c2w = Eigen::Matrix4d::Identity();  // OpenCV axes
    double h = 0, w = 0, f = 0;
  };
  std::vector<Pose> llff(count);
  for (int c = 0; c < count; ++c) {
    const double* row = &poses.values[std::size_t(c) * kPoseColumns];
    auto m = [&](int r, int col) { return row[r * 5 + col]; };  // the 3x5 LLFF matrix
    const std::string where = c < int(videos.size()) ? fmt::format("{}: row {} ({})", poses_file, c,
                                                                   videos[c].filename().string())
                                                     : fmt::format("{}: row {}", poses_file, c);
    Pose& pose = llff[c];
    pose.h = m(0, 4), pose.w = m(1, 4), pose.f = m(2, 4);
    if (!(pose.h > 0 && pose.w > 0 && pose.f > 0))
      fail("{}: (h, w, f) = ({}, {}, {}) must be positive", where, pose.h, pose.w, pose.f);
    for (int r = 0; r < 3; ++r) {
      pose.c2w(r, 0) = m(r, 1);   // right
      pose.c2w(r, 1) = m(r, 0);   // down
      pose.c2w(r, 2) = -m(r, 2);  // forward = -back
      pose.c2w(r, 3) = m(r, 3);
    }
    check_rigid(pose.c2w, where + " pose");
  }
  if (int(videos.size()) != count)
    fail("{}: {} camera videos (cam*.mp4) but {} has {} pose rows", source.string(), videos.size(),
         poses_file, count);

  std::vector<detail::VideoInfo> probed;
  for (const auto& path : videos) probed.push_back(detail::probe_video(path));
  int steps = probed[0].frames;
  for (const auto& v : probed) steps = std::min(steps, v.frames);
  // Plain ints, not a structured binding: clang 14 (the fuzzing build) cannot capture those in
  // lambdas.
  const auto [first_frame, last_frame] = detail::frame_range(options, steps, "the videos");
  const int first = first_frame, last = last_frame;

  io::Scene scene;
  scene.num_frames = last - first + 1;
  scene.fps = probed[0].fps;
  scene.calibration = io::CalibrationSource::kLab;  // the dataset's own calibration
  for (int c = 0; c < count; ++c) {
    const Pose& pose = llff[c];
    Camera cam;
    cam.name = probed[c].path.stem().string();
    cam.world_to_camera = pose.c2w.inverse();
    // The video may be stored at another resolution than (w, h) of the poses: scale.
    const detail::VideoInfo& v = probed[c];
    const double sx = v.width / pose.w, sy = v.height / pose.h;
    if (std::abs(sx - sy) > 0.01 * std::max(sx, sy))
      fail("{}: video is {}x{} but the poses say {}x{} (different aspect ratio)", v.path.string(),
           v.width, v.height, pose.w, pose.h);
    cam.width = v.width, cam.height = v.height;
    cam.fx = pose.f * sx, cam.fy = pose.f * sy;
    cam.cx = 0.5 * v.width, cam.cy = 0.5 * v.height;
    cam.split = (cam.name == "cam00" && count > 1) ? Split::kTest : Split::kTrain;
    scene.cameras.push_back(downscaled(cam, options.downscale));
  }
  scene.up = detail::mean_camera_up(scene.cameras);

  AtomicDirectory dir(out, options.force);
  scene.root = dir.temp_path();
  const std::size_t total = std::size_t(count) * scene.num_frames;
  detail::parallel_jobs(count, total, "import n3dv", options.progress,
                        [&](std::size_t c, Progress& progress) {
                          const detail::VideoInfo& v = probed[c];
                          const Camera& cam = scene.cameras[c];
                          detail::decode_video(v, first, last, [&](const Image& image, int k) {
                            media::write_png(scene.image_path(int(c), k - first),
                                             media::resize_area(image, cam.width, cam.height));
                            progress.tick();
                          });
                        });
  io::write_scene_json(scene);
  dir.commit();
}

}  // namespace retimegs::ingest
