// A calibration recovered from the footage by COLMAP's mapper (calibration.hpp:
// recover_calibration), for `import videos` without --calib.
#include <algorithm>
#include <map>
#include <optional>

#include <fmt/format.h>

#include "calibration.hpp"
#include "calibration_features.hpp"
#include "import_common.hpp"
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

// A guide model must place this many cameras to judge the static matches: a similarity between
// two cameras' placements is not determined by fewer.
constexpr int kMinGuideCameras = 3;
// Matches a pair needs before COLMAP verifies it (its --SiftMatching.min_num_inliers default):
// fewer can never pass.
constexpr std::size_t kMinPairMatches = 15;
// The refinements after the guide: a match is kept where it lies within this fraction of the
// image's larger side of the epipolar line of the previous placement (10 px, then 4 px at
// 640x360): loose while the guide, placed by moving features alone, may be a few degrees off,
// then as tight as COLMAP's own verification (--SiftMatching.max_error 4 px).
constexpr double kRefineTolerance[] = {1.0 / 64, 1.0 / 160};
// A refinement's observations are trimmed to these reprojection errors, one round each, the model
// adjusted after each (calibration.hpp: tighten), pixels. COLMAP's mapper keeps every observation
// within 4 px of its point's projection (--Mapper.filter_max_reproj_error), and its bundle adjuster
// weighs them by their squared error; but a SIFT feature on what moves (cloth, skin, seen from
// different sides) lies 1.5 px or more off its point far more often than one on the static
// background (in a Panoptic model 16 % against 6 %, 37 % of the large-scale moving ones), and
// together they bend the cameras: from the true Panoptic cameras the adjustment moves them 2 % of
// the rig's extent away, and without those observations stays within 1.4 %. SIFT locates a feature
// to a fraction of a pixel, so what the model leaves over 0.75 px is mostly such; in steps, so that
// each round's model, freed of the worst, judges the next. The principal points, which the mapper
// keeps at the image centre (freed from the guide on, they run off), are adjusted in the
// tightening: lenses are rarely centred (Panoptic's up to 14 px at 640x360), and trimmed against a
// centred one, the observations towards the image's edges would go. Freed, a principal point is
// weakly determined (it trades with the camera's rotation): where nothing bends a model, it costs
// up to 1 % of the rig's extent (synthetic rings of 24 and 31 cameras: 0.8-1.0 % before, 1.5-2.0 %
// after), against the 2 % the trimmed observations bend the Panoptic cameras by.
constexpr double kTightenSteps[] = {2, 1.5, 1, 1, 0.75, 0.75};

