// A calibration recovered from the footage by COLMAP's mapper (calibration.hpp:
// recover_calibration), for `import videos` without --calib.
#include <algorithm>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <regex>
#include <string>

#include <Eigen/Geometry>

#include <fmt/format.h>

#include "calibration.hpp"
#include "calibration_features.hpp"
#include "import_common.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/progress.hpp"

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
// Rigs of at most this many cameras keep the tracks of two cameras, which COLMAP's mapper and
// triangulator ignore by default (--Mapper.tri_ignore_two_view_tracks: a photo collection sees
// most of its scene from many images, and a two-view point agrees with one epipolar line only).
// A rig of two cameras has no other tracks: without them the mapper keeps only its initial pair's
// points and the final triangulation none, whose bundle adjustment then fails. A few cameras
// spread round a subject (45 degrees or more apart) see most surfaces from two of them at most, so
// that a camera may share too few longer tracks to be registered, or the registered cameras too
// few to triangulate. COLMAP's minimum triangulation angle (--Mapper.tri_min_angle) drops the
// two-view points too near a ray to place, and its reprojection filter
// (--Mapper.filter_max_reproj_error) the ones that disagree with the cameras. Larger rigs keep
// COLMAP's default: there, most points are seen by three cameras or more.
constexpr std::size_t kMaxCamerasWithTwoViewTracks = 8;
bool keep_two_view_tracks(std::size_t cameras) {
  return cameras <= kMaxCamerasWithTwoViewTracks;
}

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

// Reconstructions are combined (combine_reconstructions) by the similarity between the centres of
// the cameras they share: three or more determine it; two leave the rotation about the line
// through them free.
constexpr std::size_t kMinCombinedCameras = 3;

// A guide model must place this many cameras to judge the static matches: a similarity between
// two cameras' placements is not determined by fewer. A rig of two cameras has nothing more to
// judge them by: its guide is the two (min_guide_cameras).
constexpr std::size_t kMinGuideCameras = 3;
std::size_t min_guide_cameras(std::size_t rig_cameras) {
  return std::min(kMinGuideCameras, rig_cameras);
}
// A rig of two cameras keeps its distortion at none (the adjustments of the mapper and of a
// tightening leave it out): two cameras aimed at one point, as a rig's are, do not determine
// their focal lengths (a critical configuration of two views), and a distortion term trades with
// them freely there, running off to values no lens has (-1 on a synthetic pair, its focal lengths
// 70-90 % long; held, 7-19 % in most runs).
constexpr std::size_t kMinCamerasForDistortion = 3;

// A tightening frees the principal points (tighten) of models of this many cameras or more: the
// cameras of a model are determined up to a projective transformation of 15 degrees of freedom, a
// similarity's 7 aside; each camera whose pixels are square and unskewed fixes 2 of the other 8,
// and 2 more with its principal point known. Fewer cameras keep the principal points at the image
// centre, where the mapper puts them.
constexpr std::size_t kMinCamerasForPrincipalPoints = 4;
// Matches a pair needs before COLMAP verifies it (its --SiftMatching.min_num_inliers default):
// fewer can never pass.
constexpr std::size_t kMinPairMatches = 15;
// The refinements after the guide: a match is kept where it lies within this fraction of the
// image's larger side of the epipolar line of the previous placement (10 px, then 4 px at
// 640x360): loose while the guide, placed by moving features alone, may be a few degrees off,
// then as tight as COLMAP's own verification (--SiftMatching.max_error 4 px).
constexpr double kRefineTolerance[] = {1.0 / 64, 1.0 / 160};
// Independent reconstructions combined (combine_reconstructions): COLMAP's mapper, run on several
// threads, registers the cameras in another order each time, and where a camera's observations
// determine its place weakly, places it elsewhere: on the Panoptic frames the distance of a camera
// that sees mostly floor or one wall trades with its focal length, and runs on the same matches
// put that camera up to 3.3 % of the rig's extent from the truth, in either direction. Per camera
// the placement nearest the other runs' is kept, so that one run placing a camera apart, or
// folding, does not move it (of runs at 1.7, 1.9, 2.0, 3.1 and 3.3 % the combination is at
// 1.7 %). Runs that agree on a wrong place, it keeps there: the combination of three is within
// 2 % in nineteen imports of twenty-three (1.4 to 2.7 %), a single run in five of eight (1.4 to
// 2.8 %); five did no better. With SIMPLE_PINHOLE on those undistorted frames, sixteen of sixteen
// (1.2 to 1.95 %).
constexpr int kReconstructions = 3;
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

