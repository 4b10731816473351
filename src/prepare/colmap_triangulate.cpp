// `prepare --points colmap`: triangulation with known poses through the COLMAP command line
// (feature_extractor -> exhaustive_matcher -> point_triangulator), as COLMAP's FAQ "Reconstruct
// sparse/dense model from known camera poses" describes.
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <tuple>

#include <fmt/format.h>

#include "retimegs/colmap/run.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/prepare/colmap_triangulate.hpp"

namespace retimegs::prepare {
namespace fs = std::filesystem;
using colmap::number;
using colmap::run_colmap;

bool keeps_two_view_tracks(std::size_t training_cameras) {
  return training_cameras < kTwoViewTrackCameras;
}

double triangulation_angle_degrees(const Eigen::Vector3d& x,
                                   const std::vector<Eigen::Vector3d>& centres) {
  double widest = 0;
  for (std::size_t i = 0; i < centres.size(); ++i)
    for (std::size_t j = i + 1; j < centres.size(); ++j) {
      const Eigen::Vector3d a = centres[i] - x, b = centres[j] - x;
      // atan2 of |a x b| and a . b: accurate at small angles, where acos is not.
      widest = std::max(widest, std::atan2(a.cross(b).norm(), a.dot(b)));
    }
  return widest * 180 / std::numbers::pi;
}

bool keep_triangulated_point(const io::ColmapPoint& point,
                             const std::vector<Eigen::Vector3d>& centres, bool two_view_tracks,
                             const ColmapOptions& options) {
  const std::size_t multi_view = std::size_t(std::max(options.min_track_length, 2));
  if (centres.size() >= multi_view) return true;
  return two_view_tracks && centres.size() == 2 &&
         triangulation_angle_degrees(point.xyz, centres) >= kTwoViewMinAngleDegrees &&
         point.error <= 0.5 * options.max_reprojection_error;
}

io::PointCloud triangulate_with_colmap(const io::Scene& scene, int frame, const fs::path& work_dir,
                                       const fs::path& log_dir, const ColmapOptions& options) {
  const fs::path exe = find_colmap(options);
  if (frame < 0 || frame >= scene.num_frames)
    fail("--points colmap: frame {} is outside the scene's frames 0:{}", frame,
         scene.num_frames - 1);
  const std::vector<int> cams = io::training_cameras(scene);
  if (cams.size() < 2)
    fail("--points colmap: triangulation needs at least 2 training cameras, the scene has {}",
         cams.size());

  // Fresh work folder (only what this function writes is removed).
  fs::create_directories(work_dir);
  for (const char* name : {"images", "known", "sparse", "database.db", "lists"})
    fs::remove_all(work_dir / name);
  const fs::path images = work_dir / "images", known = work_dir / "known",
                 sparse = work_dir / "sparse", &logs = log_dir, database = work_dir / "database.db";
  fs::create_directories(images);
  fs::create_directories(known);
  fs::create_directories(sparse);
  fs::create_directories(work_dir / "lists");

  // One COLMAP camera per distinct intrinsics; the known model below uses the same grouping.
  using Key = std::tuple<int, int, double, double, double, double>;
  std::map<Key, std::uint32_t> groups;
  io::ColmapModel model;
  std::map<std::uint32_t, std::vector<std::string>> group_images;
  for (std::size_t i = 0; i < cams.size(); ++i) {
    const Camera& cam = scene.cameras[cams[i]];
    const fs::path src = scene.image_path(cams[i], frame);
    if (!fs::is_regular_file(src)) fail("{}: missing image", src.string());
    const std::string name = cam.name + ".png";
    fs::copy_file(src, images / name, fs::copy_options::overwrite_existing);
    const Key key{cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy};
    auto [it, added] = groups.emplace(key, std::uint32_t(groups.size() + 1));
    if (added)
      model.cameras.push_back(
          {it->second, "PINHOLE", cam.width, cam.height, {cam.fx, cam.fy, cam.cx, cam.cy}});
    group_images[it->second].push_back(name);
    model.images.push_back(io::ColmapImage::from_world_to_camera(std::uint32_t(i + 1), it->second,
                                                                 name, cam.world_to_camera));
  }
  io::write_colmap_model_txt(model, known);

  for (const auto& cam : model.cameras) {
    const fs::path list = work_dir / "lists" / fmt::format("camera{}.txt", cam.id);
    write_text_file(list, fmt::format("{}\n", fmt::join(group_images[cam.id], "\n")));
    std::vector<std::string> args = {
        "--database_path",
        database.string(),
        "--image_path",
        images.string(),
        "--image_list_path",
        list.string(),
        "--ImageReader.camera_model",
        "PINHOLE",
        "--ImageReader.single_camera",
        "1",
        "--ImageReader.camera_params",
        fmt::format("{},{},{},{}", number(cam.params[0]), number(cam.params[1]),
                    number(cam.params[2]), number(cam.params[3]))};
    const std::vector<std::string> sift = colmap::sift_extraction_args(options);
    args.insert(args.end(), sift.begin(), sift.end());
    run_colmap(exe, "feature_extractor", args, logs, options.verbose);
  }
  std::vector<std::string> matcher = {"--database_path", database.string()};
  const std::vector<std::string> matching = colmap::exhaustive_matching_args(options);
  matcher.insert(matcher.end(), matching.begin(), matching.end());
  run_colmap(exe, "exhaustive_matcher", matcher, logs, options.verbose);
  // --clear_points 1 makes COLMAP renumber the known images by name to the database's ids.
  run_colmap(
      exe, "point_triangulator",
      {"--database_path", database.string(), "--image_path", images.string(), "--input_path",
       known.string(), "--output_path", sparse.string(), "--clear_points", "1",
       "--Mapper.num_threads", std::to_string(options.threads), "--Mapper.ba_refine_focal_length",
       "0", "--Mapper.ba_refine_principal_point", "0", "--Mapper.ba_refine_extra_params", "0",
       "--Mapper.filter_max_reproj_error", number(options.max_reprojection_error),
       // Known poses make a point seen by two cameras as good as any: keep them.
       "--Mapper.tri_ignore_two_view_tracks", "0"},
      logs, options.verbose);

  io::ColmapModel result = io::read_colmap_model(sparse);
  const std::size_t triangulated = result.points.size();
  std::map<std::uint32_t, Eigen::Vector3d> centres;  // by COLMAP image id
  for (const io::ColmapImage& image : result.images) {
    const Eigen::Matrix4d w2c = image.world_to_camera();
    centres[image.id] = -w2c.topLeftCorner<3, 3>().transpose() * w2c.topRightCorner<3, 1>();
  }
  const bool two_view = keeps_two_view_tracks(cams.size());
  std::vector<Eigen::Vector3d> track;
  std::erase_if(result.points, [&](const io::ColmapPoint& p) {
    track.clear();
    for (std::uint32_t id : p.track_images) {
      const auto it = centres.find(id);
      if (it == centres.end())
        fail("{}: point {} is seen by image {}, which the model does not have", sparse.string(),
             p.id, id);
      track.push_back(it->second);
    }
    return !keep_triangulated_point(p, track, two_view, options);
  });
  if (result.points.empty())
    fail(
        "colmap point_triangulator found no point seen by {} for frame {} ({} triangulated from "
        "{} cameras; too little texture or overlap?); logs in {}",
        two_view ? fmt::format("2 or more cameras at {} degrees or wider", kTwoViewMinAngleDegrees)
                 : fmt::format("{} or more cameras", options.min_track_length),
        frame, triangulated, cams.size(), logs.string());
  return result.point_cloud();
}

}  // namespace retimegs::prepare
