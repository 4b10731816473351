// A calibration recovered from the footage by COLMAP's mapper (calibration.hpp:
// recover_calibration), for `import videos` without --calib.
#include <algorithm>

#include <fmt/format.h>

#include "calibration.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"

namespace retimegs::ingest::detail {
namespace fs = std::filesystem;

namespace {

// COLMAP drops models of fewer images (its default, 10, suits photo collections); a rig of two
// cameras is a calibration already, and the caller refuses fewer.
constexpr int kMinModelSize = 2;
// Matches needed to start a model from two images and to register a further one: COLMAP's
// defaults (100 and 30) suit photo collections with many images per viewpoint; a rig has one
// image per camera, and neighbours on a sparse ring share a fraction of that (a 16-camera ring of
// 320x240 views of a textured synthetic scene: 100-180 between neighbours, ~30 two apart).
constexpr int kInitMinInliers = 30;
constexpr int kRegisterMinInliers = 15;

// Mean reprojection error over every observation (COLMAP's per-point error is the mean over its
// track).
double mean_reprojection_error(const io::ColmapModel& model) {
  double sum = 0, observations = 0;
  for (const io::ColmapPoint& p : model.points) {
    sum += p.error * double(p.track_length);
    observations += double(p.track_length);
  }
  return observations > 0 ? sum / observations : 0;
}

}  // namespace

RecoveredCalibration recover_calibration(const std::vector<std::string>& cameras,
                                         const fs::path& work_dir, const fs::path& model_dir,
                                         const fs::path& log_dir,
                                         const colmap::ColmapOptions& options) {
  const fs::path exe = colmap::find_colmap(options);
  const fs::path images = work_dir / "images", database = work_dir / "database.db",
                 sparse = work_dir / "sparse";
  fs::create_directories(sparse);

  std::vector<std::string> extractor = {"--database_path",
                                        database.string(),
                                        "--image_path",
                                        images.string(),
                                        "--ImageReader.camera_model",
                                        "SIMPLE_RADIAL",
                                        "--ImageReader.single_camera_per_image",
                                        "1"};
  const std::vector<std::string> sift = colmap::sift_extraction_args(options);
  extractor.insert(extractor.end(), sift.begin(), sift.end());
  colmap::run_colmap(exe, "feature_extractor", extractor, log_dir, options.verbose);

  std::vector<std::string> matcher = {"--database_path", database.string()};
  const std::vector<std::string> matching = colmap::exhaustive_matching_args(options);
  matcher.insert(matcher.end(), matching.begin(), matching.end());
  colmap::run_colmap(exe, "exhaustive_matcher", matcher, log_dir, options.verbose);

  const std::vector<std::string> mapper = {"--database_path",
                                           database.string(),
                                           "--image_path",
                                           images.string(),
                                           "--output_path",
                                           sparse.string(),
                                           "--Mapper.num_threads",
                                           std::to_string(options.threads),
                                           "--Mapper.min_model_size",
                                           std::to_string(kMinModelSize),
                                           "--Mapper.init_min_num_inliers",
                                           std::to_string(kInitMinInliers),
                                           "--Mapper.abs_pose_min_num_inliers",
                                           std::to_string(kRegisterMinInliers),
                                           "--Mapper.filter_max_reproj_error",
                                           colmap::number(options.max_reprojection_error)};
  try {
    colmap::run_colmap(exe, "mapper", mapper, log_dir, options.verbose);
  } catch (const Error&) {
    // It fails ("failed to create sparse model") when no two images share enough matches to
    // start a model: none registered, refused below as one alone is.
    if (!fs::is_empty(sparse)) throw;
  }

  // The mapper writes one numbered folder per disconnected model.
  io::ColmapModel best;
  for (const auto& entry : fs::directory_iterator(sparse)) {
    if (!entry.is_directory()) continue;
    io::ColmapModel model = io::read_colmap_model(entry.path());
    if (model.images.size() > best.images.size()) best = std::move(model);
  }
  RecoveredCalibration out;
  std::vector<std::string> registered;
  for (const io::ColmapImage& image : best.images)
    registered.push_back(fs::path(image.name).stem().string());
  std::sort(registered.begin(), registered.end());
  for (const std::string& name : cameras)
    if (!std::binary_search(registered.begin(), registered.end(), name))
      out.unregistered.push_back(name);
  std::sort(out.unregistered.begin(), out.unregistered.end());
  if (registered.size() < 2)
    fail(
        "COLMAP registered {} of {} cameras, a calibration needs at least 2: the frames share too "
        "few features (more texture in view, another --calib-frame, or a rig file with --calib "
        "help; log: {})",
        registered.size(), cameras.size(), shown_path(log_dir / "mapper.log"));

  io::write_colmap_model_txt(best, model_dir);
  out.cameras = read_colmap_calibration(model_dir);
  out.points = best.points.size();
  out.reprojection_error = mean_reprojection_error(best);
  return out;
}

}  // namespace retimegs::ingest::detail