// The mapper's options for a rig of `rig_cameras`.
std::vector<std::string> mapper_args(const fs::path& database, const fs::path& images,
                                     const fs::path& sparse, std::size_t rig_cameras,
                                     const colmap::ColmapOptions& options) {
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
          "--Mapper.tri_ignore_two_view_tracks",
          keep_two_view_tracks(rig_cameras) ? "0" : "1",
          "--Mapper.ba_refine_extra_params",
          rig_cameras >= kMinCamerasForDistortion ? "1" : "0",
          "--Mapper.filter_max_reproj_error",
          colmap::number(options.max_reprojection_error)};
}

// A model COLMAP wrote: as read, its folder, whose tracks a later step adjusts, and the database
// of the matches it was mapped from.
struct Mapped {
  io::ColmapModel model;
  fs::path dir;  // empty when there is no model
  fs::path database;
};

// Runs the mapper on `database` into `sparse` and returns the model that registers the most
// images (none registered when it made none).
Mapped map_largest(const fs::path& exe, const fs::path& database, const fs::path& images,
                   const fs::path& sparse, std::size_t rig_cameras, const fs::path& log_dir,
                   const colmap::ColmapOptions& options) {
  fs::create_directories(sparse);
  try {
    colmap::run_colmap(exe, "mapper", mapper_args(database, images, sparse, rig_cameras, options),
                       log_dir, options.verbose);
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
    if (model.images.size() > best.model.images.size())
      best = {std::move(model), entry.path(), database};
  }
  return best;
}

// COLMAP's own features and matches of the reference frame (work_dir/images), every pair
// matched and verified, into the returned database.
fs::path match_reference_frame(const fs::path& exe, const fs::path& work_dir,
                               const fs::path& log_dir, const colmap::ColmapOptions& options) {
  const fs::path images = work_dir / "images", database = work_dir / "database.db";
  std::vector<std::string> extractor = {"--database_path",
                                        database.string(),
                                        "--image_path",
                                        images.string(),
                                        "--ImageReader.camera_model",
                                        options.camera_model,
                                        "--ImageReader.single_camera_per_image",
                                        "1"};
  const std::vector<std::string> sift = colmap::sift_extraction_args(options);
  extractor.insert(extractor.end(), sift.begin(), sift.end());
  colmap::run_colmap(exe, "feature_extractor", extractor, log_dir, options.verbose);

  std::vector<std::string> matcher = {"--database_path", database.string()};
  const std::vector<std::string> matching = colmap::exhaustive_matching_args(options);
  matcher.insert(matcher.end(), matching.begin(), matching.end());
  colmap::run_colmap(exe, "exhaustive_matcher", matcher, log_dir, options.verbose);
  return database;
}

// Each camera's placement in a model, in the order of `cameras` (none where it is not placed).
// The distortion is left out: the tolerances above are far wider than its effect near the centre.
std::vector<std::optional<Placement>> placements(const io::ColmapModel& model,
                                                 const std::vector<std::string>& cameras) {
  std::map<std::string, Placement> by_name;
  for (const io::ColmapImage& image : model.images) {
    const io::ColmapCamera& camera = model.camera(image.camera_id);
    Placement p;
    // A single-focal model (kRecoveredCameraModels): f, cx, cy, then its distortion.
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

// The features of work_dir/features imported into dir/database.db (returned) and the pairs'
// matches (`matches`: a list per pair of `cameras`, in pair order) verified by COLMAP; logs in
// log_dir.
fs::path verify_matches(const fs::path& exe, const fs::path& work_dir, const fs::path& dir,
                        const std::vector<std::string>& cameras,
                        const std::vector<Matches>& matches, const fs::path& log_dir,
                        const colmap::ColmapOptions& options) {
  const fs::path database = dir / "database.db";
  fs::create_directories(dir);
  colmap::run_colmap(
      exe, "feature_importer",
      {"--database_path", database.string(), "--image_path", (work_dir / "images").string(),
       "--import_path", (work_dir / "features").string(), "--ImageReader.camera_model",
       options.camera_model, "--ImageReader.single_camera_per_image", "1"},
      log_dir, options.verbose);
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
      log_dir, options.verbose);
  return database;
}

// The features of the moving-feature calibration (calibration_features.hpp), written to
// work_dir/features, and per pair of cameras (in pair order) the matches of the moving ones and
// of every one.
struct MovingMatches {
  std::vector<CameraFeatures> features;
  std::vector<Matches> moving, all;
};

MovingMatches moving_matches(const std::vector<std::string>& cameras,
                             const CalibrationFrames& frames, const fs::path& work_dir,
                             const colmap::ColmapOptions& options, bool progress) {
  MovingMatches out;
  out.features.resize(cameras.size());
  parallel_jobs(
      cameras.size(), cameras.size(), "calibration features", progress,
      [&](std::size_t c, Progress& bar) {
        out.features[c] = camera_features(
            frames.instants, [&](int k) { return frames.frame(c, k); }, options.max_num_features);
        write_colmap_features(out.features[c], work_dir / "features" / (cameras[c] + ".png.txt"));
        bar.tick();
      });
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t a = 0; a < cameras.size(); ++a)
    for (std::size_t b = a + 1; b < cameras.size(); ++b) pairs.emplace_back(a, b);
  out.moving.resize(pairs.size());
  out.all.resize(pairs.size());
  parallel_jobs(pairs.size(), pairs.size(), "calibration matches", progress,
                [&](std::size_t p, Progress& bar) {
                  const auto [a, b] = pairs[p];
                  const CameraFeatures &fa = out.features[a], &fb = out.features[b];
                  out.moving[p] = match_features(fa, fb, true, false);
                  // The groups match apart (calibration_features.hpp): the still ones, then the
                  // moving ones as above, is every match.
                  out.all[p] = match_features(fa, fb, false, true);
                  out.all[p].insert(out.all[p].end(), out.moving[p].begin(), out.moving[p].end());
                  bar.tick();
                });
  return out;
}

