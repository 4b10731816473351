#pragma once
// A training checkpoint folder, the same for every device: model.rgs (with the camera colours),
// state.json (iteration, generator, active SH degree, each optimiser's step count),
// adam/<name>_{m,v}.npy, each optimiser's moments as [rows, width] float32, and manifest.json,
// written last: the iteration and each other file's size and FNV-1a 64 hash, which ties the files
// to one step (a file copied from another checkpoint, truncated or missing is refused).
#include <filesystem>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "retimegs/model/model_file.hpp"
#include "retimegs/train/adam.hpp"

namespace retimegs::train {

// The optimisers of a checkpoint by name (a primitive field, or "camera_color").
using NamedAdams = std::vector<std::pair<std::string, const Adam*>>;

constexpr const char* kCameraColorAdam = "camera_color";
constexpr const char* kCameraPoseAdam = "camera_pose";
constexpr const char* kCameraClockAdam = "camera_clock";

// Writes the folder `dir` atomically (core/atomic_file.hpp), replacing an older one. The active SH
// degree is model.config.sh_degree.
void write_checkpoint(const std::filesystem::path& dir, const model::Model& model, int iteration,
                      const std::mt19937_64& rng, const NamedAdams& optimizers);

// Writes dir/manifest.json for the files now under `dir` (write_checkpoint's last file).
void write_checkpoint_manifest(const std::filesystem::path& dir, int iteration);
// The iteration of dir/manifest.json once every file it lists is there with its size and hash and
// no other file is; throws Error naming the checkpoint and the file otherwise, and when the
// manifest is missing (a checkpoint of an older retimegs: it cannot be verified).
int verify_checkpoint_manifest(const std::filesystem::path& dir);

// A checkpoint read back: the model (its config.sh_degree that of the state), the iteration and
// the generator; the optimisers are read on demand into Adams of the expected shape.
class Checkpoint {
 public:
  // Verifies the manifest first; throws Error naming the file and the key on a missing or
  // malformed part, and when the checkpoint's time grid is not `grid` (resuming with another
  // --window or --train-frames).
  Checkpoint(const std::filesystem::path& dir, const model::TimeGrid& grid);

  model::Model model;
  int iteration = 0;
  std::mt19937_64 rng;

  // Reads optimiser `name` into `adam`, which has the expected shape; Error naming the folder or
  // the state file when the files do not match it.
  void read_adam(const std::string& name, Adam& adam) const;

 private:
  std::filesystem::path dir_, state_file_;
  nlohmann::json state_;
};

}  // namespace retimegs::train
