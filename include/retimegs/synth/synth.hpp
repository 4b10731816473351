#pragma once
// Procedural multi-view dynamic test scenes (`retimegs synth`), rendered by an analytic ray caster
// that shares no code with the splat renderer. Writes a complete scene in the scene format:
// supersampled images, foreground masks, exact flows (strides 1 and 2, both directions, unknown
// where occluded or out of view) and per-frame surface point clouds.
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "retimegs/io/perturb_calibration.hpp"

namespace retimegs::synth {

struct SynthOptions {
  std::string preset = "default";  // see synth_presets()
  int cameras = 8;
  int frames = 17;
  int width = 256, height = 192;
  std::uint64_t seed = 0;
  double fps = 24.0;
  int supersample = 2;  // per axis: 2 -> 2x2 rays per pixel
  // Per-camera clock offsets by camera name (synth --time-offsets): that camera's frame k, its mask
  // and its flows show the scene at t = k + offset (its flows run between two of its own frames);
  // scene.json records them as the cameras' time_offset unless record_offsets is false (the same
  // footage as a user has it who never measured the offsets). Points stay at t = k.
  std::map<std::string, double> time_offsets;
  bool record_offsets = true;
  // synth --perturb-calibration: the images are rendered with the true cameras, scene.json holds
  // them perturbed by these amounts (io::perturb_calibration, drawn from `seed`; calibration
  // "user") and io::kTrueCalibrationFile beside it the true ones, so that tests know the answer.
  std::optional<io::CalibrationPerturbation> perturb_calibration;
  bool force = false;  // replace an existing output folder
  bool progress = true;
};

struct SynthPreset {
  std::string name, description;
};
const std::vector<SynthPreset>& synth_presets();

// Writes the scene to `out` atomically (a temporary folder renamed at the end). Throws Error on
// bad options (unknown preset, sizes < 8, frames < 2, ...) naming the option and value.
void synthesize_scene(const SynthOptions& options, const std::filesystem::path& out);

}  // namespace retimegs::synth