// One reconstruction by the moving features in run_dir, logs in log_dir: the guide mapped from
// the verified moving matches (`guide`, a database: COLMAP's verification is the same every run),
// then refinements that add the static matches and keep every one that agrees with the previous
// placement (agreeing_matches: among the cameras it placed), each refinement's model tightened.
// None registered when the footage moves too little for a guide.
Mapped place_by_moving_features(const fs::path& exe, const std::vector<std::string>& cameras,
                                const MovingMatches& matches, const fs::path& guide,
                                const fs::path& work_dir, const fs::path& run_dir,
                                const fs::path& log_dir, const colmap::ColmapOptions& options) {
  const fs::path images = work_dir / "images";
  Mapped placed = map_largest(exe, guide, images, run_dir / "guide" / "sparse", cameras.size(),
                              log_dir / "guide", options);
  if (placed.model.images.size() < min_guide_cameras(cameras.size())) return {};
  int round = 0;
  for (const double tolerance : kRefineTolerance) {
    const std::vector<Matches> kept = agreeing_matches(placements(placed.model, cameras),
                                                       matches.features, matches.all, tolerance);
    const std::string step = fmt::format("refine{}", ++round);
    const fs::path database =
        verify_matches(exe, work_dir, run_dir / step, cameras, kept, log_dir / step, options);
    Mapped refined = map_largest(exe, database, images, run_dir / step / "sparse", cameras.size(),
                                 log_dir / step, options);
    // One that places fewer is dropped.
    if (refined.model.images.size() < placed.model.images.size()) break;
    const fs::path tightened =
        tighten(exe, refined.dir, run_dir / step / "tightened", log_dir / step, options);
    placed = {io::read_colmap_model(tightened), tightened, database};
  }
  return placed;
}

// The points COLMAP's point_triangulator reports triangulating in its log (its
// "=> Triangulated <n> points" line per image); -1 when the log has no such line.
long triangulated_points(const fs::path& log) {
  std::ifstream in(log);
  const std::regex line(R"(=> Triangulated (\d+) points)");
  long total = -1;
  std::smatch m;
  for (std::string text; std::getline(in, text);)
    if (std::regex_search(text, m, line)) total = std::max(total, 0L) + std::stol(m[1]);
  return total;
}

}  // namespace

fs::path tighten(const fs::path& exe, const fs::path& model_dir, const fs::path& work_dir,
                 const fs::path& log_dir, const colmap::ColmapOptions& options) {
  // Round 0 adjusts every observation, the principal points now included: a lens off centre
  // leaves the mapper's model (its principal points at the centre, the offset taken up by the
  // camera's rotation) off by pixels towards the image's edges, which a trim would take for wrong
  // and remove, leaving the centre, from which principal point and rotation cannot be told apart.
  const std::size_t model_cameras = io::read_colmap_model(model_dir).images.size();
  const bool principal_points = model_cameras >= kMinCamerasForPrincipalPoints,
             distortion = model_cameras >= kMinCamerasForDistortion;
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
                        "--BundleAdjustment.refine_principal_point", principal_points ? "1" : "0",
                        "--BundleAdjustment.refine_extra_params", distortion ? "1" : "0"},
                       logs, options.verbose);
    model = adjusted;
  }
  return model;
}