std::vector<std::string> mapper_args(const fs::path& database, const fs::path& images,
                                     const fs::path& sparse, const colmap::ColmapOptions& options) {
  return {"--database_path",
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
}

// A model COLMAP wrote: as read, and its folder, whose tracks a later step adjusts.
struct Mapped {
  io::ColmapModel model;
  fs::path dir;  // empty when there is no model
};

// Runs the mapper into `sparse` and returns the model that registers the most images (none
// registered when it made none).
Mapped map_largest(const fs::path& exe, const std::vector<std::string>& args,
                   const fs::path& sparse, const fs::path& log_dir,
                   const colmap::ColmapOptions& options) {
  fs::create_directories(sparse);
  try {
    colmap::run_colmap(exe, "mapper", args, log_dir, options.verbose);
  } catch (const Error&) {
    // It fails ("failed to create sparse model") when no two images share enough matches to
    // start a model: none registered, as the caller says.
    if (!fs::is_empty(sparse)) throw;
  }
  // The mapper writes one numbered folder per disconnected model.
  Mapped best;
  for (const auto& entry : fs::directory_iterator(sparse)) {
    if (!entry.is_directory()) continue;
    io::ColmapModel model = io::read_colmap_model(entry.path());
    if (model.images.size() > best.model.images.size()) best = {std::move(model), entry.path()};
  }
  return best;
}

// COLMAP's own features and matches of the reference frame (work_dir/images), every pair
// matched and verified, then the mapper.
Mapped map_reference_frame(const fs::path& exe, const fs::path& work_dir, const fs::path& log_dir,
                           const colmap::ColmapOptions& options) {
  const fs::path images = work_dir / "images", database = work_dir / "database.db";
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

  const fs::path sparse = work_dir / "sparse";
  return map_largest(exe, mapper_args(database, images, sparse, options), sparse, log_dir, options);
}

// Each camera's placement in a model, in the order of `cameras` (none where it is not placed).
// The distortion is left out: the tolerances above are far wider than its effect near the centre.
std::vector<std::optional<Placement>> placements(const io::ColmapModel& model,
                                                 const std::vector<std::string>& cameras) {
  std::map<std::string, Placement> by_name;
  for (const io::ColmapImage& image : model.images) {
    const io::ColmapCamera& camera = model.camera(image.camera_id);
    Placement p;
    // SIMPLE_RADIAL, as every camera is made here: f, cx, cy, k.
    p.k << camera.params[0], 0, camera.params[1], 0, camera.params[0], camera.params[2], 0, 0, 1;
    p.world_to_camera = image.world_to_camera();
    p.larger_side = std::max(camera.width, camera.height);
    by_name[fs::path(image.name).stem().string()] = p;
  }
  std::vector<std::optional<Placement>> out(cameras.size());
  for (std::size_t c = 0; c < cameras.size(); ++c)
    if (const auto it = by_name.find(cameras[c]); it != by_name.end()) out[c] = it->second;
  return out;
}

// One step of the moving-feature calibration in work_dir/<step>: the features imported, the
// pairs' matches (`matches`: a list per pair of `cameras`, in pair order) verified by COLMAP, and
// the mapper; logs in log_dir/<step>.
Mapped map_matches(const fs::path& exe, const fs::path& work_dir, const std::string& step,
                   const std::vector<std::string>& cameras, const std::vector<Matches>& matches,
                   const fs::path& log_dir, const colmap::ColmapOptions& options) {
  const fs::path dir = work_dir / step, database = dir / "database.db",
                 images = work_dir / "images", logs = log_dir / step;
  fs::create_directories(dir);
  colmap::run_colmap(
      exe, "feature_importer",
      {"--database_path", database.string(), "--image_path", images.string(), "--import_path",
       (work_dir / "features").string(), "--ImageReader.camera_model", "SIMPLE_RADIAL",
       "--ImageReader.single_camera_per_image", "1"},
      logs, options.verbose);
  std::string list;
  std::size_t pair = 0;
  for (std::size_t a = 0; a < cameras.size(); ++a)
    for (std::size_t b = a + 1; b < cameras.size(); ++b, ++pair) {
      if (matches[pair].size() < kMinPairMatches) continue;
      list += fmt::format("{}.png {}.png\n", cameras[a], cameras[b]);
      for (const auto& [i, j] : matches[pair]) list += fmt::format("{} {}\n", i, j);
      list += '\n';
    }
  write_text_file(dir / "matches.txt", list);
  colmap::run_colmap(
      exe, "matches_importer",
      {"--database_path", database.string(), "--match_list_path", (dir / "matches.txt").string(),
       "--match_type", "raw", "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads",
       std::to_string(options.threads)},
      logs, options.verbose);
  return map_largest(exe, mapper_args(database, images, dir / "sparse", options), dir / "sparse",
                     logs, options);
}

// The moving-feature calibration (calibration_features.hpp): the guide from moving features
// alone, then refinements that add the static ones and keep every match that agrees with the
// previous placement (agreeing_matches: among the cameras it placed), each refinement's model
// tightened. None registered when the footage moves too little for a guide.
Mapped map_moving_features(const fs::path& exe, const std::vector<std::string>& cameras,
                           const CalibrationFrames& frames, const fs::path& work_dir,
                           const fs::path& log_dir, const colmap::ColmapOptions& options,
                           bool progress) {
  std::vector<CameraFeatures> features(cameras.size());
  parallel_jobs(
      cameras.size(), cameras.size(), "calibration features", progress,
      [&](std::size_t c, Progress& bar) {
        features[c] = camera_features(
            frames.instants, [&](int k) { return frames.frame(c, k); }, options.max_num_features);
        write_colmap_features(features[c], work_dir / "features" / (cameras[c] + ".png.txt"));
        bar.tick();
      });
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t a = 0; a < cameras.size(); ++a)
    for (std::size_t b = a + 1; b < cameras.size(); ++b) pairs.emplace_back(a, b);
  std::vector<Matches> moving(pairs.size()), all(pairs.size());
  parallel_jobs(pairs.size(), pairs.size(), "calibration matches", progress,
                [&](std::size_t p, Progress& bar) {
                  const auto [a, b] = pairs[p];
                  moving[p] = match_features(features[a], features[b], true, false);
                  // The groups match apart (calibration_features.hpp): the still ones, then the
                  // moving ones as above, is every match.
                  all[p] = match_features(features[a], features[b], false, true);
                  all[p].insert(all[p].end(), moving[p].begin(), moving[p].end());
                  bar.tick();
                });

  Mapped placed = map_matches(exe, work_dir, "guide", cameras, moving, log_dir, options);
  if (int(placed.model.images.size()) < kMinGuideCameras) return {};
  int round = 0;
  for (const double tolerance : kRefineTolerance) {
    const std::vector<Matches> kept =
        agreeing_matches(placements(placed.model, cameras), features, all, tolerance);
    const std::string step = fmt::format("refine{}", ++round);
    Mapped refined = map_matches(exe, work_dir, step, cameras, kept, log_dir, options);
    // One that places fewer is dropped.
    if (refined.model.images.size() < placed.model.images.size()) break;
    const fs::path tightened =
        tighten(exe, refined.dir, work_dir / step / "tightened", log_dir / step, options);
    placed = {io::read_colmap_model(tightened), tightened};
  }
  return placed;
}

}  // namespace

