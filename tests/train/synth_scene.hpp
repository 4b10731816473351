#pragma once
// A small 5-frame "minimal" synthetic scene (exact flows, masks, points) for the train tests.
#include <filesystem>

#include "retimegs/io/scene.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/synth/synth.hpp"

namespace retimegs::train {

inline io::Scene minimal_scene(const std::filesystem::path& root, int cameras, int width,
                               int height) {
  synth::SynthOptions options;
  options.preset = "minimal";
  options.cameras = cameras;
  options.frames = 5;
  options.width = width, options.height = height;
  options.progress = false;
  synth::synthesize_scene(options, root);
  return media::read_scene(root);
}

}  // namespace retimegs::train