CombinedReconstructions combine_reconstructions(const std::vector<io::ColmapModel>& models) {
  const io::ColmapModel& first = models.front();
  CombinedReconstructions out;
  out.model.cameras = first.cameras;
  out.model.images = first.images;
  out.spread.assign(first.images.size(), 0);
  std::map<std::string, std::size_t> index;
  for (std::size_t i = 0; i < first.images.size(); ++i) index[first.images[i].name] = i;

  // Per image of the first, its placements in the first's frame.
  struct Candidate {
    Eigen::Matrix3d rotation;  // world to camera
    Eigen::Vector3d centre;
    const io::ColmapCamera* camera;
  };
  const auto centre = [](const io::ColmapImage& image) -> Eigen::Vector3d {
    const Eigen::Matrix4d w2c = image.world_to_camera();
    return -w2c.topLeftCorner<3, 3>().transpose() * w2c.topRightCorner<3, 1>();
  };
  std::vector<std::vector<Candidate>> candidates(first.images.size());
  for (const io::ColmapModel& model : models) {
    std::vector<std::pair<std::size_t, const io::ColmapImage*>> shared;
    for (const io::ColmapImage& image : model.images)
      if (const auto it = index.find(image.name); it != index.end())
        shared.emplace_back(it->second, &image);
    Eigen::Matrix4d similarity = Eigen::Matrix4d::Identity();
    if (&model != &first) {
      if (shared.size() < kMinCombinedCameras) continue;
      Eigen::Matrix3Xd from(3, shared.size()), to(3, shared.size());
      for (std::size_t k = 0; k < shared.size(); ++k)
        from.col(k) = centre(*shared[k].second), to.col(k) = centre(first.images[shared[k].first]);
      similarity = Eigen::umeyama(from, to, /*with_scaling=*/true);
    }
    const Eigen::Matrix3d scaled_rotation = similarity.topLeftCorner<3, 3>();
    const Eigen::Matrix3d rotation = scaled_rotation / scaled_rotation.col(0).norm();
    for (const auto& [i, image] : shared)
      candidates[i].push_back(
          {image->world_to_camera().topLeftCorner<3, 3>() * rotation.transpose(),
           (similarity * centre(*image).homogeneous()).head<3>(), &model.camera(image->camera_id)});
  }

  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& c : candidates) mean += c.front().centre;
  mean /= double(candidates.size());
  double radius = 0;
  for (const auto& c : candidates) radius = std::max(radius, (c.front().centre - mean).norm());
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const std::vector<Candidate>& placed = candidates[i];
    std::size_t best = 0;
    double best_sum = std::numeric_limits<double>::infinity();
    for (std::size_t a = 0; a < placed.size(); ++a) {
      double sum = 0;
      for (const Candidate& b : placed) sum += (placed[a].centre - b.centre).norm();
      if (sum < best_sum) best = a, best_sum = sum;
    }
    const Candidate& chosen = placed[best];
    Eigen::Matrix4d w2c = Eigen::Matrix4d::Identity();
    w2c.topLeftCorner<3, 3>() = chosen.rotation;
    w2c.topRightCorner<3, 1>() = -chosen.rotation * chosen.centre;
    io::ColmapImage& image = out.model.images[i];
    image = io::ColmapImage::from_world_to_camera(image.id, image.camera_id, image.name, w2c);
    for (io::ColmapCamera& camera : out.model.cameras)
      if (camera.id == image.camera_id) camera.params = chosen.camera->params;
    for (const Candidate& b : placed)
      out.spread[i] = std::max(out.spread[i], (b.centre - chosen.centre).norm() / radius);
  }
  return out;
}

