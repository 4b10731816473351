// COLMAP project (sparse model + images/) -> scene format: one static frame.
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <set>

#include <fmt/format.h>

#include "import_common.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/ingest/import.hpp"
#include "retimegs/io/colmap.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/resize.hpp"

namespace retimegs::ingest {
namespace fs = std::filesystem;

namespace {

constexpr double kStaticFps = 30.0;  // a static capture has no frame rate; any positive value

fs::path find_images(const fs::path& source, const fs::path& model_dir) {
  for (const fs::path& d :
       {source / "images", model_dir / ".." / "images", model_dir / ".." / ".." / "images"})
    if (fs::is_directory(d)) return d.lexically_normal();
  fail("{}: no images/ folder beside the COLMAP model", source.string());
}

// Camera names: file stems, or the relative path without extension with '/' -> '_' when stems
// collide. Images that still share a name (a.png and a.jpg) are an error naming both: one camera
// would silently replace the other.
std::vector<std::string> camera_names(const std::vector<io::ColmapImage>& images,
                                      const std::string& what) {
  std::vector<std::string> names;
  for (const auto& im : images) names.push_back(fs::path(im.name).stem().string());
  if (std::set<std::string>(names.begin(), names.end()).size() != names.size()) {
    names.clear();
    for (const auto& im : images) {
      std::string n = fs::path(im.name).replace_extension().generic_string();
      std::replace(n.begin(), n.end(), '/', '_');
      names.push_back(n);
    }
  }
  std::map<std::string, std::size_t> first;
  for (std::size_t i = 0; i < names.size(); ++i)
    if (const auto [it, fresh] = first.emplace(names[i], i); !fresh)
      fail("{}: images '{}' and '{}' would both be camera '{}'", what, images[it->second].name,
           images[i].name, names[i]);
  return names;
}

}  // namespace

void import_colmap(const fs::path& source, const fs::path& out, const ImportOptions& options) {
  if (!fs::is_directory(source)) fail("{}: COLMAP source folder does not exist", source.string());
  check_downscale(options.downscale);
  if (options.first_frame != 0 || options.last_frame > 0)
    fail("--frames: a COLMAP model is one static frame (0:0), got {}:{}", options.first_frame,
         options.last_frame);
  const fs::path model_dir = io::find_colmap_model(source);
  io::ColmapModel model = io::read_colmap_model(model_dir);
  if (model.images.empty()) fail("{}: the COLMAP model has no images", model_dir.string());
  std::sort(model.images.begin(), model.images.end(),
            [](const io::ColmapImage& a, const io::ColmapImage& b) { return a.name < b.name; });
  const fs::path image_dir = find_images(source, model_dir);

  // One undistortion per COLMAP camera that an image uses.
  std::map<std::uint32_t, std::unique_ptr<detail::Undistorter>> undistorters;
  for (const auto& im : model.images)
    if (!undistorters.count(im.camera_id))
      undistorters[im.camera_id] = std::make_unique<detail::Undistorter>(
          model.camera(im.camera_id),
          fmt::format("{}: camera {}", (model_dir / "cameras").string(), im.camera_id));

  io::Scene scene;
  scene.num_frames = 1;
  scene.fps = kStaticFps;
  scene.calibration = io::CalibrationSource::kUser;  // a user's reconstruction: a few pixels off
  const auto names = camera_names(model.images, (model_dir / "images").string());
  for (std::size_t i = 0; i < model.images.size(); ++i) {
    const io::ColmapImage& im = model.images[i];
    Camera cam = undistorters.at(im.camera_id)->pinhole();
    cam.name = names[i];
    cam.world_to_camera = im.world_to_camera();
    check_rigid(cam.world_to_camera, fmt::format("{}: image {}", model_dir.string(), im.name));
    scene.cameras.push_back(downscaled(cam, options.downscale));
    const fs::path file = image_dir / im.name;
    if (!fs::is_regular_file(input_status(file)))
      fail("{}: missing image of the COLMAP model", file.string());
  }
  scene.up = detail::mean_camera_up(scene.cameras);

  AtomicDirectory dir(out, options.force);
  scene.root = dir.temp_path();
  detail::parallel_jobs(
      model.images.size(), model.images.size(), "import colmap", options.progress,
      [&](std::size_t i, Progress& progress) {
        const io::ColmapImage& im = model.images[i];
        const io::ColmapCamera& source_camera = model.camera(im.camera_id);
        const fs::path file = image_dir / im.name;
        const Image image = media::read_image(file);
        if (image.width != source_camera.width || image.height != source_camera.height)
          fail("{}: image is {}x{} but COLMAP camera {} is {}x{}", file.string(), image.width,
               image.height, im.camera_id, source_camera.width, source_camera.height);
        const Camera& cam = scene.cameras[i];
        media::write_png(
            scene.image_path(int(i), 0),
            media::resize_area(undistorters.at(im.camera_id)->apply(image), cam.width, cam.height));
        progress.tick();
      });
  if (!model.points.empty()) io::write_points_ply(scene.points_path(0), model.point_cloud());
  io::write_scene_json(scene);
  dir.commit();
}

}  // namespace retimegs::ingest