fs::path tighten(const fs::path& exe, const fs::path& model_dir, const fs::path& work_dir,
                 const fs::path& log_dir, const colmap::ColmapOptions& options) {
  // Round 0 adjusts every observation, the principal points now included: a lens off centre
  // leaves the mapper's model (its principal points at the centre, the offset taken up by the
  // camera's rotation) off by pixels towards the image's edges, which a trim would take for wrong
  // and remove, leaving the centre, from which principal point and rotation cannot be told apart.
  fs::path model = model_dir;
  for (std::size_t round = 0; round <= std::size(kTightenSteps); ++round) {
    const fs::path logs = log_dir / fmt::format("tighten{}", round),
                   adjusted = work_dir / fmt::format("adjusted{}", round);
    if (round > 0) {
      const fs::path filtered = work_dir / fmt::format("filtered{}", round);
      fs::create_directories(filtered);
      colmap::run_colmap(
          exe, "point_filtering",
          {"--input_path", model.string(), "--output_path", filtered.string(), "--max_reproj_error",
           colmap::number(kTightenSteps[round - 1]), "--min_track_len", "2"},
          logs, options.verbose);
      model = filtered;
    }
    fs::create_directories(adjusted);
    colmap::run_colmap(exe, "bundle_adjuster",
                       {"--input_path", model.string(), "--output_path", adjusted.string(),
                        "--BundleAdjustment.refine_principal_point", "1"},
                       logs, options.verbose);
    model = adjusted;
  }
  return model;
}

RecoveredCalibration recover_calibration(const std::vector<std::string>& cameras,
                                         const CalibrationFrames& frames, const fs::path& work_dir,
                                         const fs::path& model_dir, const fs::path& log_dir,
                                         const colmap::ColmapOptions& options, bool progress) {
  const fs::path exe = colmap::find_colmap(options);
  RecoveredCalibration out;
  Mapped mapped;
  if (frames.instants >= kMinInstants)
    mapped = map_moving_features(exe, cameras, frames, work_dir, log_dir, options, progress);
  out.moving = !mapped.model.images.empty();
  if (!out.moving) mapped = map_reference_frame(exe, work_dir, log_dir, options);
  const io::ColmapModel& best = mapped.model;

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
