#pragma once
// The image files of a scene (io/scene.hpp; docs/formats.md): images/<camera>/<frame:05d>.png and
// the optional masks/<camera>/<frame:05d>.png, read through media/image_io.hpp. The scene.json
// side is io's, which needs no image codec.
#include <filesystem>
#include <optional>

#include "retimegs/core/image.hpp"
#include "retimegs/io/scene.hpp"

namespace retimegs::media {

enum class SceneCheck {
  kJson,   // scene.json only (io::read_scene_json)
  kFiles,  // + every image exists with its camera's size, and so has every mask that exists
};

// Reads and validates scene.json (io::read_scene_json) and, with kFiles, the sizes of the images
// and masks. Throws Error naming the file and the field at fault.
io::Scene read_scene(const std::filesystem::path& root, SceneCheck check = SceneCheck::kFiles);

// Loaders that check the size against the camera; errors name the file.
Image load_image(const io::Scene& scene, int camera, int frame);
std::optional<Image> load_mask(const io::Scene& scene, int camera, int frame);  // nullopt if absent

}  // namespace retimegs::media
