#pragma once
// The browser viewer's data (docs/formats.md, "The viewer's data"): a model, and optionally its
// scene, as one binary of texture-ready arrays (model.bin) and a JSON manifest (model.json) that
// says where each texture lies, the time grid and window settings, and the scene's cameras. The
// viewer evaluates the model at any time in its vertex shader exactly as model::slice does,
// so the manifest carries every setting slice reads.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "retimegs/io/scene.hpp"
#include "retimegs/model/model_file.hpp"

namespace retimegs::view {

// Texels per texture row. WebGL2 guarantees textures of 2048 x 2048; the SH texture of a model
// with more than 2048 x 2048 / texels_per_primitive primitives needs a larger MAX_TEXTURE_SIZE,
// which the viewer checks.
constexpr int kTextureWidth = 2048;

// One texture of the binary: RGBA texels, kTextureWidth per row, `texels_per_primitive` texels
// for each primitive (primitive i's first texel is i * texels_per_primitive, row-major).
struct PackedTexture {
  std::string name;
  bool half = false;  // RGBA16F (IEEE binary16) or RGBA32F, little-endian
  int texels_per_primitive = 1;
  int height = 0;            // rows
  std::uint64_t offset = 0;  // bytes from the start of model.bin
  std::uint64_t bytes = 0;   // kTextureWidth * height * 4 * (2 or 4)
};

struct Packed {
  std::string manifest;            // model.json
  std::vector<std::uint8_t> data;  // model.bin
  std::vector<PackedTexture> textures;
};

// The scene side of the manifest: its cameras (as the model saw them, model::seen_camera: a
// training camera through its pose correction), `up`, fps and the near plane that `retimegs
// render` uses (io::scene_near_plane).
struct PackScene {
  const io::Scene* scene = nullptr;  // nullptr: no cameras; the viewer frames the primitives
  double near_plane = 0.01;          // render::RenderOptions' default without a scene
};

// Throws Error naming the field and row of a value that a half float cannot hold (|x| > 65504).
Packed pack(const model::Model& model, const PackScene& scene);

// The viewer's data of `retimegs view` and `export --web`: the 4D model file `model_path` as
// render draws it (playback::read_4d_model), packed with the scene folder `scene_path`'s cameras
// and the near plane of its renders (playback::near_plane: --near `near` when given, else the
// scene's); no scene (empty path): no cameras, and `near` when given. Throws Error naming the
// file, or --near, on a bad model, scene or near plane.
Packed pack_for_web(const std::filesystem::path& model_path,
                    const std::filesystem::path& scene_path, const std::optional<double>& near);

// IEEE binary16 from a float, rounding to nearest even (what the GPU reads back exactly).
std::uint16_t half_from_float(float value);
float float_from_half(std::uint16_t half);

}  // namespace retimegs::view
