#pragma once
// A small 5-frame "minimal" synthetic scene (exact flows, masks, points) for the train tests.
#include <filesystem>

#include "retimegs/data/scene.hpp"
#include "retimegs/data/synth.hpp"

namespace retimegs::train {

inline data::Scene minimal_scene(const std::filesystem::path& root, int cameras, int width,
                                 int height) {
  data::SynthOptions options;
  options.preset = "minimal";
  options.cameras = cameras;
  options.frames = 5;
  options.width = width, options.height = height;
  options.progress = false;
  data::synthesize_scene(options, root);
  return data::read_scene(root);
}

}  // namespace retimegs::train
