#include "retimegs/media/scene_images.hpp"

#include "retimegs/core/error.hpp"
#include "retimegs/media/image_io.hpp"

namespace retimegs::media {
namespace fs = std::filesystem;
using io::check_file_size;
using io::Scene;

namespace {

void check_files(const Scene& scene) {
  for (int c = 0; c < int(scene.cameras.size()); ++c) {
    const Camera& cam = scene.cameras[c];
    for (int k = 0; k < scene.num_frames; ++k) {
      const fs::path image = scene.image_path(c, k);
      if (!fs::exists(image))
        fail("{}: missing image of camera '{}' frame {} (num_frames is {})", image.string(),
             cam.name, k, scene.num_frames);
      const ImageSize size = read_image_size(image);
      check_file_size(image, cam, size.width, size.height);
      const fs::path mask = scene.mask_path(c, k);
      if (fs::exists(mask)) {
        const ImageSize msize = read_image_size(mask);
        check_file_size(mask, cam, msize.width, msize.height);
      }
    }
  }
}

}  // namespace

Scene read_scene(const fs::path& root, SceneCheck check) {
  Scene scene = io::read_scene_json(root);
  if (check == SceneCheck::kFiles) check_files(scene);
  return scene;
}

Image load_image(const Scene& scene, int camera, int frame) {
  const fs::path path = scene.image_path(camera, frame);
  Image image = read_image(path);
  check_file_size(path, scene.cameras.at(camera), image.width, image.height);
  return image;
}

std::optional<Image> load_mask(const Scene& scene, int camera, int frame) {
  const fs::path path = scene.mask_path(camera, frame);
  if (!fs::exists(path)) return std::nullopt;
  Image mask = read_mask(path);
  check_file_size(path, scene.cameras.at(camera), mask.width, mask.height);
  return mask;
}

}  // namespace retimegs::media