RecoveredCalibration recover_calibration(const std::vector<std::string>& cameras,
                                         const CalibrationFrames& frames, const fs::path& work_dir,
                                         const fs::path& model_dir, const fs::path& log_dir,
                                         const colmap::ColmapOptions& options, bool progress) {
  const fs::path exe = colmap::find_colmap(options);
  // Reconstruction k (from 0) works in <folder>/run<k+1> of its work and log folders, the first
  // in the folders themselves (its mapper's log where the refusal below points).
  const auto run_dir = [](const fs::path& dir, int k) {
    return k == 0 ? dir : dir / fmt::format("run{}", k + 1);
  };
  // A rig of fewer cameras than a combination needs is reconstructed once: its reconstructions
  // could not be combined (nor, with two cameras, differ in the order the mapper registers them).
  const int reconstructions = cameras.size() >= kMinCombinedCameras ? kReconstructions : 1;
  // place(k) for each reconstruction k under one progress bar: those that place two cameras or
  // more, or the first alone when it does not (there is nothing the others could add to).
  const auto reconstruct = [&](const std::function<Mapped(int)>& place) {
    std::vector<Mapped> runs;
    Progress bar("calibration reconstructions", reconstructions, progress);
    for (int k = 0; k < reconstructions; ++k) {
      Mapped mapped = place(k);
      bar.tick();
      const bool placed = mapped.model.images.size() >= 2;
      if (placed || k == 0) runs.push_back(std::move(mapped));
      if (!placed && k == 0) break;
    }
    return runs;
  };
  RecoveredCalibration out;
  std::vector<Mapped> runs;
  if (frames.instants >= kMinInstants) {
    const MovingMatches matches = moving_matches(cameras, frames, work_dir, options, progress);
    const fs::path guide = verify_matches(exe, work_dir, work_dir / "guide", cameras,
                                          matches.moving, log_dir / "guide", options);
    runs = reconstruct([&](int k) {
      return place_by_moving_features(exe, cameras, matches, guide, work_dir,
                                      run_dir(work_dir / "moving", k), run_dir(log_dir, k),
                                      options);
    });
  }
  // The footage moves too little for a guide: the reference frame instead.
  out.moving = !runs.empty() && !runs.front().model.images.empty();
  if (!out.moving) {
    const fs::path database = match_reference_frame(exe, work_dir, log_dir, options);
    runs = reconstruct([&](int k) {
      return map_largest(exe, database, work_dir / "images",
                         run_dir(work_dir / "reference", k) / "sparse", cameras.size(),
                         run_dir(log_dir, k), options);
    });
  }
  // The one that registers the most cameras (the earliest on ties) sets the frame.
  std::stable_sort(runs.begin(), runs.end(), [](const Mapped& a, const Mapped& b) {
    return a.model.images.size() > b.model.images.size();
  });
  const io::ColmapModel& best = runs.front().model;

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

  std::vector<io::ColmapModel> models;
  for (Mapped& run : runs) models.push_back(std::move(run.model));
  const CombinedReconstructions combined = combine_reconstructions(models);
  out.reconstructions = int(models.size());
  for (std::size_t i = 0; i < combined.spread.size(); ++i)
    if (combined.spread[i] > out.spread)
      out.spread = combined.spread[i],
      out.spread_camera = fs::path(combined.model.images[i].name).stem().string();

  // The points of the combined cameras: the first's matches triangulated with them held.
  const fs::path known = work_dir / "combined", triangulated = work_dir / "triangulated";
  io::write_colmap_model_txt(combined.model, known);
  fs::create_directories(triangulated);
  try {
    colmap::run_colmap(exe, "point_triangulator",
                       {"--database_path",
                        runs.front().database.string(),
                        "--image_path",
                        (work_dir / "images").string(),
                        "--input_path",
                        known.string(),
                        "--output_path",
                        triangulated.string(),
                        "--clear_points",
                        "1",
                        "--Mapper.num_threads",
                        std::to_string(options.threads),
                        "--Mapper.ba_refine_focal_length",
                        "0",
                        "--Mapper.ba_refine_principal_point",
                        "0",
                        "--Mapper.ba_refine_extra_params",
                        "0",
                        "--Mapper.tri_ignore_two_view_tracks",
                        keep_two_view_tracks(registered.size()) ? "0" : "1",
                        "--Mapper.filter_max_reproj_error",
                        colmap::number(options.max_reprojection_error)},
                       log_dir, options.verbose);
  } catch (const Error&) {
    // Its bundle adjustment fails when nothing was triangulated: say so, not what COLMAP's
    // message for that says (too few matched features: the cameras were placed from them).
    const fs::path log = log_dir / "point_triangulator.log";
    if (triangulated_points(log) != 0) throw;
    fail(
        "COLMAP placed {} of {} cameras but could triangulate no point from their matches: the "
        "cameras see too little of the scene in common, or from too nearly the same direction "
        "(cameras side by side far from the scene, or turned about one spot); place the cameras "
        "further apart round what they film, or bring a calibration (--calib) (log: {})",
        registered.size(), cameras.size(), shown_path(log));
  }
  const io::ColmapModel model = io::read_colmap_model(triangulated);
  io::write_colmap_model_txt(model, model_dir);
  out.cameras = read_colmap_calibration(model_dir);
  out.points = model.points.size();
  out.reprojection_error = mean_reprojection_error(model);
  return out;
}

}  // namespace retimegs::ingest::detail
